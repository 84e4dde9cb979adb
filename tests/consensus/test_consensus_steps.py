"""DSGD/DSGT local-step variants: 'adam' = mix, then the learner's optimiser step with the
gradient at the pre-mix parameters (DSGD) or the mixed tracker (DSGT); 'plain' = textbook."""
from __future__ import annotations

import numpy as np
import torch

from ramensim.agents.consensus import ConsensusConfig, make_method
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.toy import make_least_squares


def _setup(method: str, step: str):
    prob = make_least_squares(2, 6, 10, np.random.default_rng(3))
    cfg = ConsensusConfig.model_validate({method: {"alpha": 0.2, "step": step}})
    a, b = prob.learner(0, optimizer="adam", lr=0.05), prob.learner(1, optimizer="adam", lr=0.05)
    with torch.no_grad():
        b.theta.add_(0.3)
    ma, mb = make_method(method, cfg, prob.n, degree=1), make_method(method, cfg, prob.n, degree=1)
    copy = NeighbourCopy(1, mb.payload(b), 0.0, 0.0)
    return prob, a, ma, copy


def test_dsgd_adam_step_is_mix_then_optimizer_step() -> None:
    prob, a, m, copy = _setup("dsgd", "adam")
    ref = prob.learner(0, optimizer="adam", lr=0.05)
    _, g = ref.loss_and_grad()
    g = g.clone()
    with torch.no_grad():
        ref.theta.copy_(0.5 * ref.theta + 0.5 * copy.theta)
    ref.optimizer_step(g)
    m.round(a, [copy], 1)
    assert torch.allclose(a.theta, ref.theta, atol=1e-7)


def test_dsgd_plain_step_ignores_the_optimizer() -> None:
    prob, a, m, copy = _setup("dsgd", "plain")
    theta0 = a.theta.clone()
    _, g = prob.learner(0).loss_and_grad()
    m.round(a, [copy], 1)
    expected = 0.5 * theta0 + 0.5 * copy.theta - 0.2 * g
    assert torch.allclose(a.theta, expected, atol=1e-6)


def test_dsgt_adam_step_moves_along_the_mixed_tracker() -> None:
    prob, a, m, copy = _setup("dsgt", "adam")
    y_self = m.y.clone() if m.started else prob.learner(0).loss_and_grad()[1].clone()
    ref = prob.learner(0, optimizer="adam", lr=0.05)
    with torch.no_grad():
        ref.theta.copy_(0.5 * ref.theta + 0.5 * copy.theta)
    ref.optimizer_step(0.5 * y_self + 0.5 * copy.tensors["y"])
    m.round(a, [copy], 1)
    assert torch.allclose(a.theta, ref.theta, atol=1e-6)
