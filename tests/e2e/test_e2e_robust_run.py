"""Nothing lost (issue 15): SIGTERM and SIGKILL mid-run, a failing frame reader, divergence with
finite values, run-folder locking, and pretrained decoders given by ``map.decoders``."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from ramensim.cli import main
from ramensim.config import load_scenario
from ramensim.divergence import DivergenceRule, DivergenceWatch
from ramensim.core.errors import InputError
from ramensim.runfolder import RunLock

from tiny_runs import SCENARIO, TINY


def _args(out: Path, *extra: str) -> list[str]:
    args = ["run", str(SCENARIO), "--out", str(out)]
    for s in (*TINY, *extra):
        args += ["--set", s]
    return args


def _start(out: Path, *extra: str) -> subprocess.Popen:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.Popen([sys.executable, "-m", "ramensim", "-q", *_args(out, *extra)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _wait_for_flush(proc: subprocess.Popen, out: Path, probes: bool = False) -> dict:
    """Wait until the run has flushed a partial metrics.json after some rounds (and, with
    ``probes``, after a consensus probe: on a loaded machine a second of wall time may not
    reach the first probe's simulated time). Fails if the run ends first; no clock (the
    tests' pytest-timeout mark is the hang guard)."""
    while True:
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else "the run ended before it flushed"
        try:
            m = json.loads((out / "metrics.json").read_text())
        except (OSError, ValueError):
            m = None
        if m is not None and min(a["rounds"] for a in m["per_agent"].values()) > 0 and (
                not probes or m.get("consensus_timeline")):
            return m
        time.sleep(0.5)


@pytest.mark.timeout(900)  # a hang guard only, far above an honest run on a loaded machine
def test_sigterm_stops_evaluates_and_writes_everything(tmp_path: Path) -> None:
    out = tmp_path / "term"
    proc = _start(out, "duration=600", "output.flush_every_s=1")
    try:
        partial = _wait_for_flush(proc, out)
        assert partial["status"] == "interrupted" and "partial" in partial["error"]
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
    err = proc.stderr.read() if proc.stderr else ""
    assert rc == 130, err  # interrupted (ramensim run's exit codes)
    assert "Traceback" not in err
    m = json.loads((out / "metrics.json").read_text())
    assert m["status"] == "interrupted" and m["error"] == "stopped by SIGTERM"
    assert 0 < m["sim_time_s"] < 600
    for entry in m["per_agent"].values():  # evaluated, not just flushed
        assert entry["rounds"] > 0 and entry["completion_ratio_pct"] is not None
    rows = (out / "messages.csv").read_text().strip().splitlines()
    assert len(rows) - 1 == m["communication"]["sent"] > 0
    assert (out / "mesh_agent_0.ply").is_file()
    assert not list(out.glob(".*.tmp")) and not list(out.glob(".mesh_*"))


@pytest.mark.timeout(900)  # a hang guard only
def test_sigkill_keeps_the_last_flush(tmp_path: Path) -> None:
    out = tmp_path / "kill"
    proc = _start(out, "duration=600", "output.flush_every_s=1")
    try:
        _wait_for_flush(proc, out, probes=True)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
    m = json.loads((out / "metrics.json").read_text())  # complete JSON: written atomically
    assert m["status"] == "interrupted" and "partial result" in m["error"]
    assert m["sim_time_s"] >= 1 and all(a["rounds"] > 0 for a in m["per_agent"].values())
    assert m["consensus_timeline"]  # the probes so far survive
    header = (out / "messages.csv").read_text().splitlines()[0]
    assert header.startswith("id,")
    # the lock died with the process: a new run may take the folder with --overwrite
    with RunLock(out):
        pass


def test_out_onto_a_used_folder_is_refused(tmp_path: Path, capsys) -> None:
    out = tmp_path / "used"
    out.mkdir()
    (out / "metrics.json").write_text("{}")
    assert main(_args(out, "duration=1")) == 2
    err = capsys.readouterr().err
    assert "--overwrite" in err and "not empty" in err
    with RunLock(out):  # a second writer of the same folder is refused
        with pytest.raises(InputError, match="another run"):
            with RunLock(out):
                pass


def test_failing_frame_reader_fails_that_agent_only(tmp_path: Path, monkeypatch) -> None:
    from ramensim.core.frames import FrameFeed
    from ramensim.lifecycle import run_scenario
    from ramensim.world import World

    original = World.frame_feed

    def frame_feed(self, k):
        feed = original(self, k)
        if k != 1:
            return feed

        def render(i):
            if i >= 3:
                raise OSError(f"depth/frame{i:06d}.png: [Errno 5] Input/output error")
            return feed.render(i)
        return FrameFeed(feed.times, render, feed.is_keyframe, feed.taken_by)

    monkeypatch.setattr(World, "frame_feed", frame_feed)
    sc = load_scenario(SCENARIO, [*TINY, "duration=3"])
    result = run_scenario(sc, tmp_path / "run")
    assert result.status == "failed"
    bad, good = result.per_agent["agent_1"], result.per_agent["agent_0"]
    assert "frame 3" in bad.failed_reason and "depth/frame000003.png" in bad.failed_reason
    assert "agent_1" in result.error
    assert good.failed_reason is None and good.frames > bad.frames and good.completion_ratio_pct is not None
    assert json.loads((tmp_path / "run" / "metrics.json").read_text())["status"] == "failed"


def test_huge_learning_rate_is_marked_diverged(tmp_path: Path) -> None:
    from ramensim.lifecycle import run_scenario

    sc = load_scenario(SCENARIO, [*TINY, "duration=2", "map.lr=1000"])
    result = run_scenario(sc, tmp_path / "run")
    assert result.status == "diverged"
    for a in result.per_agent.values():
        assert a.diverged and a.diverged_round == 1 and "sum of the loss weights" in a.diverged_reason


def test_divergence_rules() -> None:
    w = DivergenceWatch(DivergenceRule(loss_factor=100, warmup_rounds=2, loss_weight_sum=10.0))
    assert w.after_round(0, 50.0) is None          # below the ceiling 10 x 10
    assert "sum of the loss weights" in w.after_round(1, 101.0)
    for loss in (1.0, 0.5, 0.2, 0.3, 15.0):        # growth 75x its minimum: healthy enough
        assert w.after_round(0, loss) is None
    assert "running minimum" in w.after_round(0, 25.0)
    assert w.after_round(0, float("nan")) is None  # the mapper reports non-finite values itself
    assert w.after_evaluation(0, 60.0) is None
    assert w.after_evaluation(0, 30.0) is None
    assert "collapsed" in w.after_evaluation(0, 10.0)
    assert w.after_evaluation(1, 5.0) is None and w.after_evaluation(1, 0.5) is None  # never good


def test_pretrained_decoders_are_used(tmp_path: Path) -> None:
    from ramensim.agents.map import load_decoders
    from ramensim.sim import build_simulation

    dec = tmp_path / "dec" / "tiny.pt"
    assert main(["-q", "pretrain-decoders", "--iterations", "3", "--duration", "1", "--seed", "3",
                 "--out", str(dec)]) == 0
    scen = tmp_path / "s.yaml"
    scen.write_text(SCENARIO.read_text() + "\n# decoders relative to this file\n", encoding="utf-8")
    sc = load_scenario(scen, [*TINY, "duration=2", "map.decoders=dec/tiny.pt"])
    sim = build_simulation(sc, base_dir=scen.parent)
    weights, shipped = load_decoders(dec), load_decoders()
    try:
        for m in sim.maps:
            for k, v in weights.items():
                assert torch.equal(m.decoders.params[k].cpu(), v)
                assert not torch.equal(m.decoders.params[k].cpu(), shipped[k])
    finally:
        sim.world.close()
    out = tmp_path / "run"
    argv = ["run", str(scen), "--out", str(out)]
    for s in (*TINY, "duration=2", "map.decoders=dec/tiny.pt"):
        argv += ["--set", s]
    assert main(argv) == 0
    assert str(dec) in (out / "run.log").read_text()
    assert yaml_value(out / "scenario.yaml", "map", "decoders") == "dec/tiny.pt"
    bad = ["run", str(scen), "--out", str(tmp_path / "bad")]
    for s in (*TINY, "duration=2", "map.decoders=dec/missing.pt"):
        bad += ["--set", s]
    assert main(bad) == 2


def yaml_value(path: Path, *keys: str):
    import yaml

    node = yaml.safe_load(path.read_text())
    for k in keys:
        node = node[k]
    return node


def test_long_scenario_name_gives_a_short_folder_name(tmp_path: Path) -> None:
    from ramensim.runfolder import new_run_dir

    path = new_run_dir(tmp_path, "x" * 4000 + "/../" + "y" * 10, 12345678901234567890)
    assert len(path.name) < 160 and path.parent == tmp_path
    path.mkdir()  # a legal name on every filesystem with 255-byte names
