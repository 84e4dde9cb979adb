"""Building and running one simulation: the composition root of the event loop.

One ``simpy.Environment`` (seconds); per agent a camera, a mapper on its own compute
clock and a radio (``ramensim.agents.process``); one packet-level channel over the topology
graph (``channels``); events fan out to the Rerun recorder. Nothing waits on a barrier.
"""
from __future__ import annotations

import logging
import math
import os
import signal
import threading
import time
import uuid
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any, Callable

import numpy as np
import simpy
import torch

from ramensim.agents.consensus import MethodSpec, get_method, make_method
from ramensim.agents.copies import CopyStore
from ramensim.agents.map import NeuralMap, load_decoders
from ramensim.agents.process import AgentProcess, ClockModel, RadioSchedule
from ramensim.agents.step import ConsensusStep
from ramensim.channels.channel import Channel
from ramensim.core.frames import FrameFeed
from ramensim.core.events import (Diverged, Event, MapSnapshot, MetricsEvaluated, Notice, RoundCompleted,
                                  UncertaintySnapshot)
from ramensim.channels.topology import Topology
from ramensim.errors import InputError
from ramensim.evaluate import Evaluator
from ramensim.core.files import atomic_write_yaml, fsync_dir
from ramensim.divergence import DivergenceRule, DivergenceWatch
from ramensim.core.results import METRIC_KEYS, SUMMARY_KEYS, AgentMetrics, MetricSummary, RunResult, Status
from ramensim.runfolder import RunLog
from ramensim.schema import Scenario
from ramensim.seeding import Seeds
from ramensim.core.alloc import keep_freed_memory
from ramensim.memory import check_memory
from ramensim.world import World, build_world

log = logging.getLogger(__name__)


class EventBus:
    """Fans every event out to the subscribers (the recorder, tests, ...)."""

    def __init__(self) -> None:
        self.subscribers: list[Callable[[Event], None]] = []

    def __call__(self, event: Event) -> None:
        for sub in self.subscribers:
            sub(event)


@dataclass
class Simulation:
    """A built, not yet run, simulation."""

    scenario: Scenario
    env: simpy.Environment
    world: World
    maps: list[NeuralMap]
    """One map per agent; a single one for a method whose learner merges every camera."""
    steps: list[ConsensusStep]
    processes: list[AgentProcess]
    channel: Channel | None
    bus: EventBus
    seeds: Seeds
    timeline: list[dict[str, Any]] = field(default_factory=list)
    """Periodic evaluations: {t, agent, metrics...}."""
    consensus_timeline: list[dict[str, float]] = field(default_factory=list)
    """Periodic consensus probes: {t, consensus_error, theta_rms}."""
    watch: DivergenceWatch = field(default_factory=DivergenceWatch)
    """The divergence rule beyond non-finite values (loss growth, evaluation collapse)."""

    @property
    def method(self) -> MethodSpec:
        return get_method(self.scenario.method)

    def fed_by(self, k: int) -> list[int]:
        """The robots whose cameras feed map ``k``."""
        return list(range(self.scenario.agents.count)) if self.method.merges_frames else [k]

    @property
    def map_names(self) -> list[str]:
        if self.method.merges_frames:
            return ["central"]
        return [f"agent_{i}" for i in range(len(self.maps))]


def build_simulation(sc: Scenario, base_dir: Path | None = None) -> Simulation:
    """Compose world, maps, methods, channel and processes for ``sc``."""
    keep_freed_memory()  # no page faults per mapping iteration (ramensim/core/alloc.py)
    seeds = Seeds(sc.seed)
    n = sc.agents.count
    world = build_world(sc.world, n, sc.duration, seeds.numpy, base_dir=base_dir)
    env = simpy.Environment()
    bus = EventBus()
    spec = get_method(sc.method)
    try:
        topology = Topology(sc.topology, n, position=world.position)
    except ValueError as exc:
        raise InputError(f"scenario: {exc}") from None
    channel: Channel | None = None
    if spec.communicates:
        try:
            channel = Channel(env, sc.channel, topology, n, seeds.numpy("channel"),
                              position=world.position, emit=bus, first_hit=_first_hit(sc, world), base_dir=base_dir)
        except ValueError as exc:
            raise InputError(f"scenario: {exc}") from None
    decoders = _decoders(sc.map.decoders, base_dir)
    feeds = [world.frame_feed(k) for k in range(n)]
    if spec.merges_frames:
        feeds = [FrameFeed.merged(feeds)]
    # Every agent draws its initial table from the same seed: a shared Theta_init (paper, Alg. 1).
    maps = [NeuralMap(world.bounds, sc.map, decoders, seeds.torch("map/init"), seeds.torch(f"map/samples/{k}"))
            for k in range(len(feeds))]
    # before the agents and their per-neighbour state: refuse what the machine cannot hold
    check_memory(sc, maps[0].n_params, len(maps), topology, spec.memory_vectors)
    theta0 = maps[0].theta.detach().clone()
    steps: list[ConsensusStep] = []
    processes: list[AgentProcess] = []
    for k, (feed, learner) in enumerate(zip(feeds, maps)):
        step, proc = build_agent(sc, k, env, learner, feed, theta0, channel, topology, seeds, bus)
        steps.append(step)
        processes.append(proc)
    mc = sc.map
    watch = DivergenceWatch(DivergenceRule(loss_weight_sum=mc.rgb_weight + mc.depth_weight + mc.sdf_weight
                                           + mc.fs_weight + mc.smooth_weight))
    return Simulation(sc, env, world, maps, steps, processes, channel, bus, seeds, watch=watch)


