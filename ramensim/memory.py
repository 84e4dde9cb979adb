"""Memory a run will need, estimated before it starts, so that a scenario too large for the
machine is refused with the reason instead of being killed by the kernel's OOM killer.

Almost all of a run's memory is parameter-sized vectors (n float32 / int32, 4n bytes; n is the
map's hash-grid size, 2^log2_hashmap_size x levels x features): per map its parameters, Adam's
two moments, the gradient and the visit counts (:data:`MAP_VECTORS`), per agent the method's
buffers and per neighbour what the method keeps of it (``MethodSpec.memory_vectors``). With
degree d per agent that is n_agents x (5 + a + d x e) vectors: quadratic in the number of
agents on a complete graph. Measured on the 2-core dev machine (docs/RELIABILITY.md): 40
agents of RAMEN on a ring (4 s), 5.4 GiB peak RSS against an estimate of 5.8 GiB; the default
scenario (3 agents, 10 s) 0.91 GiB against 1.36 GiB; 40 agents on the complete graph, estimate
52 GiB: the run was killed by the OOM killer at 23 GiB before this check existed.
"""
from __future__ import annotations

import logging
import math
import os
from typing import Any, Sequence

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

MAP_VECTORS = 5
"""Parameter-sized vectors of one map: theta, Adam's m and v, the gradient, the visit counts."""
BASE_BYTES = 1 << 30
"""Everything else (interpreter, torch, the scene, frames, evaluation): about 1 GiB."""
SKIP_ENV = "RAMENSIM_SKIP_MEMORY_CHECK"


def estimate_bytes(n_params: int, n_maps: int, degrees: Sequence[int], vectors: tuple[int, int],
                   lent: int = 0) -> int:
    """Bytes a run needs: ``n_maps`` maps of ``n_params`` parameters, per agent k the method's
    ``vectors`` = (per agent, per neighbour) times ``degrees[k]`` neighbours, and ``lent``
    vectors of rounds' work buffers (:func:`lent_vectors`)."""
    per_agent, per_link = vectors
    count = n_maps * MAP_VECTORS + sum(per_agent + per_link * d for d in degrees) + lent
    return BASE_BYTES + 4 * int(n_params) * count


def concurrent_rounds(n_maps: int, device: Any = "cpu", settings: Any = None) -> int:
    """Rounds that run at once, as the team engine's settings say (``settings``, else asked of
    ``agents/rounds/modes.engine_settings`` for ``n_maps`` maps on ``device``): every map's in
    lockstep batches, the worker threads, 1 inline."""
    if settings is None:
        from ramensim.agents.rounds import engine_settings

        try:
            settings = engine_settings(n_maps, device)
        except ValueError:  # a bad RAMENSIM_TEAM_* value: refused with its message when the run builds
            return n_maps
    return int(settings.rounds_at_once)


def lent_vectors(spec: Any, n_maps: int, device: Any = "cpu", settings: Any = None) -> int:
    """Parameter-sized vectors of the rounds' work buffers lent from the method's pool
    (``MethodSpec.round_vectors``, ``agents/consensus/scratch.py``): one set per round at once
    (:func:`concurrent_rounds`). ``device``: the maps' torch device (:func:`planned_device` for
    a scenario not built); ``settings``: the engine's, when the caller has them."""
    return int(getattr(spec, "round_vectors", 0)) * concurrent_rounds(n_maps, device, settings)


def planned_device(sc: Any) -> Any:
    """The torch device ``sc``'s maps will be on, by the run's own rule
    (:func:`ramensim.agents.map.config.resolve_device`: ``auto`` is cuda where torch sees one),
    without refusing ``cuda`` where torch sees none (a sweep planned here may run on a GPU
    elsewhere; the run itself refuses it)."""
    from ramensim.agents.map.config import resolve_device

    return resolve_device(sc.map.device, check=False)


