"""Live viewing never holds a run (issue 29): a viewer that cannot start (no display) or a URL
where nothing listens is one warning paragraph, the run ends by itself, and run.rrd is written
whatever the live mode."""
from __future__ import annotations

from pathlib import Path

import pytest

from ramensim.config import load_scenario
from ramensim.lifecycle import run_scenario
from ramensim.recording.viewer import free_port

ROOT = Path(__file__).resolve().parents[2]
SMALL = ["agents.count=2", "duration=1", "world.camera.width=40", "world.camera.height=30", "world.camera.fx=30",
         "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5", "evaluation.voxel_m=0.1",
         "evaluation.n_samples=2000", "evaluation.cull=frustum", "map.n_rays=64", "consensus.primal_steps=2",
         "recording.live_timeout_s=2"]


@pytest.mark.parametrize("mode", ["connect", "spawn"])
def test_unreachable_viewer_warns_and_the_run_saves_its_recording(tmp_path, monkeypatch, caplog, mode):
    port = free_port()  # nothing listens there
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    extra = [f"recording.mode={mode}", f"recording.url=rerun+http://127.0.0.1:{port}/proxy",
             f"recording.serve_port={port}"]
    sc = load_scenario(ROOT / "scenarios" / "office_3agents.yaml", SMALL + extra)
    with caplog.at_level("WARNING"):
        result = run_scenario(sc, tmp_path / "run")
    assert result.status == "ok"
    rrd = tmp_path / "run" / "run.rrd"
    assert rrd.is_file() and rrd.stat().st_size > 10_000
    text = " ".join(caplog.text.split())
    assert f"recording.mode {mode}:" in text and "the recording is still saved to" in text
    assert ("no display" in text) if mode == "spawn" else (f"127.0.0.1:{port}" in text)
