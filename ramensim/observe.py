"""What a run observes and writes while and after it runs: the maps' meshes and uncertainty for
the recorder, the consensus probes (eq. CE-1, CE-2), the periodic evaluation (the timeline),
and the run's result (metrics.json, messages.csv), partial (:func:`flush`) and final
(:func:`finish`), both assembled by :func:`collect_result`.

The run's lifecycle (``ramensim.lifecycle``) schedules these on the simulation that
``ramensim.sim`` built; nothing here changes what the agents do, except the divergence rule's
``mark_diverged`` after an evaluation collapses.
"""
from __future__ import annotations

import logging
import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from ramensim.core.events import MapSnapshot, MetricsEvaluated, Notice, UncertaintySnapshot
from ramensim.core.files import WriteFailed, atomic_write_with
from ramensim.core.results import METRIC_KEYS, SUMMARY_KEYS, AgentMetrics, MetricSummary, RunResult, Status
from ramensim.scoring import Evaluator
from ramensim.evaluation.mesh import export_ply
from ramensim.sim import Simulation

log = logging.getLogger(__name__)

STAGES_ENV = "RAMENSIM_EVAL_STAGES"
"""``RAMENSIM_EVAL_STAGES=1``: metrics.json's ``build`` also holds ``eval_stage_s``, every
evaluation's wall-clock cost per stage (:meth:`ramensim.scoring.Evaluator.record_evaluation`).
Off by default: every field of metrics.json but ``wall_time_s`` is reproducible, and these
are wall-clock figures. run.log has them either way (one line per evaluation)."""


def stages_text(record: dict[str, Any]) -> str:
    """An evaluation's cost record in words: each stage's wall-clock seconds, largest first."""
    stages = sorted(record["stage_s"].items(), key=lambda kv: -kv[1])
    return ", ".join(f"{k} {v:.2f}" for k, v in stages if v >= 0.005) or "no stage"


def alive(sim: Simulation, k: int) -> bool:
    """Whether agent ``k``'s map is worth observing: it has mapped and has not diverged."""
    p = sim.processes[k]
    return p.diverged is None and p.rounds > 0


def snapshot_meshes(sim: Simulation, evaluator: Evaluator) -> None:
    for k, m in enumerate(sim.settled_maps()):  # every round started before now is in the maps, as inline
        if alive(sim, k):
            mesh = evaluator.mesh_of(m, voxel_m=sim.scenario.recording.mesh_voxel_m)
            sim.bus(MapSnapshot(sim.env.now, k, np.asarray(mesh.vertices), np.asarray(mesh.faces),
                                np.asarray(mesh.visual.vertex_colors)[:, :3] if len(mesh.vertices) else
                                np.zeros((0, 3), np.uint8)))


def snapshot_uncertainty(sim: Simulation) -> None:
    for k, m in enumerate(sim.settled_maps()):
        if alive(sim, k):
            pts, counts = m.coarse_level_points_and_visits()
            sim.bus(UncertaintySnapshot(sim.env.now, k, pts, counts))


def probe_consensus(sim: Simulation) -> None:
    """Consensus error (RMS pairwise difference of the maps' parameters) and the maps' RMS,
    over the agents that are mapping and have not diverged."""
    from ramensim.evaluation.summary import consensus_error

    live = [m for k, m in enumerate(sim.settled_maps()) if alive(sim, k)]
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


def evaluate_now(sim: Simulation, evaluator: Evaluator, out: Path | None = None, wall0: float = 0.0) -> None:
    """Score every live map now (the timeline), check the collapse rule, keep each map's latest
    mesh (atomically replaced) and flush the results so far. Its wall time goes to run.log
    (how evaluation cost grows with simulated time: the speed issue's profile).

    With an evaluation lane (:class:`EvaluationLane`, ``sim.eval_lane``) the scoring runs on
    the lane's thread on frozen copies of the maps while the simulation goes on; its results
    enter the timeline, the recording and the flushed files when the next evaluation starts or
    the run ends (:meth:`EvaluationLane.publish`), with the simulated time they were taken at."""
    lane = sim.eval_lane
    if lane is not None:
        lane.publish()  # the previous evaluation first: the timeline stays in order
    started = time.perf_counter()
    maps = sim.settled_maps()
    t = sim.env.now
    poses = evaluator.poses_by_agent_until(t)
    jobs = []
    scored = set(evaluator.periodic_sample([k for k in range(len(maps)) if alive(sim, k)]))
    for k, m in enumerate(maps):
        if k not in scored:
            continue
        path = out / f"mesh_{sim.map_names[k]}.ply" if out is not None and sim.scenario.output.save_meshes else None
        jobs.append((k, m if lane is None else m.frozen_copy(), sim.fed_by(k), path))

    def score() -> tuple[float, list[tuple[int, dict[str, Any]]], dict[str, Any]]:
        t0, times = time.perf_counter(), {}
        team = evaluator.team_coverage_pct(np.concatenate(poses, axis=0), times=times)
        results = evaluator.score_all([(m, fed, path) for _, m, fed, path in jobs], poses, run=sim.engine.map,
                                      at_once=sim.engine.workers, times=times, periodic=True)
        record = evaluator.record_evaluation(t, times, time.perf_counter() - t0, len(jobs))
        return team, [(k, r) for (k, *_), r in zip(jobs, results)], record

    if lane is not None:
        lane.submit(t, score, started, out, wall0)
        return
    _publish_evaluation(sim, t, *score(), started, out, wall0)