def available_bytes() -> int | None:
    """MemAvailable of /proc/meminfo (bytes), else None (not Linux)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def check_memory(sc: Any, n_params: int, n_maps: int, topology: Any, vectors: tuple[int, int],
                 available: int | None = None, lent: int = 0) -> int:
    """Refuse (InputError) a run whose estimate exceeds the memory available now; log a
    warning above half of it. Returns the estimate (bytes). ``RAMENSIM_SKIP_MEMORY_CHECK=1``
    turns the refusal into a warning."""
    n = sc.agents.count
    dynamic = bool(getattr(topology, "dynamic", False))
    degrees = [n - 1 if dynamic else len(topology.neighbours(k)) for k in range(n)] if vectors[1] else [0] * n
    need = estimate_bytes(n_params, n_maps, degrees, vectors, lent)
    have = available_bytes() if available is None else available
    if have is None:
        return need
    gib = 1 << 30
    what = (f"about {need / gib:.1f} GiB ({n} agents of {sc.method}, {n_params:,} parameters per map, "
            f"{'up to ' if dynamic else ''}{max(degrees) if degrees else 0} neighbours each on the "
            f"'{sc.topology.kind}' topology)")
    if need > have:
        msg = (f"scenario: this run needs {what} but {have / gib:.1f} GiB are available; every agent keeps "
               f"parameter-sized state per neighbour, so memory grows with agents x neighbours. Use a sparser "
               f"topology (topology.kind ring, path, grid or disk), fewer agents (agents.count) or smaller maps "
               f"(map.log2_hashmap_size); {SKIP_ENV}=1 runs it anyway.")
        if os.environ.get(SKIP_ENV, "") not in ("", "0"):
            log.warning("%s", msg)
        else:
            raise InputError(msg)
    elif need > have / 2:
        log.warning("this run needs %s, more than half of the %.1f GiB available", what, have / gib)
    return need


def scenario_estimate(sc: Any) -> int:
    """:func:`estimate_bytes` of a validated scenario without building it: maps of
    ``sc.map.n_params`` parameters (one per agent, or one for a method that merges frames), and
    the method's per-agent and per-neighbour vectors over the topology's degrees (a disk graph
    counted as complete: any two agents may meet)."""
    from ramensim.agents.consensus.registry import get_method
    from ramensim.channels import Topology

    spec = get_method(sc.method)
    n = sc.agents.count
    n_maps = 1 if spec.merges_frames else n
    if sc.topology.kind == "disk":
        degrees = [n - 1] * n
    else:
        topo = Topology(sc.topology, n, None)
        degrees = [len(topo.neighbours(k)) for k in range(n)]
    if not spec.memory_vectors[1]:
        degrees = [0] * n
    return estimate_bytes(sc.map.n_params, n_maps, degrees, spec.memory_vectors,
                          lent_vectors(spec, n_maps, planned_device(sc)))


def sweep_workers_that_fit(estimates: dict[str, int], workers: int, available: int | None = None) -> int:
    """How many of ``workers`` parallel runs fit the memory available now, given each planned
    run's estimate (bytes, by point name): refuses (InputError naming the run) a point that
    alone exceeds it, and otherwise lowers the worker count until the largest runs that could
    run together fit, with a warning. ``RAMENSIM_SKIP_MEMORY_CHECK=1`` skips the check."""
    have = available_bytes() if available is None else available
    if have is None or not estimates or os.environ.get(SKIP_ENV, "") not in ("", "0"):
        return workers
    gib = 1 << 30
    largest = sorted(estimates.items(), key=lambda kv: -kv[1])
    name, need = largest[0]
    if need > have:
        raise InputError(f"sweep point '{name}' needs about {need / gib:.1f} GiB but {have / gib:.1f} GiB are "
                         f"available on this machine; nothing was run. Every agent keeps parameter-sized state "
                         f"per neighbour: use a sparser topology, fewer agents or smaller maps "
                         f"(map.log2_hashmap_size) for that point, or {SKIP_ENV}=1 to run it anyway.")
    fit = workers
    while fit > 1 and sum(v for _, v in largest[:fit]) > have:
        fit -= 1
    if fit < workers:
        log.warning("sweep: %d parallel runs of the largest points (%s) would need %.1f GiB of the %.1f GiB "
                    "available; running %d at a time", workers, ", ".join(n for n, _ in largest[:workers]),
                    sum(v for _, v in largest[:workers]) / gib, have / gib, fit)
    return fit


RAY_BYTES = 40
"""Bytes of one keyframe ray in the ray database: origin, direction, colour (3 float32 each) and
depth (one float32)."""


def robot_breakdown(sc: Any) -> list[tuple[str, int]]:
    """What one robot of scenario ``sc`` costs in memory, item by item (bytes), as
    :func:`estimate_bytes` counts it plus the ray database at the run's end: its map's
    parameters, Adam's two moments, the gradient and the visit counts (n float32 / int32 each),
    the method's own vectors, its state per neighbour (x its largest degree), and the keyframe
    rays it will hold after ``duration`` s (``keyframe_pixel_share`` of each keyframe's pixels).
    A neighbour's copy is stored once however many robots hold the same sent state
    (``agents/encoding.py``): the per-neighbour figure is the method's declared bound, which
    assumes every neighbour holds a different version."""
    from ramensim.agents.consensus.registry import get_method

    n = int(sc.map.n_params)
    spec = get_method(sc.method)
    per_agent, per_link = spec.memory_vectors
    degree = 0
    if per_link and sc.agents.count > 1:
        if sc.topology.kind == "disk":
            degree = sc.agents.count - 1
        else:
            from ramensim.channels import Topology

            topo = Topology(sc.topology, sc.agents.count, None)
            degree = max(len(topo.neighbours(k)) for k in range(sc.agents.count))
    cam = sc.world.camera
    keyframes = math.floor(sc.duration * cam.fps / cam.keyframe_every) + 1
    rays = keyframes * max(1, math.ceil(sc.map.keyframe_pixel_share * cam.width * cam.height))
    return [("map parameters (theta)", 4 * n), ("optimizer state (Adam m, v)", 8 * n),
            ("gradient buffer", 4 * n), ("visit counts (eq. 18)", 4 * n),
            (f"method state ({sc.method}: {per_agent} vectors)", 4 * n * per_agent),
            (f"per-neighbour state ({per_link} vectors x {degree} neighbours)", 4 * n * per_link * degree),
            (f"ray database ({keyframes} keyframes at {sc.duration:g} s)", RAY_BYTES * rays)]


def describe(sc: Any, available: int | None = None) -> str:
    """The memory a run of ``sc`` will need, in words: per robot item by item, the team, the
    whole run's estimate against what this machine has now."""
    mib, gib = 1 << 20, 1 << 30
    items = robot_breakdown(sc)
    robot = sum(b for _, b in items)
    need = scenario_estimate(sc) + sc.agents.count * items[-1][1]
    have = available_bytes() if available is None else available
    lines = [f"memory of one robot ({sc.map.n_params:,} parameters per map):"]
    lines += [f"  {what:<58} {b / mib:>9.1f} MiB" for what, b in items]
    lines.append(f"  {'one robot in all':<58} {robot / mib:>9.1f} MiB")
    from ramensim.agents.consensus.registry import get_method

    spec = get_method(sc.method)
    n_maps = 1 if spec.merges_frames else sc.agents.count
    dev = planned_device(sc)
    if spec.round_vectors:
        sets = concurrent_rounds(n_maps, dev)
        what = f"rounds' work buffers, the team's ({sets} at once x {spec.round_vectors} vectors)"
        lines.append(f"  {what:<58} {4 * sc.map.n_params * spec.round_vectors * sets / mib:>9.1f} MiB")
    lines.append(f"the run: about {need / gib:.2f} GiB for {sc.agents.count} robots on the "
                 f"'{sc.topology.kind}' topology (about {BASE_BYTES / gib:.0f} GiB of it the interpreter, "
                 f"scene, frames and evaluation)"
                 + (f"; {have / gib:.1f} GiB available now: " + ("fits" if need <= have else "does NOT fit")
                    if have is not None else ""))
    return "\n".join(lines)
