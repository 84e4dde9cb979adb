"""One run's lifecycle: its folder and lock, the simulation built by ``ramensim.sim``, the
observers scheduled on its clock (``ramensim.observe``), the event loop up to the scenario's
duration with signals turned into a clean stop, and the final evaluation and results.
"""
from __future__ import annotations

import logging
import math
import signal
import threading
import time
from functools import partial
from pathlib import Path
from typing import Any, Callable

import numpy as np
import simpy

from ramensim import observe
from ramensim.agents.rounds import engine_settings
from ramensim.costs import record as record_cost
from ramensim.core.events import Event, RoundCompleted
from ramensim.core.files import atomic_write_yaml
from ramensim.core.results import RunResult
from ramensim.core.errors import InputError
from ramensim.scoring import Evaluator
from ramensim.runfolder import RunLog
from ramensim.schema import Scenario
from ramensim.sim import Simulation, build_simulation

log = logging.getLogger(__name__)


def run_scenario(scenario: Scenario, out_dir: str | Path, base_dir: str | Path | None = None,
                 subscribers: list[Callable[[Event], None]] | None = None) -> RunResult:
    """Run ``scenario`` and write its folder ``out_dir``: ``scenario.yaml`` (resolved),
    ``run.log``, ``messages.csv``, ``mesh_<agent>.ply``, ``metrics.json`` and ``run.rrd``.
    Returns the typed result that ``metrics.json`` holds. ``base_dir`` resolves relative
    paths in the scenario.

    Nothing is lost (docs/RELIABILITY.md): SIGINT and SIGTERM stop the run at the next event,
    which is then evaluated and written with status ``interrupted`` (a second SIGINT aborts);
    the results so far are flushed atomically every ``output.flush_every_s`` simulated seconds
    and after each periodic evaluation (``metrics.json`` with status ``interrupted`` until the
    final one replaces it); an error inside the event loop ends the run with status
    ``failed`` and still writes what was mapped. A lock keeps a second run out of the folder.
    A run refused before it starts (bad input found while building: a dataset that cannot be
    read, a run too large for the memory) leaves nothing behind: the files it had written are
    removed, and the folder too if the run created it, so the same command can be run again."""
    from ramensim.runfolder import RunLock

    out = Path(out_dir)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"run folder {out}: it cannot be created ({exc.strerror or exc}); expected a writable "
                         f"folder (--out, or the scenario's output.dir {scenario.output.dir!r}).") from None
    with RunLock(out):
        try:
            return _run_locked(scenario, out, base_dir, subscribers)
        except _RefusedAtStart as exc:  # nothing ran; the lock is ours, so are the files
            refused = exc.error
            for name in ("scenario.yaml", "run.log"):
                try:
                    (out / name).unlink()
                except OSError:
                    pass
    if created:
        try:
            out.rmdir()  # only when empty: nothing of the user's is touched
        except OSError:
            pass
    raise refused


class _RefusedAtStart(Exception):
    """Bad input found while building the simulation (``error``): the run never started."""

    def __init__(self, error: InputError) -> None:
        super().__init__(str(error))
        self.error = error


def _copy_plugins(scenario: Scenario, out: Path) -> None:
    """A copy of each plugin file the scenario loads, in ``out/plugins/`` (metrics.json's
    ``build.plugins`` has their SHA-256): the run folder keeps the code it ran."""
    import shutil

    from ramensim.plugins import is_file_entry

    files = [Path(p) for p in scenario.plugins if is_file_entry(p) and Path(p).is_file()]
    if not files:
        return
    (out / "plugins").mkdir(exist_ok=True)
    for f in files:
        shutil.copy2(f, out / "plugins" / f.name)


def _run_locked(scenario: Scenario, out: Path, base_dir: str | Path | None,
                subscribers: list[Callable[[Event], None]] | None) -> RunResult:
    """The run itself, in ``out`` whose lock the caller holds."""
    atomic_write_yaml(out / "scenario.yaml", scenario.model_dump(mode="json"))
    _copy_plugins(scenario, out)
    wall0 = time.perf_counter()
    with RunLog(out / "run.log"):
        log.info("run %s: method=%s agents=%d duration=%.1f s seed=%d -> %s", scenario.name,
                 scenario.method, scenario.agents.count, scenario.duration, scenario.seed, out)
        try:
            sim = build_simulation(scenario, Path(base_dir) if base_dir is not None else None)
        except InputError as exc:
            raise _RefusedAtStart(exc) from None
        recorder = _make_recorder(sim, out)
        if recorder is not None:
            sim.bus.subscribers.append(recorder)
        sim.bus.subscribers.extend(subscribers or [])
        sim.bus.subscribers.append(partial(_watch_rounds, sim))
        evaluator = Evaluator.for_scenario(scenario, sim.world)
        schedule_observers(sim, recorder is not None, evaluator, out, wall0)
        status, error = "ok", None
        # the handlers stay through the final evaluation: a SIGTERM then does not cut it short
        with StopOnSignal() as stop:
            try:
                stopped = _run_until(sim.env, scenario.duration, stop)
                if stopped is not None:
                    status, error = "interrupted", f"stopped by {stopped}"
                    log.warning("%s at t=%.2f s; evaluating what was mapped so far", stopped, sim.env.now)
            except KeyboardInterrupt:
                status, error = "interrupted", "interrupted by the user"
                log.warning("interrupted at t=%.2f s; evaluating what was mapped so far", sim.env.now)
            except Exception as exc:  # noqa: BLE001 - a failed run still writes what it has
                status = "failed"
                error = f"{type(exc).__name__} at t={sim.env.now:.2f} s: {' '.join(str(exc).split())}"
                log.exception("the run failed at t=%.2f s; evaluating what was mapped so far", sim.env.now)
            try:
                metrics = observe.finish(sim, out, evaluator, status, error, wall0)
                record_cost(scenario.name, scenario.method, scenario.agents.count, metrics.sim_time_s,
                            metrics.wall_time_s, metrics.status)
            finally:
                sim.engine.close()
                if recorder is not None:
                    recorder.close()
                sim.world.close()
    return metrics


