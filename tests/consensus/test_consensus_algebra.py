"""Exact algebra of the C-ADMM methods: RAMEN == DiNNO with equal weights, eq. 19 weights,
and the analytic consensus gradient against autograd on eq. 16."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.consensus import ConsensusConfig, DinnoMethod, RamenMethod, edge_weights, make_method
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.toy import make_least_squares


def _copies(problem, rng, k, with_visits=True):
    out = []
    for j in range(k):
        theta = problem.theta0 + torch.from_numpy(rng.standard_normal(problem.n)).float()
        visits = torch.from_numpy(rng.integers(0, 50, problem.n))
        out.append(NeighbourCopy(j + 1, {"theta": theta, "visits": visits}, 0.0, 0.0))
    return out


@pytest.mark.parametrize("optimizer", ["sgd", "adam"])
def test_ramen_with_equal_weights_is_dinno(optimizer):
    rng = np.random.default_rng(3)
    prob = make_least_squares(3, 40, 25, rng, hidden_fraction=0.0)
    rho = 0.05
    # beta_l == beta_u == rho makes every RAMEN weight exactly rho (eq. 19 with eps = 0).
    ramen = RamenMethod(prob.n, 10, beta_l=rho, beta_u=rho)
    dinno = DinnoMethod(prob.n, 10, rho=rho)
    la = prob.learner(0, optimizer=optimizer, lr=0.05)
    lb = prob.learner(0, optimizer=optimizer, lr=0.05)
    for r in range(5):
        copies = _copies(prob, rng, 2)
        sa = ramen.round(la, copies, 2)
        sb = dinno.round(lb, copies, 2)
        assert torch.allclose(la.theta, lb.theta, rtol=1e-5, atol=1e-6), r
        assert torch.allclose(ramen.p, dinno.p, rtol=1e-5, atol=1e-7), r
        assert sa.scalars["aug_objective"] == pytest.approx(sb.scalars["aug_objective"], rel=1e-5)
        assert sa.scalars["dual_norm"] == pytest.approx(sb.scalars["dual_norm"], rel=1e-5)
        assert sa.scalars["mean_weight"] == pytest.approx(rho)


def test_ramen_uniform_visits_gives_dinno_weights():
    # max(u_sum) == min(u_sum): w = beta_u = rho everywhere, whatever beta_l.
    n = 16
    u = torch.full((n,), 7, dtype=torch.int64)
    wi, wj = torch.empty(n), torch.empty(n)
    edge_weights(u, u, 1e-7, 1e-4, wi, wj)
    assert torch.all(wi == torch.tensor(1e-4, dtype=torch.float32))
    assert torch.all(wj == wi)


def test_weights_symmetric_and_bounded():
    rng = np.random.default_rng(0)
    n = 1000
    for _ in range(20):
        ui = torch.from_numpy(rng.integers(0, 100, n))
        uj = torch.from_numpy(rng.integers(0, 100, n))
        bl, bu = 1e-7, 1e-4
        wij, wji = torch.empty(n), torch.empty(n)
        wji_b, wij_b = torch.empty(n), torch.empty(n)
        edge_weights(ui, uj, bl, bu, wij, wji)  # computed by i
        edge_weights(uj, ui, bl, bu, wji_b, wij_b)  # computed by j from the same copies
        assert torch.equal(wij, wij_b) and torch.equal(wji, wji_b)
        lo, hi = torch.tensor(bl, dtype=torch.float32), torch.tensor(bu, dtype=torch.float32)
        assert bool(((wij >= lo) & (wij <= hi)).all()) and bool(((wji >= lo) & (wji <= hi)).all())


def test_weights_known_values_and_clamp():
    # u_i = [0, 2, 4], u_j = [0, 2, 0]: u_sum = [0, 4, 4], eps = (1 - 0.1)/4, zeta = 0.1
    ui = torch.tensor([0, 2, 4])
    uj = torch.tensor([0, 2, 0])
    wi, wj = torch.empty(3), torch.empty(3)
    edge_weights(ui, uj, 0.1, 1.0, wi, wj)
    assert torch.allclose(wi, torch.tensor([0.1, 0.55, 1.0]))
    assert torch.allclose(wj, torch.tensor([0.1, 0.55, 0.1]))
    # min(u_sum) > 0: raw formula gives zeta - ... < beta_l for an unvisited own entry -> clamped
    ui = torch.tensor([10, 0, 10])
    uj = torch.tensor([0, 20, 30])  # u_sum = [10, 20, 40]; eps = 0.9/30, zeta = 0.1 - 0.3 = -0.2
    edge_weights(ui, uj, 0.1, 1.0, wi, wj)
    assert torch.allclose(wi, torch.tensor([0.1, 0.1, 0.1]))  # raw 0.1, -0.2, 0.1
    assert torch.allclose(wj, torch.tensor([0.1, 0.4, 0.7]))  # raw -0.2, 0.4, 0.7


def test_edge_weights_rejects_bad_bounds():
    u = torch.zeros(3, dtype=torch.int64)
    with pytest.raises(ValueError, match="beta_l"):
        edge_weights(u, u, 1.0, 0.5, torch.empty(3), torch.empty(3))


def test_ramen_dual_and_gradient_match_equations():
    """p update against eq. 17 written out, and the primal gradient against autograd of eq. 16."""
    rng = np.random.default_rng(5)
    prob = make_least_squares(2, 30, 20, rng, hidden_fraction=0.3)
    lr = prob.learner(0, optimizer="sgd", lr=0.0)  # lr 0: theta stays theta^t
    lr.loss_and_grad()  # some visits
    bl, bu = 1e-3, 1e-1
    m = RamenMethod(prob.n, 1, beta_l=bl, beta_u=bu)
    copies = _copies(prob, rng, 2)
    theta_t = lr.theta.clone()
    visits_t = lr.visits.clone()  # u_i as the round saw it (loss_and_grad updates it afterwards)
    m.round(lr, copies, 2)
    # reference, eq. 14, 17 and the gradient of eq. 16 by autograd
    p_ref = torch.zeros(prob.n, dtype=torch.float64)
    theta = theta_t.double().clone().requires_grad_(True)
    penalty = 0.0
    for c in copies:
        wi, wj = torch.empty(prob.n), torch.empty(prob.n)
        edge_weights(visits_t, c.tensors["visits"], bl, bu, wi, wj)
        wi, wj, thj = wi.double(), wj.double(), c.theta.double()
        z = (wi * theta_t.double() + wj * thj) / (wi + wj)  # eq. 14
        p_ref += 2 * wi * wj / (wi + wj) * (theta_t.double() - thj)  # eq. 17
        penalty = penalty + (wi * (theta - z) ** 2).sum()
    assert torch.allclose(m.p.double(), p_ref, rtol=1e-5, atol=1e-9)
    aug = theta @ p_ref + penalty
    (g_ref,) = torch.autograd.grad(aug, theta)
    # analytic consensus gradient at a perturbed theta
    theta2 = theta_t + 0.3 * torch.from_numpy(rng.standard_normal(prob.n)).float()
    g = torch.zeros(prob.n)
    m._add_consensus_grad(g, theta2)
    theta_p = theta2.double().clone().requires_grad_(True)
    pen2 = theta_p @ p_ref
    for c in copies:
        wi, wj = torch.empty(prob.n), torch.empty(prob.n)
        edge_weights(visits_t, c.tensors["visits"], bl, bu, wi, wj)
        wi, wj, thj = wi.double(), wj.double(), c.theta.double()
        z = (wi * theta_t.double() + wj * thj) / (wi + wj)
        pen2 = pen2 + (wi * (theta_p - z) ** 2).sum()
    (g_ref2,) = torch.autograd.grad(pen2, theta_p)
    assert torch.allclose(g.double(), g_ref2, rtol=1e-4, atol=1e-7)
    assert g_ref.shape == g.shape


def test_dinno_gradient_matches_eq9():
    rng = np.random.default_rng(6)
    prob = make_least_squares(2, 25, 20, rng)
    lr = prob.learner(0, optimizer="sgd", lr=0.0)
    rho = 0.2
    m = DinnoMethod(prob.n, 1, rho)
    copies = _copies(prob, rng, 3)
    theta_t = lr.theta.clone()
    m.round(lr, copies, 3)
    p_ref = sum(rho * (theta_t.double() - c.theta.double()) for c in copies)
    assert torch.allclose(m.p.double(), p_ref, rtol=1e-5, atol=1e-8)
    theta2 = theta_t + torch.from_numpy(rng.standard_normal(prob.n)).float()
    g = torch.zeros(prob.n)
    m._add_consensus_grad(g, theta2)
    ref = p_ref + sum(2 * rho * (theta2.double() - (theta_t.double() + c.theta.double()) / 2) for c in copies)
    assert torch.allclose(g.double(), ref, rtol=1e-5, atol=1e-6)


def test_no_copies_round_is_local_plus_dual():
    rng = np.random.default_rng(7)
    prob = make_least_squares(1, 10, 20, rng)
    cfg = ConsensusConfig(primal_steps=4)
    a, b = prob.learner(0, lr=0.1), prob.learner(0, lr=0.1)
    s = make_method("ramen", cfg, prob.n).round(a, [], 0)
    make_method("local", cfg, prob.n).round(b, [], 0)
    assert torch.equal(a.theta, b.theta)
    assert s.copies_used == 0 and s.scalars["primal_residual"] == 0.0 and not s.diverged
