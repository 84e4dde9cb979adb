"""The step's loss and gradient (agents/map/step.py: L_obj, eq. 5-6, plus the smoothness term)
checked against what they must be rather than against another implementation: the gradient
against central finite differences of the returned loss on the same draws, and the loss against
its terms computed by hand (numpy, from the map's own field queried at the drawn samples). Each
check runs on a map's own C kernels, its torch path, and the team's batched torch pass."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, _native, synthetic
from ramensim.agents.map.decoders import init_decoders
from ramensim.agents.map.hashgrid import encode_torch
from ramensim.agents.map.team_batch import team_loss_and_grad

TINY = dict(n_levels=4, log2_hashmap_size=10, n_rays=48, n_stratified=6, n_surface=3, smooth_lattice=4,
            geo_hidden=16, color_hidden=16, geo_feat_dim=7, oneblob_bins=4, smooth_weight=1e-2)
FORMS = ["map-c", "map-torch", "team"]
NONE = dict(rgb_weight=0.0, depth_weight=0.0, sdf_weight=0.0, fs_weight=0.0, smooth_weight=0.0)
TERMS = {"all": {}, "rgb": {**NONE, "rgb_weight": 1.0}, "depth": {**NONE, "depth_weight": 1.0},
         "sdf": {**NONE, "sdf_weight": 1.0}, "fs": {**NONE, "fs_weight": 1.0}, "smooth": {**NONE, "smooth_weight": 1.0}}
"""Loss weights: the map's own (sdf dominates), or one term alone, so that each term's gradient is checked."""


def _maps(form: str, train: bool = True, **weights) -> list[NeuralMap]:
    if form == "map-c" and _native.get_lib() is None:
        pytest.skip("the C kernels did not build here")
    cfg = MapConfig(**{**TINY, **weights}, native=(form == "map-c"))
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    maps = []
    for r in range(3 if form == "team" else 1):
        m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1),
                      torch.Generator().manual_seed(10 + r))
        if r != 1:  # in the team, robot 1 has no frame yet: zero loss and gradient
            for i, f in enumerate(synthetic.frames(3, 40, 30, phase=0.7 * r)):
                m.add_frame(f, keyframe=(i % 2 == 0))
        for _ in range((2 + r) * train):  # trained a little: an SDF with surfaces, unlike the initial table
            m.optimizer_step(m.loss_and_grad()[1])
        maps.append(m)
    return maps


def _step(form: str, maps: list[NeuralMap], states: list[torch.Tensor]) -> list[tuple[dict, torch.Tensor]]:
    """One step of every map from the given generator states (so: the same draws each time)."""
    for m, s in zip(maps, states):
        m.gen.set_state(s)
    out = team_loss_and_grad(maps) if form == "team" else [maps[0].loss_and_grad()]
    return [(s, g.clone()) for s, g in out]


STEPS = (0.05, 0.03, 0.02, 0.012, 0.007)
"""Finite-difference steps along a direction v: this share of theta's largest entry (v scaled to max 1)."""


@pytest.mark.parametrize("form, term", [(f, t) for f in FORMS for t in TERMS
                                        if f == "map-c" or t not in ("rgb", "depth")])
def test_gradient_is_the_loss_derivative(form: str, term: str) -> None:
    """Directional derivatives of the loss (central differences, same draws) along the returned
    gradient g and along g's signs with random weights u equal <g, g> and <g, u> within 1 %.

    The loss is piecewise smooth: the rendering weights are cut behind the first sign change of
    the SDF, so a step that moves a sign change jumps. Of the ``STEPS``, the first two in a row
    that agree (no cut crossed) count. On the torch forms the rgb and depth terms are summed in
    float32, whose rounding swamps the difference at steps small enough to cross no cut, so they
    are checked on the C kernels only (double sums); on the torch forms their values are checked
    by hand below and their gradient is autograd of that value through the decoder and grid
    backward that the other terms check here."""
    maps = _maps(form, **TERMS[term])
    states = [m.gen.get_state() for m in maps]
    base = _step(form, maps, states)
    theta0 = [m.theta.clone() for m in maps]
    gen = torch.Generator().manual_seed(3)
    checked = 0
    for b, (m, (s, g)) in enumerate(zip(maps, base)):
        if float(g.abs().max()) == 0.0:
            assert s["loss"] == 0.0 and not m.has_data  # the robot without a frame
            continue
        for v in (g, torch.rand(g.shape, generator=gen) * g.sign()):
            exact = float(torch.dot(g.double(), v.double()))
            central = []
            for rel in STEPS:
                eps = rel * float(theta0[b].abs().max()) / float(v.abs().max())
                up, down = (_loss_moved(form, maps, states, b, theta0[b], v, sign * eps) for sign in (1, -1))
                central.append((up - down) / (2 * eps))
            pairs = [k for k in range(len(STEPS) - 1) if abs(central[k] - central[k + 1]) <= 1e-2 * abs(exact)]
            assert pairs, (form, term, b, "a cut of the rendering weights within every step", central, exact)
            assert central[pairs[0] + 1] == pytest.approx(exact, rel=1e-2), (form, term, b, central, exact)
            checked += 1
    assert checked >= 2


