"""The team engine (agents/team.py): rounds computed off the event loop, several robots at once,
with the results of computing each round inline at its start."""
from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest
import torch

import ramensim
from ramensim.agents.map.threads import capped, thread_cap
from ramensim.agents.step import ConsensusStep
from ramensim.agents.team import BATCH_ENV, WORKERS_ENV, TeamEngine, team_workers

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "office_3agents.yaml"
SMALL = {
    "duration": 6, "agents.count": 3, "world.camera.width": 40, "world.camera.height": 30,
    "world.camera.fx": 30, "world.camera.fy": 30, "world.camera.cx": 19.5, "world.camera.cy": 14.5,
    "evaluation.voxel_m": 0.1, "evaluation.n_samples": 5000, "evaluation.cull": "frustum",
    "evaluation.every_s": 2.0, "evaluation.consensus_every_s": 0.5,
    "map.n_rays": 128, "consensus.primal_steps": 3, "recording.mode": "off",
    "agents.compute.jitter": 0.3,
}
"""Three robots whose rounds overlap (jittered clocks), evaluations and probes in between."""


def test_engine_runs_jobs_on_workers_and_returns_their_results() -> None:
    engine = TeamEngine(2)
    gate = threading.Barrier(2, timeout=30)
    names: list[str] = []

    def job(x: int):
        def run() -> int:
            gate.wait()  # both jobs must be running at once, or this times out
            names.append(threading.current_thread().name)
            return x * x
        return run
    a, b = engine.submit(job(3)), engine.submit(job(4))
    assert engine.max_in_flight == 2
    assert (a.result(), b.result()) == (9, 16)
    assert all(n.startswith("ramensim-round") for n in names)
    engine.close()


def test_engine_keeps_a_rounds_exception_for_its_owner() -> None:
    for workers in (1, 2):
        engine = TeamEngine(workers)

        def bad() -> int:
            raise FloatingPointError("non-finite map")
        t = engine.submit(bad)
        ok = engine.submit(lambda: 1)
        engine.drain()  # does not raise: the exception belongs to the round's owner
        assert ok.result() == 1
        with pytest.raises(FloatingPointError, match="non-finite map"):
            t.result()
        engine.close()


def test_workers_cap_every_map_stage_at_one_thread() -> None:
    engine = TeamEngine(2)
    seen = engine.submit(lambda: (thread_cap(), capped(0), capped(4), torch.get_num_threads())).result()
    assert seen == (1, 1, 1, 1)
    assert thread_cap() == 0 and capped(4) == 4  # the caller's thread is not capped
    engine.close()


def test_lockstep_batches_refused_off_the_torch_path(tmp_path: Path, monkeypatch) -> None:
    from ramensim.errors import InputError

    monkeypatch.setenv(BATCH_ENV, "1")  # the maps run the C kernels here: one clear paragraph
    with pytest.raises(InputError, match="RAMENSIM_TEAM_BATCH=1: .*torch path"):
        ramensim.run(SCENARIO, {**SMALL, "duration": 1}, out=tmp_path / "x")


def test_team_workers_from_environment(monkeypatch) -> None:
    monkeypatch.setenv(WORKERS_ENV, "8")
    assert team_workers(3) == 3  # never more than the maps
    monkeypatch.setenv(WORKERS_ENV, "1")
    assert team_workers(3) == 1
    monkeypatch.setenv(WORKERS_ENV, "two")
    with pytest.raises(ValueError, match=WORKERS_ENV):
        team_workers(3)
    monkeypatch.delenv(WORKERS_ENV)
    assert team_workers(1) == 1
    assert team_workers(5, "cuda") == 1


class _Learner:
    def __init__(self) -> None:
        self.frames: list[int] = []

    def add_frame(self, frame, keyframe) -> None:
        self.frames.append(frame)


def test_frames_arriving_during_a_round_are_held_until_it_is_collected() -> None:
    learner = _Learner()

    class _Store:
        def select(self, now, policy, max_age):
            from ramensim.agents.copies import Selection
            return Selection([])

    class _Method:
        def round(self, lrn, copies, degree):
            from ramensim.core.results import RoundResult
            return RoundResult.from_scalars({"loss": float(len(lrn.frames)), "grad_evals": 1.0})

    step = ConsensusStep(0, learner, _Method(), _Store(), "float32", torch.zeros(1), lambda: 0)
    step.add_frame(1, True)
    job = step.begin_round(0.0)
    step.add_frame(2, False)  # arrives while the round is in flight
    step.add_frame(3, True)
    assert learner.frames == [1]
    assert job().result.loss == 1.0  # the round saw only what it started with
    step.end_round()
    assert learner.frames == [1, 2, 3]  # in order, once collected


def _run(tmp: Path, monkeypatch, workers: int, method: str) -> tuple[bytes, dict]:
    monkeypatch.setenv(WORKERS_ENV, str(workers))
    out = tmp / f"{method}_w{workers}"
    ramensim.run(SCENARIO, {**SMALL, "method": method}, out=out)
    metrics = json.loads((out / "metrics.json").read_text())
    metrics.pop("wall_time_s")
    build = metrics.pop("build")
    # two workers: rounds off the event loop and the periodic evaluations on their own thread
    assert (build["team_workers"], build["evaluation_lane"]) == ((2, True) if workers == 2 else (1, False))
    return (out / "messages.csv").read_bytes(), metrics