def _publish_evaluation(sim: Simulation, t: float, team: float, results: list[tuple[int, dict[str, Any]]],
                        record: dict[str, Any], started: float, out: Path | None, wall0: float) -> None:
    """An evaluation taken at simulated time ``t`` (s) into the run: the collapse rule, the
    timeline, the bus (recording) at ``t``, run.log (with its cost per stage, ``record``) and
    the flushed files."""
    for k, result in results:
        collapse = sim.watch.after_evaluation(k, result.get("completion_ratio_pct"))
        if collapse is not None:
            sim.processes[k].mark_diverged(collapse)
        sim.timeline.append({"t": t, "agent": k, **result, "team_coverage_pct": team})
        sim.bus(MetricsEvaluated(t, k, {key: result[key] for key in SUMMARY_KEYS
                                        if isinstance(result.get(key), float) and math.isfinite(result[key])}))
    if math.isfinite(team):
        sim.bus(MetricsEvaluated(t, -1, {"team_coverage_pct": team}))
    log.info("evaluation at t=%.0f s took %.2f s of wall time (scoring %.2f s: %s)", t,
             time.perf_counter() - started, record["wall_s"], stages_text(record))
    if out is not None:
        flush(sim, out, wall0)


class EvaluationLane:
    """Periodic evaluations off the critical path: one scoring thread that scores frozen copies
    of the maps (:meth:`ramensim.agents.map.NeuralMap.frozen_copy`) while the event loop and the
    team engine go on. At most one evaluation is in flight; it is published (timeline, recording
    at its own simulated time, run.log, flushed files) when the next one starts or the run ends,
    so the timeline, metrics.json and the meshes are those of scoring inline. One difference,
    for runs whose evaluation collapses (``ramensim.divergence``): the robot is marked diverged
    when that evaluation is published (the next evaluation's time, or the run's end), not at the
    time it was taken. ``threads``: cap of the scoring thread's map stages (1 beside the team
    engine's workers on a CPU; 0 = none)."""

    def __init__(self, sim: Simulation, threads: int = 0) -> None:
        from concurrent.futures import ThreadPoolExecutor

        from ramensim.agents.map.threads import set_thread_cap

        self.sim = sim
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="ramensim-eval",
                                        initializer=(lambda: set_thread_cap(threads)) if threads else None)
        self._pending: tuple[Any, float, float, Path | None, float] | None = None
        self.closed = False

    def submit(self, t: float, score: Any, started: float, out: Path | None, wall0: float) -> None:
        """Score in the background (``score() -> (team, [(agent, result)])``), taken at ``t`` s."""
        self._pending = (self._pool.submit(score), t, started, out, wall0)

    def publish(self) -> None:
        """Wait for the evaluation in flight, if any, and publish it (its exception, if it raised)."""
        if self._pending is None:
            return
        future, t, started, out, wall0 = self._pending
        self._pending = None
        team, results, record = future.result()
        _publish_evaluation(self.sim, t, team, results, record, started, out, wall0)

    def close(self) -> None:
        """Publish what is in flight and stop the thread."""
        self.closed = True
        try:
            self.publish()
        finally:
            self._pool.shutdown(wait=True)


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
    atomic_write_with(out / "messages.csv", sim.channel.log.write_csv)


