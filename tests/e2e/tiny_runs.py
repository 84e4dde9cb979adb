"""The smallest real run the app tests make: the default office scenario with two robots, a
40 x 30 camera, coarse evaluation and no recording (a few seconds of simulated time each)."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "office_3agents.yaml"
TINY = [
    "agents.count=2", "world.camera.width=40", "world.camera.height=30",
    "world.camera.fx=30", "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5",
    "evaluation.voxel_m=0.1", "evaluation.n_samples=5000", "evaluation.cull=frustum",
    "map.n_rays=128", "consensus.primal_steps=3", "recording.mode=off",
]
"""``--set`` overrides of :data:`SCENARIO` (add ``duration=...``)."""
