"""Simulated-time sanity: how many events a scenario would schedule, estimated before it runs.

A run's wall time grows with the number of SimPy events, and a few keys multiply it without
bound: ``agents.compute.seconds_per_iteration: 1e-9`` makes a round cost a nanosecond of
simulated time (10^10 rounds in 10 s), a huge camera ``fps`` or a tiny period does the same
for frames and periodic work. :func:`estimate_events` counts, per kind, the events the
scenario implies (upper estimates: a round is charged at least one optimiser iteration at the
fastest agent's speed and the lowest jitter draw); :func:`check_budget` refuses a scenario
whose total exceeds :data:`MAX_EVENTS`, or whose expensive periodic work (evaluations, mesh
snapshots) exceeds :data:`MAX_EVALUATIONS`, with the estimate in the message.
"""
from __future__ import annotations

import math
from typing import Any

from ramensim.agents.consensus import get_method

MAX_EVENTS = 10_000_000
"""Most events (frames, mapping rounds, messages, periodic ticks) a scenario may imply."""
MAX_EVALUATIONS = 10_000
"""Most periodic evaluations or mesh snapshots (each extracts a mesh per map)."""
MIN_ROUND_S = 1e-9
"""Floor of one round's simulated cost (``ClockModel.cost``), seconds."""

def _ticks(duration: float, period: float | None) -> float:
    return 0.0 if period is None or period <= 0 else duration / period


def estimate_events(sc: Any) -> dict[str, float]:
    """Upper estimates of the events of scenario ``sc`` (a Scenario), by kind."""
    n = sc.agents.count
    T = sc.duration
    scene = sc.world.scene
    if getattr(scene, "kind", "builtin") in ("builtin", "mesh"):
        fps = sc.world.camera.fps
    else:  # datasets: their own frame rate, thinned by the stride, capped by max_frames
        fps = getattr(scene, "fps", sc.world.camera.fps) / max(1, getattr(scene, "stride", 1))
    frames = n * T * fps
    max_frames = getattr(scene, "max_frames", None)
    if max_frames is not None:
        frames = min(frames, float(max_frames) * n)
    comp = sc.agents.compute
    spec = get_method(sc.method)  # the method declares its steps per round (MethodSpec.steps_per_round)
    iters = sc.consensus.primal_steps if spec.steps_per_round == "primal_steps" else 1
    speeds = [sc.agents.speed(k) for k in range(n)]
    if comp.mode == "wall":
        round_s = max(MIN_ROUND_S, 1e-4 * min(speeds))  # a measured round takes at least ~0.1 ms
    else:
        round_s = max(MIN_ROUND_S, iters * comp.seconds_per_iteration * min(speeds) * (1 - comp.jitter))
    rounds = n * T / round_s
    degree = n - 1
    if sc.radio.mode == "every_round":
        messages = rounds * degree
    else:
        messages = n * degree * _ticks(T, sc.radio.period_s)
    rec = sc.recording
    recording = rec.mode != "off"
    evaluations = _ticks(T, sc.evaluation.every_s)
    snapshots = _ticks(T, rec.mesh_period_s) if recording else 0.0
    periodic = (evaluations + snapshots
                + (_ticks(T, rec.uncertainty_period_s) if recording else 0.0)
                + _ticks(T, sc.evaluation.consensus_every_s)
                + _ticks(T, sc.channel.link_monitor_period_s)
                + _ticks(T, getattr(sc.output, "flush_every_s", None))
                + (n * degree / 2 * _ticks(T, sc.channel.windows.period_s)
                   if sc.channel.windows.kind == "periodic" else 0.0))
    return {"frames": frames, "rounds": rounds, "messages": messages, "periodic": periodic,
            "evaluations": evaluations, "mesh_snapshots": snapshots,
            "total": frames + rounds + messages + periodic}


def _fmt(x: float) -> str:
    return f"{x:.3g}" if math.isfinite(x) else "infinitely many"


def check_budget(sc: Any) -> None:
    """ValueError (one sentence, with the estimate and the keys that drive it) when ``sc``
    implies more than :data:`MAX_EVENTS` events or :data:`MAX_EVALUATIONS` evaluations."""
    est = estimate_events(sc)
    if not est["total"] <= MAX_EVENTS:
        parts = ", ".join(f"{k} {_fmt(v)}" for k, v in est.items() if k in ("frames", "rounds", "messages",
                                                                              "periodic"))
        raise ValueError(
            f"the scenario would schedule about {_fmt(est['total'])} simulation events ({parts}) in "
            f"duration={sc.duration:g} s, more than the {MAX_EVENTS:.0e} a run may have; expected a "
            f"longer agents.compute.seconds_per_iteration (now {sc.agents.compute.seconds_per_iteration:g} s), "
            f"a lower camera fps, longer periods or a shorter duration")
    worst = max(est["evaluations"], est["mesh_snapshots"])
    if not worst <= MAX_EVALUATIONS:
        raise ValueError(
            f"the scenario would evaluate or snapshot the maps about {_fmt(worst)} times "
            f"(evaluation.every_s={sc.evaluation.every_s}, recording.mesh_period_s={sc.recording.mesh_period_s}) "
            f"in duration={sc.duration:g} s, more than {MAX_EVALUATIONS}; expected longer periods")
