"""The weighted consensus error (eq. CE-2, ``weights.weighted_consensus_error``) against the
unweighted one (CE-1, ``evaluation.summary.consensus_error``) and a hand computation."""
from __future__ import annotations

import math

import pytest
import torch

from ramensim.agents.consensus.weights import edge_weights, weighted_consensus_error
from ramensim.evaluation.summary import consensus_error


def _thetas(m: int, n: int, seed: int = 0) -> list[torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    return [torch.randn(n, generator=g) for _ in range(m)]


@pytest.mark.parametrize("m", [2, 3, 5])
def test_equal_weights_give_the_unweighted_error(m: int) -> None:
    th = _thetas(m, 1000)
    zero = [torch.zeros(1000, dtype=torch.int32) for _ in range(m)]  # no visits: w = beta_u everywhere
    same = [torch.full((1000,), 7, dtype=torch.int32) for _ in range(m)]
    for visits in (zero, same):
        assert weighted_consensus_error(th, visits, 1e-7, 1e-4) == pytest.approx(consensus_error(th), rel=1e-6)


def test_matches_a_hand_computation_with_eq19_weights() -> None:
    th = _thetas(3, 64, seed=1)
    g = torch.Generator().manual_seed(2)
    visits = [torch.randint(0, 50, (64,), generator=g, dtype=torch.int32) for _ in range(3)]
    num = den = 0.0
    for i in range(3):
        for j in range(i + 1, 3):
            wi, wj = edge_weights(visits[i], visits[j], 1e-7, 1e-4, torch.empty(64), torch.empty(64))
            wbar = (wi.double() + wj.double()) / 2
            num += float((wbar * (th[i].double() - th[j].double()) ** 2).sum())
            den += float(wbar.sum())
    assert weighted_consensus_error(th, visits, 1e-7, 1e-4) == pytest.approx(math.sqrt(num / den), rel=1e-5)


def test_unobserved_disagreement_barely_counts() -> None:
    """Maps that agree where they were observed and differ only where nobody looked: the
    unweighted error sees the difference, the weighted one (beta_l / beta_u = 1/1000) hardly."""
    n = 2000
    a = torch.zeros(n)
    b = torch.zeros(n)
    b[1000:] = 1.0  # differ on the second half only
    seen = torch.zeros(n, dtype=torch.int32)
    seen[:1000] = 100
    unweighted = consensus_error([a, b])
    weighted = weighted_consensus_error([a, b], [seen, seen], 1e-7, 1e-4)
    assert unweighted == pytest.approx(math.sqrt(0.5))
    # eq. 19 over u_i + u_j in [0, 200]: unseen w = beta_l, seen w = (beta_u - beta_l) / 2 + beta_l
    w_seen = (1e-4 - 1e-7) / 2 + 1e-7
    assert weighted == pytest.approx(math.sqrt(1e-7 / (1e-7 + w_seen)), rel=1e-4)
    assert weighted < unweighted / 10


def test_bad_input_is_named() -> None:
    th = _thetas(2, 10)
    with pytest.raises(ValueError, match="visit"):
        weighted_consensus_error(th, [torch.zeros(10, dtype=torch.int32)], 1e-7, 1e-4)
    with pytest.raises(ValueError, match="same"):
        weighted_consensus_error(th, [torch.zeros(10, dtype=torch.int32), torch.zeros(9, dtype=torch.int32)], 1e-7, 1e-4)
    assert weighted_consensus_error(th[:1], [torch.zeros(10, dtype=torch.int32)], 1e-7, 1e-4) == 0.0