def build_info(sim: Simulation) -> dict[str, Any]:
    """What computes this run's maps: kernel ``-march`` target, device, each stage's backend as
    ``<backend>@<threads>``, the team engine's mode and worker threads (``agents/rounds/``), and the host and build of :func:`ramensim.provenance.provenance`
    (CPU model, SIMD level, cores, GPU, host fingerprint, commit, dirty, versions) (RunResult.build)."""
    from ramensim.core.native import march
    from ramensim.provenance import provenance

    m = sim.maps[0]
    choices = {"decoder": getattr(m.decoders, "choice", None), "grid": m.grid_choice, "objective": m.objective_choice}
    backends = {stage: f"{ch.backend}@{ch.threads}" for stage, ch in choices.items() if ch is not None}
    return {**provenance(str(sim.device)), "march": march(), "device": str(sim.device), "backends": backends,
            "team_mode": sim.engine.mode, "team_workers": sim.engine.workers, "team_lockstep": sim.engine.lockstep,
            "team_largest_batch": sim.engine.largest_batch, "evaluation_lane": sim.eval_lane is not None}


def collect_result(sim: Simulation, status: Status, error: str | None, wall_s: float,
                   per_agent: dict[str, AgentMetrics], summary: dict[str, MetricSummary] | None = None,
                   consensus: float | None = None, consensus_weighted: float | None = None,
                   team_coverage_pct: float | None = None) -> RunResult:
    """The run's :class:`RunResult` from its state now (scenario, clock, message log, timelines,
    map size) and what the caller evaluated: the one place a result is assembled, for the
    periodic partial results (:func:`flush`) and the final one (:func:`finish`)."""
    sc, env = sim.scenario, sim.env
    comm = _comm_summary(sim)
    return RunResult(
        status=status, error=error, scenario=sc.name, method=sc.method, seed=sc.seed,
        n_agents=sc.agents.count, success_rate=sc.channel.success_rate,
        sim_time_s=env.now, wall_time_s=wall_s, per_agent=per_agent, summary=summary or {},
        consensus_error=consensus, consensus_error_weighted=consensus_weighted,
        diverged_agents=[n for n, a in per_agent.items() if a.diverged],
        team_coverage_pct=team_coverage_pct,
        communication=comm.get("total", {}), communication_links=comm.get("links", {}),
        timeline=sim.timeline, consensus_timeline=sim.consensus_timeline,
        theta_bytes=int(sim.maps[0].theta.numel() * sim.maps[0].theta.element_size()),
        build=build_info(sim),
    )


def flush(sim: Simulation, out: Path, wall0: float) -> None:
    """Write the results so far atomically: messages.csv and a partial metrics.json (status
    ``interrupted``, the timeline and consensus probes so far, per agent its rounds, frames and
    state, metrics not evaluated). The final metrics.json replaces it when the run ends, so a
    run killed without warning (SIGKILL, power loss) keeps what it had at the last flush."""
    sc, env = sim.scenario, sim.env
    try:  # a full disk mid-run: the run goes on (its results are in memory), the next flush retries
        _atomic_messages_csv(sim, out)
    except OSError as exc:
        log.warning("flush at t=%.2f s: %s", env.now, exc)
    per_agent: dict[str, AgentMetrics] = {}
    for k, name in enumerate(sim.map_names):
        proc = sim.processes[k]
        per_agent[name] = AgentMetrics(
            rounds=proc.rounds, frames=proc.frames_seen, busy_s=proc.busy_s, diverged=proc.diverged is not None,
            diverged_round=proc.diverged[0] if proc.diverged else None,
            diverged_reason=proc.diverged[1] if proc.diverged else None,
            failed_reason=proc.failed,
            reason=f"partial result at t={env.now:.2f} s: final metrics not evaluated (the run did not finish)")
    error = (f"partial result written at t={env.now:.2f} s of {sc.duration:g} s while the run was going; "
             f"the run ended without finishing if this file remained")
    try:
        collect_result(sim, "interrupted", error, time.perf_counter() - wall0, per_agent).write(out / "metrics.json")
    except OSError as exc:
        log.warning("flush at t=%.2f s: %s", env.now, exc)


def _nan_to_none(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in d.items()}


