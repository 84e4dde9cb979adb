"""The C-ADMM methods' round work vectors are lent per round (agents/consensus/scratch.py): a
round's result does not depend on the set it gets, rounds running at once get different sets,
and a team computed one round at a time allocates one set, not one per robot."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.consensus import ConsensusConfig, make_method
from ramensim.agents.consensus.scratch import POOL
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.toy import make_least_squares

N = 3000


def _rounds(name: str, visits_dtype: torch.dtype, poison: bool) -> tuple[torch.Tensor, torch.Tensor]:
    """Three rounds of agent 0 against a moving copy of agent 1; with ``poison`` every free set
    of the pool is filled with NaN (ints with -1) before each round."""
    prob = make_least_squares(2, N, 40, np.random.default_rng(3))
    lr = prob.learner(0)
    lr._visits = lr._visits.to(visits_dtype)
    m = make_method(name, ConsensusConfig(primal_steps=2), N)
    g = torch.Generator().manual_seed(5)
    for r in range(3):
        lr._visits += torch.randint(0, 3, (N,), generator=g, dtype=visits_dtype)
        copy = NeighbourCopy(1, {"theta": prob.theta0 + 0.1 * torch.randn(N, generator=g),
                                 "visits": torch.randint(0, 9, (N,), generator=g, dtype=visits_dtype),
                                 "lam": 0.01 * torch.randn(N, generator=g)}, float(r), float(r))
        if poison:
            with POOL._lock:
                for sets in POOL._free.values():
                    for bufs in sets:
                        for t in bufs.values():
                            t.fill_(float("nan") if t.is_floating_point() else -1)
        m.round(lr, [copy], 1)
    assert "_lent" not in m.__dict__  # given back at the round's end
    return lr.theta.clone(), m.p.clone()


@pytest.mark.parametrize("name", ["ramen", "dinno"])
@pytest.mark.parametrize("visits_dtype", [torch.int32, torch.int64])  # the edge kernel's path and torch's
def test_a_rounds_result_does_not_depend_on_the_set_it_gets(name, visits_dtype):
    theta_a, p_a = _rounds(name, visits_dtype, poison=False)
    theta_b, p_b = _rounds(name, visits_dtype, poison=True)
    assert torch.isfinite(theta_b).all() and torch.isfinite(p_b).all()
    assert torch.equal(theta_a, theta_b) and torch.equal(p_a, p_b)


def test_rounds_at_once_get_different_sets_and_a_set_is_reused():
    cfg = ConsensusConfig(primal_steps=1)
    a, b, c = (make_method("ramen", cfg, 2048, agent=k) for k in range(3))
    a._take_scratch()
    b._take_scratch()
    assert a._c.data_ptr() != b._c.data_ptr() and a._h.data_ptr() != b._h.data_ptr()
    ptr = a._c.data_ptr()
    a._give_scratch()
    assert "_c" not in a.__dict__
    c._take_scratch()
    assert c._c.data_ptr() == ptr  # a's set, lent again
    b._give_scratch()
    c._give_scratch()
    assert a._theta_t.numel() == 2048  # touched outside a round: lent again on demand
    a._give_scratch()


def test_a_team_one_round_at_a_time_allocates_one_set():
    prob = make_least_squares(12, 1024, 8, np.random.default_rng(0))
    cfg = ConsensusConfig(primal_steps=1)
    methods = [make_method("ramen", cfg, 1024, agent=k) for k in range(12)]
    learners = [prob.learner(k) for k in range(12)]
    before = POOL.made
    for _ in range(2):
        for k, (m, lr) in enumerate(zip(methods, learners)):
            j = (k + 1) % 12
            copy = NeighbourCopy(j, {"theta": learners[j].theta.clone(), "visits": learners[j].visits.clone()}, 0.0, 0.0)
            m.round(lr, [copy], 1)
    assert POOL.made - before <= 1
