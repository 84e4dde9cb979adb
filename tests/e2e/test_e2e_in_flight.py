"""The run's message totals account for every message sent: delivered + dropped (the log,
messages.csv) + those still in flight when the run ended (``communication.in_flight``), as the
progress bar counts them."""
from __future__ import annotations

from pathlib import Path

from ramensim.config import load_scenario
from ramensim.core.events import MessageSent
from ramensim.lifecycle import run_scenario

ROOT = Path(__file__).resolve().parents[2]


def test_sent_settled_and_in_flight_add_up(tmp_path):
    sc = load_scenario(ROOT / "scenarios" / "office_3agents.yaml", [
        "agents.count=2", "duration=3", "world.camera.width=40", "world.camera.height=30", "world.camera.fx=30",
        "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5", "evaluation.voxel_m=0.1",
        "evaluation.n_samples=5000", "evaluation.cull=frustum", "map.n_rays=128", "consensus.primal_steps=3",
        "recording.mode=off", "channel.bandwidth_bps=2.0e7"])  # slow radio: 4 MB messages queue up
    sc = sc[0] if isinstance(sc, tuple) else sc
    sent = []
    result = run_scenario(sc, tmp_path / "run", subscribers=[lambda e: sent.append(e) if isinstance(e, MessageSent) else None])
    total = result.communication
    rows = (tmp_path / "run" / "messages.csv").read_text().strip().splitlines()[1:]
    assert total["sent"] == total["delivered"] + total["dropped"] == len(rows)
    assert total["in_flight"] > 0  # the slow radio leaves some on the air at the end
    assert total["sent"] + total["in_flight"] == len(sent)