def _loss_moved(form: str, maps: list[NeuralMap], states, b: int, theta: torch.Tensor, v: torch.Tensor,
                eps: float) -> float:
    """Map b's loss at theta + eps v (the other maps as they are), from the same draws."""
    maps[b].theta.copy_(theta).add_(v, alpha=eps)
    loss = _step(form, maps, states)[b][0]["loss"]
    maps[b].theta.copy_(theta)
    return loss


def _by_hand(m: NeuralMap, draw) -> dict[str, float]:
    """Eq. 5-6 and the smoothness term in numpy (float64) from the map's field at the draw."""
    cfg, tr = m.cfg, m.cfg.truncation
    lo, ext = m.lo.cpu().double().numpy(), m.extent.cpu().double().numpy()
    xn = draw.xn.cpu().double().numpy()
    sdf_m, col = m.sdf_and_color(lo + xn * ext)                   # metres, colour in [0, 1]
    z, rays = draw.z.double().numpy(), draw.rays.double().numpy()
    R, S = z.shape
    s = sdf_m.astype(np.float64).reshape(R, S) / tr                # truncation units
    col = col.astype(np.float64).reshape(R, S, 3)
    # rendering weights: sigmoid(s/tr) sigmoid(-s/tr), cut a truncation behind the first sign change
    sig = 1.0 / (1.0 + np.exp(-s / tr))
    w = sig * (1.0 - sig)
    change = s[:, 1:] * s[:, :-1] < 0
    first = np.where(change.any(axis=1), change.argmax(axis=1), 0)
    w = w * (z < z[np.arange(R), first][:, None] + tr)
    w = w / (w.sum(axis=1, keepdims=True) + 1e-8)
    rgb, depth = (w[..., None] * col).sum(axis=1), (w * z).sum(axis=1)
    D = rays[:, 9]
    ok = D > 0
    terms = {"rgb": float(np.mean((rgb[ok] - rays[ok, 6:9]) ** 2)),           # eq. 5
             "depth": float(np.mean((depth[ok] - D[ok]) ** 2))}
    front = z < D[:, None] - tr
    band = ~front & ~(z > D[:, None] + tr) & ok[:, None]
    n_f, n_b = front.sum(), band.sum()
    terms["fs"] = float((1 - n_f / (n_f + n_b)) * np.mean((s * front - front) ** 2))               # eq. 6
    terms["sdf"] = float((1 - n_b / (n_f + n_b)) * np.mean(((z + s * tr - D[:, None]) * band) ** 2))
    n = cfg.smooth_lattice
    f = encode_torch(draw.lattice, m.theta, m.spec).double().numpy().reshape(n, n, n, -1)
    terms["smooth"] = float((np.sum(np.diff(f, axis=0) ** 2) + np.sum(np.diff(f, axis=1) ** 2)
                             + np.sum(np.diff(f, axis=2) ** 2)) / n ** 3)
    terms["loss"] = (cfg.rgb_weight * terms["rgb"] + cfg.depth_weight * terms["depth"] + cfg.sdf_weight
                     * terms["sdf"] + cfg.fs_weight * terms["fs"] + cfg.smooth_weight * terms["smooth"])
    return terms


@pytest.mark.parametrize("form", FORMS)
def test_loss_is_eq_5_6_by_hand(form: str) -> None:
    """The returned loss and terms equal eq. 5-6 and the smoothness term written out in numpy
    from the same draws, with the SDF and colour read through the map's query path."""
    maps = _maps(form)
    states = [m.gen.get_state() for m in maps]
    draws = []
    for m, s in zip(maps, states):
        m.gen.set_state(s)
        draws.append(m.draw_step(native=False))
    got = _step(form, maps, states)
    for m, d, (s, _) in zip(maps, draws, got):
        if d is None:
            assert s == {k: 0.0 for k in s}
            continue
        want = _by_hand(m, d)
        assert s.keys() == want.keys()
        for key in want:
            assert s[key] == pytest.approx(want[key], rel=1e-3, abs=1e-9), (form, key)
        assert s["loss"] > 0 and s["sdf"] > 0 and s["fs"] > 0


@pytest.mark.parametrize("observation_only", [True, False])
@pytest.mark.parametrize("form", FORMS)
def test_visits_count_where_the_gradient_is_not_zero(form: str, observation_only: bool) -> None:
    """Eq. 18: a step adds 1 to u_i where the gradient of the observation terms is not zero (the
    paper), or where the whole gradient, smoothness included, is not zero (the authors' code).
    The observation terms' gradient is the step's with the smoothness weight 0 (same draws)."""
    with_smooth, without = _maps(form, train=False), _maps(form, train=False, smooth_weight=0.0)
    for m in with_smooth:
        m.count_observation_only = observation_only
    got = _step(form, with_smooth, [m.gen.get_state() for m in with_smooth])
    obs = _step(form, without, [m.gen.get_state() for m in without])
    for m, (_, g), (_, g_obs) in zip(with_smooth, got, obs):
        counted = g_obs if observation_only else g
        assert torch.equal(m.visits, (counted != 0).to(torch.int32))
        assert m.has_data == bool(m.visits.any())
    assert not torch.equal(got[0][1] != 0, obs[0][1] != 0)  # the smoothness term touches other entries