def _first_hit(sc: Scenario, world: World) -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
    """The scene's first-hit distance (m) along rays, for the channel to count the walls between
    two robots (``channel.path_loss``); None when walls do not matter or there is no scene mesh."""
    pl = sc.channel.path_loss
    if not pl.enabled or pl.wall_loss_db <= 0.0 or world.scene is None:
        return None
    from ramensim.world import MeshRayCaster

    caster = world.camera.caster if world.camera is not None else MeshRayCaster(world.scene.mesh, threads=1)
    return lambda origins, directions: caster.cast(origins, directions)[0]


def _decoders(path: str | None, base_dir: Path | None) -> dict[str, torch.Tensor]:
    """The frozen decoders of scenario key ``map.decoders`` (relative to ``base_dir``), or the
    shipped ones when it is None."""
    if path is None:
        return load_decoders()
    p = Path(path).expanduser()
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    try:
        weights = load_decoders(p)
    except (OSError, ValueError) as exc:
        raise InputError(f"scenario key 'map.decoders' has value {path!r}: {exc}") from None
    log.info("decoders: %s", p)
    return weights


def build_agent(sc: Scenario, k: int, env: simpy.Environment, learner: NeuralMap, feed: FrameFeed,
                theta0: torch.Tensor, channel: Channel | None, topology: Topology, seeds: Seeds,
                emit: Callable[[Event], None]) -> tuple[ConsensusStep, AgentProcess]:
    """Agent ``k``: its method (from the registry), neighbour copies, mapper step, compute
    clock and SimPy processes, fed by ``feed`` and attached to ``channel`` (None: it never
    communicates)."""
    learner.count_observation_only = sc.consensus.ramen.count_observation_only
    neighbours = topology.neighbours(k) if channel is not None else []
    method = make_method(sc.method, sc.consensus, learner.n_params, degree=len(neighbours), agent=k)
    degree = partial(_degree, channel, k)
    step = ConsensusStep(k, learner, method, CopyStore(k, neighbours), sc.consensus.encoding, theta0, degree,
                         sc.consensus.stale_policy, sc.consensus.max_age_s,
                         first_round_steps=sc.consensus.first_round_steps)
    if channel is not None:
        channel.attach(k, partial(_deliver, step, env))
    comp = sc.agents.compute
    clock = ClockModel(comp.seconds_per_iteration, sc.agents.speed(k), comp.jitter, comp.mode == "wall",
                       start_delay=sc.agents.start_delay(k), rng=seeds.numpy(f"clock/{k}"))
    proc = AgentProcess(env, k, step, feed, clock, radio=channel,
                        schedule=RadioSchedule(sc.radio.mode, sc.radio.period_s), emit=emit)
    return step, proc


def _degree(channel: Channel | None, k: int) -> int:
    return len(channel.neighbours(k)) if channel is not None else 0


def _deliver(step: ConsensusStep, env: simpy.Environment, msg: Any) -> None:
    step.receive(msg.src, msg.payload, msg.stamp, env.now)


