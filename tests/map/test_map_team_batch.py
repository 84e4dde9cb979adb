"""One batched pass for a team's maps (agents/map/team_batch.py) equals each map's own torch
path, up to float rounding: the same losses, gradients and visit counts."""
from __future__ import annotations

import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, synthetic
from ramensim.agents.map.decoders import init_decoders
from ramensim.agents.map.team_batch import team_loss_and_grad

TINY = dict(n_levels=4, log2_hashmap_size=10, n_rays=64, n_stratified=6, n_surface=3,
            smooth_lattice=4, geo_hidden=16, color_hidden=16, geo_feat_dim=7, oneblob_bins=4, native=False)


def _team(k: int, **over) -> list[NeuralMap]:
    cfg = MapConfig(**{**TINY, **over})
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    maps = []
    for r in range(k):
        m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1),
                      torch.Generator().manual_seed(10 + r))
        if r != 1:  # robot 1 has no frame yet: zero loss and gradient, as alone
            for i, f in enumerate(synthetic.frames(3, 40, 30, phase=0.7 * r)):
                m.add_frame(f, keyframe=(i % 2 == 0))
        # different maps: a few steps of their own before the comparison
        for _ in range(r):
            _, g = m.loss_and_grad()
            m.optimizer_step(g)
        maps.append(m)
    return maps


@pytest.mark.parametrize("over", [{}, {"smooth_weight": 0.0}])
def test_team_batch_equals_each_map_alone(over) -> None:
    alone, batched = _team(4, **over), _team(4, **over)
    for step in range(3):  # the generators advance identically over several calls
        expected = [(s, g.clone(), m.visits.clone()) for m in alone for s, g in [m.loss_and_grad()]]
        got = team_loss_and_grad(batched)
        for (s_a, g_a, v_a), (s_b, g_b), m in zip(expected, got, batched):
            assert s_a.keys() == s_b.keys()
            for key in s_a:
                assert s_b[key] == pytest.approx(s_a[key], rel=1e-5, abs=1e-9), (step, key)
            scale = float(g_a.abs().max()) or 1.0
            assert torch.allclose(g_b, g_a, rtol=1e-4, atol=1e-6 * scale), (step, float((g_b - g_a).abs().max()))
            assert torch.equal(m.visits, v_a)
        for m, (_, g) in zip(batched, got):
            m.optimizer_step(g)
        for m, (_, g, _) in zip(alone, expected):
            m.optimizer_step(g)
    assert float(expected[0][1].abs().sum()) > 0 and float(got[1][1].abs().sum()) == 0.0


def test_team_batch_refuses_maps_on_the_c_kernels() -> None:
    maps = _team(2)
    maps[0].grid_native = True
    with pytest.raises(ValueError, match="torch path"):
        team_loss_and_grad(maps)
