"""NeuralMap as a Learner: visits (eq. 18), determinism, Adam, queries, state."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.learner import Learner
from ramensim.agents.map import MapConfig, NeuralMap, load_decoders, save_decoders
from ramensim.agents.map import synthetic
from ramensim.agents.map.decoders import init_decoders

SMALL = dict(log2_hashmap_size=12, n_rays=128, n_stratified=12, n_surface=4, smooth_lattice=6)


@pytest.fixture(scope="module")
def frames():
    return synthetic.frames(6, 40, 30)


def make(frames, seed_init=0, seed_samp=1, native=True, **kw):
    cfg = MapConfig(**{**SMALL, "native": native, **kw})
    dec = init_decoders(cfg, torch.Generator().manual_seed(42))
    m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(seed_init),
                  torch.Generator().manual_seed(seed_samp))
    for i, f in enumerate(frames):
        m.add_frame(f, keyframe=(i % 2 == 0))
    return m


def test_is_a_learner(frames):
    m = make(frames)
    assert isinstance(m, Learner)
    assert m.theta.dtype == torch.float32 and m.theta.shape == (m.n_params,)
    assert m.n_params == 16 * 2 ** 12 * 2
    assert float(m.theta.abs().max()) <= 1e-4


def test_same_init_seed_same_theta(frames):
    assert torch.equal(make(frames, 0, 1).theta, make(frames, 0, 2).theta)
    assert not torch.equal(make(frames, 0, 1).theta, make(frames, 3, 1).theta)


def test_visits_count_only_observation_losses(frames):
    a = make(frames, smooth_weight=1.0)
    b = make(frames, smooth_weight=0.0)
    _, ga = a.loss_and_grad()
    ga = ga.clone()
    _, gb = b.loss_and_grad()
    assert torch.equal(a.visits, b.visits)  # smoothness does not count
    assert torch.equal(b.visits, (gb != 0).to(torch.int32))
    assert int(((ga != 0) & (a.visits == 0)).sum()) > 0  # smoothness-only entries exist
    for _ in range(3):
        b.loss_and_grad()
    assert int(b.visits.max()) == 4 and int(b.visits.min()) == 0


def test_determinism_same_seeds_identical_theta(frames):
    runs = []
    for _ in range(2):
        m = make(frames)
        for _ in range(4):
            s, g = m.loss_and_grad()
            m.optimizer_step(g)
        runs.append((m.theta.clone(), m.visits.clone(), s))
    assert torch.equal(runs[0][0], runs[1][0]) and torch.equal(runs[0][1], runs[1][1])
    assert runs[0][2] == runs[1][2]
    other = make(frames, seed_samp=7)
    for _ in range(4):
        other.optimizer_step(other.loss_and_grad()[1])
    assert not torch.equal(other.theta, runs[0][0])


def test_native_and_torch_paths_give_same_step(frames):
    a = make(frames, native=True)
    b = make(frames, native=False)
    for _ in range(2):
        sa, ga = a.loss_and_grad()
        sb, gb = b.loss_and_grad()
        assert sa["loss"] == pytest.approx(sb["loss"], rel=1e-4)
        assert torch.allclose(ga, gb, atol=1e-6, rtol=1e-3)
        a.optimizer_step(ga)
        b.optimizer_step(gb)
    assert torch.allclose(a.theta, b.theta, atol=1e-4)


def test_adam_matches_torch_optim(frames):
    m = make(frames)
    p = m.theta.clone().requires_grad_(True)
    opt = torch.optim.Adam([p], lr=0.01, betas=(0.9, 0.99), eps=1e-15)
    g = torch.Generator().manual_seed(0)
    for _ in range(5):
        grad = torch.randn(m.n_params, generator=g) * (torch.rand(m.n_params, generator=g) < 0.3)
        m.optimizer_step(grad)
        p.grad = grad.clone()
        opt.step()
    assert torch.allclose(m.theta, p.detach(), atol=1e-6)


def test_loss_decreases_and_queries(frames):
    m = make(frames, n_rays=256)
    first = m.loss_and_grad()[0]["loss"]
    for _ in range(30):
        s, g = m.loss_and_grad()
        m.optimizer_step(g)
    assert s["loss"] < first
    assert set(s) == {"loss", "rgb", "depth", "sdf", "fs", "smooth"}
    sdf, rgb = m.sdf_and_color(np.random.default_rng(0).uniform(0, 3, (1000, 3)))
    assert sdf.shape == (1000,) and rgb.shape == (1000, 3)
    assert float(rgb.min()) >= 0 and float(rgb.max()) <= 1
    d = m.render_depth(frames[0].c2w, frames[0].K, stride=4)
    assert d.shape == (8, 10) and np.isfinite(d).all()
    pts, counts = m.coarse_level_points_and_visits()
    assert pts.shape == (16 ** 3, 3) and counts.shape == (16 ** 3,)
    assert counts.max() > 0 and counts.max() <= 31


def test_state_roundtrip(frames, tmp_path):
    m = make(frames)
    m.optimizer_step(m.loss_and_grad()[1])
    sd = m.state_dict()
    n = make(frames, seed_init=9)
    n.load_state_dict(sd)
    assert torch.equal(n.theta, m.theta) and torch.equal(n.visits, m.visits)
    save_decoders(m.decoders.weights(), tmp_path / "d.pt")
    w = load_decoders(tmp_path / "d.pt")
    assert torch.equal(w["geo.0"], m.decoders.weights()["geo.0"])


def test_bad_inputs_have_clear_messages(frames, tmp_path):
    cfg = MapConfig(**SMALL)
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    with pytest.raises(ValueError, match="bounds"):
        NeuralMap(np.zeros((2, 3)), cfg, dec, torch.Generator(), torch.Generator())
    bad = dict(dec)
    bad["geo.0"] = torch.zeros(32, 81)
    with pytest.raises(ValueError, match="geo.0"):
        NeuralMap(synthetic.bounds(), cfg, bad, torch.Generator(), torch.Generator())
    with pytest.raises(FileNotFoundError, match="nope.pt"):
        load_decoders(tmp_path / "nope.pt")
    with pytest.raises(ValueError):
        MapConfig(near=2.0, far=1.0)
    with pytest.raises(ValueError):
        MapConfig(n_rays=0)
    assert MapConfig.paper().n_rays == 2048 and MapConfig.paper().samples_per_ray == 43


def test_empty_map_returns_zero_gradient():
    cfg = MapConfig(**SMALL)
    m = NeuralMap(synthetic.bounds(), cfg, init_decoders(cfg, torch.Generator().manual_seed(0)),
                  torch.Generator(), torch.Generator())
    s, g = m.loss_and_grad()
    assert s["loss"] == 0.0 and int((g != 0).sum()) == 0 and int(m.visits.sum()) == 0


def test_visits_can_include_smoothness_like_the_official_code(frames):
    a = make(frames, smooth_weight=1.0)
    a.count_observation_only = False
    _, g = a.loss_and_grad()
    assert torch.equal(a.visits, (g != 0).to(torch.int32))  # every non-zero entry counted
    b = make(frames, smooth_weight=1.0)
    b.loss_and_grad()
    assert int(a.visits.sum()) > int(b.visits.sum())


def test_paper_preset_is_selectable_and_overridable():
    from ramensim.agents.map.config import PRESETS

    paper = MapConfig(preset="paper")
    assert (paper.n_rays, paper.n_stratified, paper.n_surface, paper.log2_hashmap_size) == (2048, 32, 11, 16)
    assert MapConfig(preset="paper", n_rays=512).n_rays == 512
    assert PRESETS["paper"] == paper and MapConfig().n_rays == 1024
