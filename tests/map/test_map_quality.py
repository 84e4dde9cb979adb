"""Single agent, every frame of the synthetic room, default budget: held-out depth.

Run: PYTHONPATH=. python -m pytest -m slow tests/map/test_map_quality.py -s
"""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, load_decoders
from ramensim.agents.map import synthetic


def held_out_depth_error(rounds_per_frame: int = 1) -> float:
    cfg = MapConfig()
    m = NeuralMap(synthetic.bounds(), cfg, load_decoders(), torch.Generator().manual_seed(0),
                  torch.Generator().manual_seed(1))
    frames = synthetic.frames(24, 80, 60)
    for i, f in enumerate(frames):
        m.add_frame(f, keyframe=(i % 2 == 0))
        for _ in range(rounds_per_frame * 10):  # B = 10 steps per round
            m.optimizer_step(m.loss_and_grad()[1])
    errs = []
    for c2w in synthetic.trajectory(6, phase=0.37):  # views between the training poses
        _, gt = synthetic.render(c2w, synthetic.intrinsics(80, 60))
        d = m.render_depth(c2w, synthetic.intrinsics(80, 60), stride=2)
        errs.append(np.abs(d - gt[::2, ::2]).mean())
    return float(np.mean(errs))


@pytest.mark.slow
def test_held_out_depth_matches_ground_truth():
    err = held_out_depth_error(rounds_per_frame=2)
    print(f"held-out mean absolute depth error: {err * 100:.2f} cm")
    assert err < 0.05