def finish(sim: Simulation, out: Path, evaluator: Evaluator, status: Status, error: str | None,
           wall0: float) -> RunResult:
    """Evaluate every agent's final map and write the run's outputs: the small ones first
    (messages.csv, metrics.json), then the meshes, each atomically. The run's wall time is
    the one figure every output reports (metrics.json, run.log's ``finished:`` line, the
    summary): from ``wall0`` (``time.perf_counter()`` when the run folder was taken, before
    building the simulation) to the final evaluation's end (s). A file that cannot be
    written (a full disk) does not stop the others: once all are tried, :class:`WriteFailed`
    names each missing file and the bytes it needed (metrics.json, if it was written, is
    valid and complete)."""
    from ramensim.evaluation.summary import consensus_error, summarize_agents

    sc, env = sim.scenario, sim.env
    lane = sim.eval_lane
    if lane is not None and not lane.closed:
        try:
            lane.close()  # the last periodic evaluation enters the timeline before the final one
        except Exception as exc:  # noqa: BLE001 - as an evaluation failing inside the event loop
            log.error("a periodic evaluation failed: %s", exc)
            if status in ("ok", "diverged"):
                status, error = "failed", f"periodic evaluation failed: {type(exc).__name__}: {exc}"
    maps = sim.settled_maps()
    unwritten: list[OSError] = []
    if sim.channel is not None:
        try:
            _atomic_messages_csv(sim, out)
        except OSError as exc:
            log.error("%s", exc.strerror or exc)
            unwritten.append(exc)
    meshes: dict[str, Any] = {}
    t0, times = time.perf_counter(), {}
    poses = evaluator.poses_by_agent_until(env.now)
    team = evaluator.team_coverage_pct(np.concatenate(poses, axis=0), times=times)
    per_agent: dict[str, AgentMetrics] = {}
    finite_thetas = []
    live = [k for k in range(len(maps)) if sim.processes[k].diverged is None]
    keep = (lambda i, mesh: meshes.__setitem__(sim.map_names[live[i]], mesh)) if sc.output.save_meshes else None
    # the meshes on the team engine's workers, the culling and metrics in order here
    scores = dict(zip(live, evaluator.score_all([(maps[k], sim.fed_by(k), None) for k in live], poses,
                                                run=sim.engine.map, on_mesh=keep,
                                                at_once=sim.engine.workers, times=times,
                                                overlap=sim.engine.parallel_map)))
    record = evaluator.record_evaluation(env.now, times, time.perf_counter() - t0, len(live), final=True)
    log.info("final evaluation at t=%.0f s took %.2f s of wall time: %s", env.now, record["wall_s"],
             stages_text(record))
    for k, (name, m) in enumerate(zip(sim.map_names, maps)):
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
            entry.update(scores[k])
        agent = AgentMetrics.model_validate(_nan_to_none(entry))
        per_agent[name] = agent
        sim.bus(MetricsEvaluated(env.now, k, {key: agent.metric(key) for key in SUMMARY_KEYS
                                              if math.isfinite(agent.metric(key))}))
    cons = consensus_error(finite_thetas) if len(finite_thetas) > 1 else 0.0
    live = [m for k, m in enumerate(maps) if sim.processes[k].diverged is None]
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
    result = collect_result(
        sim, status, error, time.perf_counter() - wall0, per_agent,
        summary={k: MetricSummary.model_validate(_nan_to_none(st)) for k, st in summary.items()},
        consensus=cons, consensus_weighted=wcons, team_coverage_pct=team if math.isfinite(team) else None)
    if os.environ.get(STAGES_ENV, "") == "1" and result.build is not None:
        result.build["eval_stage_s"] = list(evaluator.stage_records)
    sim.bus(MetricsEvaluated(env.now, -1, {"consensus_error": cons, "consensus_error_weighted": wcons,
                                           **({"team_coverage_pct": team} if math.isfinite(team) else {})}))
    result.write(out / "metrics.json")
    log.info("finished: %s", one_line(result))
    if evaluator.cfg.export_mesh:
        for name, mesh in meshes.items():
            try:
                export_ply(mesh, out / f"mesh_{name}.ply")
            except OSError as exc:
                log.error("%s", exc.strerror or exc)
                unwritten.append(exc)
    if unwritten:
        raise WriteFailed(unwritten[0].errno, f"the run finished and its metrics are in {out / 'metrics.json'}, "
                                              f"but {len(unwritten)} file(s) could not be written: "
                          + "; ".join(str(e.strerror or e) for e in unwritten))
    return result


def one_line(result: RunResult) -> str:
    """run.log's ``finished:`` line: simulated and wall time, each metric's mean ± std over
    maps, the consensus error and the messages."""
    parts = [f"{result.sim_time_s:.1f} s simulated in {result.wall_time_s:.1f} s of wall time"]
    for key in METRIC_KEYS:
        s = result.summary.get(key)
        if s is not None and s.mean is not None and math.isfinite(s.mean):
            parts.append(f"{key}={s.mean:.2f}±{s.std:.2f}")
    parts.append(f"consensus_error={result.consensus_error:.3g}")
    messages = result.messages_text()
    return ", ".join(parts) + (f"; messages: {messages}" if messages else "")