class StopOnSignal:
    """While active (main thread only), SIGINT and SIGTERM set :attr:`signal` instead of killing
    the process, so the event loop stops at the next event; a second SIGINT raises
    KeyboardInterrupt (abort now). The previous handlers are restored on exit."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.signal: str | None = None
        self._old: dict[int, Any] = {}

    def _handle(self, signum: int, frame: Any) -> None:
        if self.signal is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.signal = signal.Signals(signum).name

    def __enter__(self) -> "StopOnSignal":
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                try:
                    self._old[sig] = signal.signal(sig, self._handle)
                except (ValueError, OSError):
                    pass
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()


def _run_until(env: simpy.Environment, until: float, stop: StopOnSignal) -> str | None:
    """Process events up to ``until`` (s), checking ``stop`` between events; returns the
    signal's name when stopped early, else None (then ``env.now == until``)."""
    while stop.signal is None:
        if env.peek() >= until:
            if env.now < until:
                env.run(until=until)
            return None
        env.step()
    return stop.signal


def _watch_rounds(sim: Simulation, event: Event) -> None:
    """Bus subscriber: the loss-growth rule of :mod:`ramensim.divergence` after every round."""
    if isinstance(event, RoundCompleted):
        reason = sim.watch.after_round(event.agent, float(event.scalars.get("loss", math.nan)))
        if reason is not None:
            sim.processes[event.agent].mark_diverged(reason)


def _make_recorder(sim: Simulation, out: Path):
    from ramensim.recording import make_recorder

    sc = sim.scenario
    scene = sim.world.scene
    v = f = c = None
    if scene is not None and sc.recording.log_scene:
        v, f = np.asarray(scene.mesh.vertices), np.asarray(scene.mesh.faces)
        c = getattr(scene.mesh.visual, "vertex_colors", None)
    return make_recorder(sc.recording, out, sc.agents.count, v, f, c, sim.world.bounds, seed=sc.seed,
                         recording_name=sc.name, scenario=sc.model_dump(mode="json"))


def schedule_observers(sim: Simulation, recording: bool, evaluator: Evaluator, out: Path | None = None,
                        wall0: float = 0.0) -> None:
    """Map meshes and uncertainty for the recorder at their cadences, optional periodic
    evaluation (paper metrics over time), and the periodic flush of the results so far."""
    sc, env = sim.scenario, sim.env
    if out is not None and sc.output.flush_every_s is not None:
        env.process(_periodic(env, sc.output.flush_every_s, lambda: observe.flush(sim, out, wall0)))
    if recording:
        env.process(_periodic(env, sc.recording.mesh_period_s, lambda: observe.snapshot_meshes(sim, evaluator)))
        if sim.method.sends_uncertainty:
            env.process(_periodic(env, sc.recording.uncertainty_period_s, lambda: observe.snapshot_uncertainty(sim)))
    if sc.evaluation.consensus_every_s is not None and len(sim.maps) > 1:
        env.process(_periodic(env, sc.evaluation.consensus_every_s, lambda: observe.probe_consensus(sim)))
    if sc.evaluation.every_s is not None and evaluator.can_score:
        sim.eval_lane = _evaluation_lane(sim)
        env.process(_periodic(env, sc.evaluation.every_s, lambda: observe.evaluate_now(sim, evaluator, out, wall0)))


def _evaluation_lane(sim: Simulation) -> "observe.EvaluationLane | None":
    """The periodic evaluations' thread (:class:`ramensim.observe.EvaluationLane`) or None, as the
    team engine's settings say (``$RAMENSIM_EVAL_LANE``, read with the engine's others,
    ``agents/rounds/settings.py``)."""
    settings = sim.engine_settings
    if settings is None:  # a Simulation composed by hand: its engine decides
        settings = engine_settings(len(sim.maps), sim.device)
    if not settings.evaluation_lane:
        return None
    return observe.EvaluationLane(sim, threads=settings.lane_threads)


def _periodic(env: simpy.Environment, period: float, action: Callable[[], None]):
    while True:
        yield env.timeout(period)
        action()
