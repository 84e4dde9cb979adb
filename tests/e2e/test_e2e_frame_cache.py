"""A run with a cold frame cache, a warm one (nothing rendered) and the cache off writes the
same messages.csv and metrics.json, wall time aside, and another method and success rate of the
same trial renders nothing either (world/frame_cache.py)."""
from __future__ import annotations

import json
from pathlib import Path

from ramensim.config import load_scenario
from ramensim.lifecycle import run_scenario
from ramensim.world import RGBDCamera
from ramensim.world.frame_cache import CACHE_ENV

from tiny_runs import SCENARIO, TINY


def _run(out: Path, *extra: str) -> tuple[bytes, bytes]:
    result = run_scenario(load_scenario(SCENARIO, [*TINY, "duration=2", "method=ramen", *extra]), out)
    assert result.status == "ok"
    metrics = json.loads((out / "metrics.json").read_text())
    metrics.pop("wall_time_s")
    return (out / "messages.csv").read_bytes(), json.dumps(metrics, sort_keys=True).encode()


def test_cold_warm_and_off_runs_are_identical(tmp_path: Path, monkeypatch) -> None:
    cache = tmp_path / "frames"
    monkeypatch.setenv(CACHE_ENV, "off")
    off = _run(tmp_path / "off")
    monkeypatch.setenv(CACHE_ENV, str(cache))
    cold = _run(tmp_path / "cold")
    frames = sorted(cache.rglob("*.frame"))
    assert len(frames) == 2 * 10  # two robots, 2 s at 5 fps
    before = [(p, p.stat().st_mtime_ns) for p in frames]

    def refuse(self, c2w):
        raise AssertionError("a warm run rendered a frame")

    monkeypatch.setattr(RGBDCamera, "render_arrays", refuse)
    warm = _run(tmp_path / "warm")
    assert [(p, p.stat().st_mtime_ns) for p in frames] == before  # read, not rewritten
    assert off[0] == cold[0] == warm[0]
    assert off[1] == cold[1] == warm[1]
    # another method and success rate of the same trial: the same frames, none rendered
    _run(tmp_path / "dinno", "method=dinno", "channel.success_rate=0.2")
    assert sorted(cache.rglob("*.frame")) == frames
