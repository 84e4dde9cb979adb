"""The team's batched step (agents/map/team_batch.py) takes only maps that can share one batch.
Its losses and gradients are checked in tests/map/test_map_step.py, against finite differences
and by hand, as every form of the step is (the team engine's lockstep runs: tests/agents)."""
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
        for i, f in enumerate(synthetic.frames(3, 40, 30, phase=0.7 * r)):
            m.add_frame(f, keyframe=(i % 2 == 0))
        maps.append(m)
    return maps


def test_team_batch_refuses_maps_on_the_c_kernels() -> None:
    maps = _team(2)
    maps[0].grid_native = True
    with pytest.raises(ValueError, match="torch path"):
        team_loss_and_grad(maps)


def test_team_batch_refuses_maps_of_another_configuration() -> None:
    maps = _team(1) + _team(1, n_rays=32)
    with pytest.raises(ValueError, match="another grid, configuration or device"):
        team_loss_and_grad(maps)