@pytest.mark.parametrize("method", ["ramen", "dsgt"])
def test_rounds_on_two_workers_equal_rounds_inline(tmp_path: Path, monkeypatch, method: str) -> None:
    """The same messages and the same maps (metrics, evaluations over time, consensus probes)
    whether the team's rounds are computed inline or two at a time off the event loop, with the
    periodic evaluations inline or on their own thread on frozen copies of the maps."""
    inline_csv, inline = _run(tmp_path, monkeypatch, 1, method)
    team_csv, team = _run(tmp_path, monkeypatch, 2, method)
    assert inline["status"] == "ok" and inline["consensus_timeline"]
    assert len(inline["timeline"]) >= 6
    assert team_csv == inline_csv
    assert team == inline


TORCH_PATH = {**SMALL, "map.native": False, "duration": 4}
"""The maps' torch path (the GPU's form), where the team's gradients can go in lockstep batches."""


def _run_torch(tmp: Path, monkeypatch, name: str, workers: str | None) -> tuple[bytes, dict]:
    if workers is None:  # lockstep batches
        monkeypatch.delenv(WORKERS_ENV, raising=False)
        monkeypatch.setenv(BATCH_ENV, "1")
    else:
        monkeypatch.setenv(WORKERS_ENV, workers)
        monkeypatch.delenv(BATCH_ENV, raising=False)
    out = tmp / name
    ramensim.run(SCENARIO, {**TORCH_PATH, "method": "ramen"}, out=out)
    return (out / "messages.csv").read_bytes(), json.loads((out / "metrics.json").read_text())


def test_lockstep_batches_are_deterministic_and_match_inline(tmp_path: Path, monkeypatch) -> None:
    """Lockstep batches: the same run twice is identical; against rounds computed inline one
    map at a time, the same messages and the maps' metrics equal up to float rounding."""
    csv_a, a = _run_torch(tmp_path, monkeypatch, "a", None)
    csv_b, b = _run_torch(tmp_path, monkeypatch, "b", None)
    csv_i, inline = _run_torch(tmp_path, monkeypatch, "inline", "1")
    assert a["build"]["team_lockstep"] and a["build"]["team_largest_batch"] == 3
    assert not inline["build"]["team_lockstep"]
    for m in (a, b, inline):
        m.pop("wall_time_s")
        m.pop("build")
    assert csv_a == csv_b and a == b
    assert csv_a == csv_i  # the channel never sees the maps' values
    for name, agent in inline["per_agent"].items():
        for key in ("completion_ratio_pct", "artifacts_cm"):
            assert a["per_agent"][name][key] == pytest.approx(agent[key], rel=1e-3, abs=0.05), (name, key)
    assert a["consensus_error"] == pytest.approx(inline["consensus_error"], rel=1e-3)


def _poisoned_run(tmp: Path, monkeypatch, name: str, over: dict) -> dict:
    """A run whose robot 1's map turns NaN when its second round has been collected (a subscriber
    on the event loop, where no round of robot 1 is in flight)."""
    import ramensim.lifecycle as lifecycle
    from ramensim.core.events import RoundCompleted

    built: list = []
    real = lifecycle.build_simulation

    def build(*args, **kwargs):
        built.append(real(*args, **kwargs))
        return built[-1]

    def poison(event) -> None:
        if isinstance(event, RoundCompleted) and event.agent == 1 and event.round == 2:
            built[0].maps[1].theta.fill_(float("nan"))

    monkeypatch.setattr(lifecycle, "build_simulation", build)
    out = tmp / name
    ramensim.run(SCENARIO, over, out=out, subscribers=[poison])
    return json.loads((out / "metrics.json").read_text())


@pytest.mark.parametrize("mode", ["workers", "lockstep"])
def test_a_nan_in_one_map_marks_that_robot_diverged_and_the_others_go_on(tmp_path: Path, monkeypatch,
                                                                         mode: str) -> None:
    """With rounds on two workers, or the team's gradients in one lockstep batch, a robot whose map
    goes NaN is marked diverged in its next round and the others map to the end."""
    if mode == "workers":
        monkeypatch.setenv(WORKERS_ENV, "2")
        monkeypatch.delenv(BATCH_ENV, raising=False)
        over = {**SMALL, "method": "ramen"}
    else:
        monkeypatch.delenv(WORKERS_ENV, raising=False)
        monkeypatch.setenv(BATCH_ENV, "1")
        over = {**TORCH_PATH, "method": "ramen"}
    m = _poisoned_run(tmp_path, monkeypatch, mode, over)
    assert m["build"]["team_lockstep"] == (mode == "lockstep")
    assert m["status"] == "diverged"
    bad = m["per_agent"]["agent_1"]
    assert bad["diverged"] and bad["diverged_round"] == bad["rounds"] == 3  # it stops in that round
    for name in ("agent_0", "agent_2"):
        good = m["per_agent"][name]
        assert not good["diverged"] and good["rounds"] > 3 * bad["rounds"]
        assert good["completion_ratio_pct"] is not None and good["completion_ratio_pct"] > 0