def _periodic(env: simpy.Environment, period: float, action: Callable[[], None]):
    while True:
        yield env.timeout(period)
        action()


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
    ``failed`` and still writes what was mapped. A lock keeps a second run out of the folder."""
    from ramensim.runfolder import RunLock

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with RunLock(out):
        atomic_write_yaml(out / "scenario.yaml", scenario.model_dump(mode="json"))
        wall0 = time.perf_counter()
        with RunLog(out / "run.log"):
            log.info("run %s: method=%s agents=%d duration=%.1f s seed=%d -> %s", scenario.name,
                     scenario.method, scenario.agents.count, scenario.duration, scenario.seed, out)
            sim = build_simulation(scenario, Path(base_dir) if base_dir is not None else None)
            recorder = _make_recorder(sim, out)
            if recorder is not None:
                sim.bus.subscribers.append(recorder)
            sim.bus.subscribers.extend(subscribers or [])
            sim.bus.subscribers.append(partial(_watch_rounds, sim))
            evaluator = Evaluator(scenario.evaluation, sim.world, seed=scenario.seed,
                                  start_delays=[scenario.agents.start_delay(a) for a in range(scenario.agents.count)])
            _schedule_snapshots(sim, recorder is not None, evaluator, out, wall0)
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
                    metrics = _finish(sim, out, evaluator, status, error, time.perf_counter() - wall0)
                finally:
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
            _mark_diverged(sim, event.agent, reason)


def _mark_diverged(sim: Simulation, k: int, reason: str) -> None:
    proc = sim.processes[k]
    if proc.diverged is not None:
        return
    proc.diverged = (proc.rounds, reason)
    log.warning("agent %d diverged in round %d at t=%.2f s: %s", k, proc.rounds, sim.env.now, reason)
    sim.bus(Diverged(sim.env.now, k, proc.rounds, reason))
    sim.bus(Notice(sim.env.now, f"agent {k} diverged in round {proc.rounds}: {reason}", "error", k))


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


def _schedule_snapshots(sim: Simulation, recording: bool, evaluator: Evaluator, out: Path | None = None,
                        wall0: float = 0.0) -> None:
    """Map meshes and uncertainty for the recorder at their cadences, optional periodic
    evaluation (paper metrics over time), and the periodic flush of the results so far."""
    sc, env = sim.scenario, sim.env
    if out is not None and sc.output.flush_every_s is not None:
        env.process(_periodic(env, sc.output.flush_every_s, lambda: _flush(sim, out, wall0)))
    if recording:
        env.process(_periodic(env, sc.recording.mesh_period_s, lambda: _snapshot_meshes(sim, evaluator)))
        if sim.method.sends_uncertainty:
            env.process(_periodic(env, sc.recording.uncertainty_period_s, lambda: _snapshot_uncertainty(sim)))
    if sc.evaluation.consensus_every_s is not None and len(sim.maps) > 1:
        env.process(_periodic(env, sc.evaluation.consensus_every_s, lambda: _probe_consensus(sim)))
    if sc.evaluation.every_s is not None and evaluator.can_score:
        env.process(_periodic(env, sc.evaluation.every_s, lambda: _evaluate_now(sim, evaluator, out, wall0)))


def _alive(sim: Simulation, k: int) -> bool:
    p = sim.processes[k]
    return p.diverged is None and p.rounds > 0


def _snapshot_meshes(sim: Simulation, evaluator: Evaluator) -> None:
    for k, m in enumerate(sim.maps):
        if _alive(sim, k):
            mesh = evaluator.mesh_of(m, voxel_m=sim.scenario.recording.mesh_voxel_m)
            sim.bus(MapSnapshot(sim.env.now, k, np.asarray(mesh.vertices), np.asarray(mesh.faces),
                                np.asarray(mesh.visual.vertex_colors)[:, :3] if len(mesh.vertices) else
                                np.zeros((0, 3), np.uint8)))


def _snapshot_uncertainty(sim: Simulation) -> None:
    for k, m in enumerate(sim.maps):
        if _alive(sim, k):
            pts, counts = m.coarse_level_points_and_visits()
            sim.bus(UncertaintySnapshot(sim.env.now, k, pts, counts))


def _probe_consensus(sim: Simulation) -> None:
    """Consensus error (RMS pairwise difference of the maps' parameters) and the maps' RMS,
    over the agents that are mapping and have not diverged."""
    from ramensim.evaluation.summary import consensus_error

    live = [m for k, m in enumerate(sim.maps) if _alive(sim, k)]
    if len(live) < 2:
        return
    thetas = [m.theta.detach() for m in live]
    cons = consensus_error(thetas)
    wcons = _weighted_consensus(sim, live)
    rms = math.sqrt(sum(float(t.double().square().mean()) for t in thetas) / len(thetas))
    sim.consensus_timeline.append({"t": sim.env.now, "consensus_error": cons,
                                   "consensus_error_weighted": wcons, "theta_rms": rms})
    sim.bus(MetricsEvaluated(sim.env.now, -1, {"consensus_error": cons, "consensus_error_weighted": wcons}))


def _weighted_consensus(sim: Simulation, maps: list[Any]) -> float:
    """Eq. CE-2: the spread weighted by eq. 19's weights from the maps' own visit counts, with
    the scenario's RAMEN bounds beta_l, beta_u (for every method, so runs compare)."""
    from ramensim.agents.consensus.weights import weighted_consensus_error

    rc = sim.scenario.consensus.ramen
    return weighted_consensus_error([m.theta.cpu() for m in maps], [m.visits.cpu() for m in maps],
                                    rc.resolved_beta_l(), rc.resolved_beta_u())


def _evaluate_now(sim: Simulation, evaluator: Evaluator, out: Path | None = None, wall0: float = 0.0) -> None:
    """Score every live map now (the timeline), check the collapse rule, keep each map's latest
    mesh (atomically replaced) and flush the results so far."""
    poses = evaluator.poses_by_agent_until(sim.env.now)
    team = evaluator.team_coverage_pct(np.concatenate(poses, axis=0))
    for k, m in enumerate(sim.maps):
        if not _alive(sim, k):
            continue
        tmp = None
        if out is not None and sim.scenario.output.save_meshes:
            tmp = out / f".mesh_{sim.map_names[k]}.{uuid.uuid4().hex[:8]}.ply"
        result = evaluator.score(m, poses, sim.fed_by(k), mesh_path=tmp)
        if tmp is not None and tmp.is_file():
            os.replace(tmp, out / f"mesh_{sim.map_names[k]}.ply")
        collapse = sim.watch.after_evaluation(k, result.get("completion_ratio_pct"))
        if collapse is not None:
            _mark_diverged(sim, k, collapse)
        sim.timeline.append({"t": sim.env.now, "agent": k, **result, "team_coverage_pct": team})
        sim.bus(MetricsEvaluated(sim.env.now, k, {key: result[key] for key in SUMMARY_KEYS
                                                  if isinstance(result.get(key), float)
                                                  and math.isfinite(result[key])}))
    if math.isfinite(team):
        sim.bus(MetricsEvaluated(sim.env.now, -1, {"team_coverage_pct": team}))
    if out is not None:
        _flush(sim, out, wall0)


def _comm_summary(sim: Simulation) -> dict[str, Any]:
    """The message log's summary, its totals with ``in_flight``: messages sent that had not
    been delivered or dropped yet (at the end of a run: still queued or on the air), which
    neither the totals' ``sent`` nor messages.csv counts."""
    if sim.channel is None:
        return {}
    comm = sim.channel.log.summary()
    comm["total"]["in_flight"] = sim.channel.n_sent - comm["total"]["sent"]
    return comm


def _atomic_messages_csv(sim: Simulation, out: Path) -> None:
    if sim.channel is None or not sim.scenario.output.message_log:
        return
    path = out / "messages.csv"
    tmp = out / f".messages.{uuid.uuid4().hex[:8]}.csv.tmp"
    sim.channel.log.write_csv(tmp)
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    fsync_dir(out)


def _flush(sim: Simulation, out: Path, wall0: float) -> None:
    """Write the results so far atomically: messages.csv and a partial metrics.json (status
    ``interrupted``, the timeline and consensus probes so far, per agent its rounds, frames and
    state, metrics not evaluated). The final metrics.json replaces it when the run ends, so a
    run killed without warning (SIGKILL, power loss) keeps what it had at the last flush."""
    sc, env = sim.scenario, sim.env
    _atomic_messages_csv(sim, out)
    per_agent: dict[str, AgentMetrics] = {}
    for k, name in enumerate(sim.map_names):
        proc = sim.processes[k]
        per_agent[name] = AgentMetrics(
            rounds=proc.rounds, frames=proc.frames_seen, busy_s=proc.busy_s, diverged=proc.diverged is not None,
            diverged_round=proc.diverged[0] if proc.diverged else None,
            diverged_reason=proc.diverged[1] if proc.diverged else None,
            failed_reason=proc.failed,
            reason=f"partial result at t={env.now:.2f} s: final metrics not evaluated (the run did not finish)")
    comm = _comm_summary(sim)
    RunResult(
        status="interrupted",
        error=f"partial result written at t={env.now:.2f} s of {sc.duration:g} s while the run was going; "
              f"the run ended without finishing if this file remained",
        scenario=sc.name, method=sc.method, seed=sc.seed, n_agents=sc.agents.count,
        success_rate=sc.channel.success_rate, sim_time_s=env.now, wall_time_s=time.perf_counter() - wall0,
        per_agent=per_agent, summary={}, consensus_error=None,
        diverged_agents=[n for n, a in per_agent.items() if a.diverged],
        communication=comm.get("total", {}), communication_links=comm.get("links", {}),
        timeline=sim.timeline, consensus_timeline=sim.consensus_timeline,
        theta_bytes=int(sim.maps[0].theta.numel() * sim.maps[0].theta.element_size()),
    ).write(out / "metrics.json")


def _finish(sim: Simulation, out: Path, evaluator: Evaluator, status: Status, error: str | None,
            wall_s: float) -> RunResult:
    """Evaluate every agent's final map and write the run's outputs (metrics.json last)."""
    from ramensim.evaluation.summary import consensus_error, summarize_agents

    sc, env = sim.scenario, sim.env
    if sim.channel is not None:
        _atomic_messages_csv(sim, out)
    comm = _comm_summary(sim)
    poses = evaluator.poses_by_agent_until(env.now)
    team = evaluator.team_coverage_pct(np.concatenate(poses, axis=0))
    per_agent: dict[str, AgentMetrics] = {}
    finite_thetas = []
    for k, (name, m) in enumerate(zip(sim.map_names, sim.maps)):
        proc = sim.processes[k]
        entry: dict[str, Any] = {"rounds": proc.rounds, "frames": proc.frames_seen,
                                 "busy_s": proc.busy_s, "diverged": proc.diverged is not None,
                                 "failed_reason": proc.failed}
        if proc.diverged is not None:
            entry["diverged_round"], entry["diverged_reason"] = proc.diverged
            entry.update(evaluator.nan_metrics(f"agent diverged in round {proc.diverged[0]}: "
                                               f"{proc.diverged[1]}"))
        else:
            finite_thetas.append(m.theta.detach())
            mesh_path = out / f"mesh_{name}.ply" if sc.output.save_meshes else None
            entry.update(evaluator.score(m, poses, sim.fed_by(k), mesh_path=mesh_path))
        agent = AgentMetrics.model_validate({k: (None if isinstance(v, float) and math.isnan(v) else v)
                                             for k, v in entry.items()})
        per_agent[name] = agent
        sim.bus(MetricsEvaluated(env.now, k, {key: agent.metric(key) for key in SUMMARY_KEYS
                                              if math.isfinite(agent.metric(key))}))
    cons = consensus_error(finite_thetas) if len(finite_thetas) > 1 else 0.0
    live = [m for k, m in enumerate(sim.maps) if sim.processes[k].diverged is None]
    wcons = _weighted_consensus(sim, live) if len(live) > 1 else 0.0
    summary = summarize_agents({n: {key: a.metric(key) for key in SUMMARY_KEYS} for n, a in per_agent.items()})
    diverged = [n for n, a in per_agent.items() if a.diverged]
    if diverged:
        sim.bus(Notice(env.now, f"diverged: {', '.join(diverged)}", "warning"))
        if status == "ok":
            status = "diverged"
    failed = {n: a.failed_reason for n, a in per_agent.items() if a.failed_reason}
    if failed and status in ("ok", "diverged"):
        status = "failed"
        error = "; ".join(f"{n} stopped: {why}" for n, why in failed.items())
    result = RunResult(
        status=status, error=error, scenario=sc.name, method=sc.method, seed=sc.seed,
        n_agents=sc.agents.count, success_rate=sc.channel.success_rate,
        sim_time_s=env.now, wall_time_s=wall_s, per_agent=per_agent,
        summary={k: MetricSummary.model_validate({f: (None if isinstance(v, float) and math.isnan(v) else v)
                                                  for f, v in st.items()}) for k, st in summary.items()},
        consensus_error=cons, consensus_error_weighted=wcons, diverged_agents=diverged,
        team_coverage_pct=team if math.isfinite(team) else None,
        communication=comm.get("total", {}), communication_links=comm.get("links", {}),
        timeline=sim.timeline, consensus_timeline=sim.consensus_timeline,
        theta_bytes=int(sim.maps[0].theta.numel() * sim.maps[0].theta.element_size()),
    )
    sim.bus(MetricsEvaluated(env.now, -1, {"consensus_error": cons, "consensus_error_weighted": wcons,
                                           **({"team_coverage_pct": team} if math.isfinite(team) else {})}))
    result.write(out / "metrics.json")
    log.info("finished: %s", _one_line(result))
    return result


def _one_line(result: RunResult) -> str:
    parts = []
    for key in METRIC_KEYS:
        s = result.summary.get(key)
        if s is not None and s.mean is not None and math.isfinite(s.mean):
            parts.append(f"{key}={s.mean:.2f}±{s.std:.2f}")
    parts.append(f"consensus_error={result.consensus_error:.3g}")
    return ", ".join(parts)
