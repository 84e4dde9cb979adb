"""What ``ramensim doctor`` says about the backends in use beside the map's per-stage choice:
native kernels or the torch fallback and why, CUDA, Embree ray casting, rerun, threads, and a
measured mapping speed in field samples per second."""
from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass
from importlib import metadata
from typing import Any


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


@dataclass
class NativeStatus:
    """Whether the map runs its compiled C kernels, and if not why, how much slower and the fix."""

    in_use: bool
    why: str = ""
    slowdown: str = ""
    fix: str = ""
    """The remedy, starting with 'to fix:'."""


def native_status(cfg: Any) -> NativeStatus:
    """The compiled kernels' state for map config ``cfg`` (builds them on first call)."""
    from ramensim.agents.map import _native
    from ramensim.core.native import fix_hint, native_disabled

    fix = fix_hint()  # the one wording of the fix ("to fix: ..."), shared with the run's warning
    slowdown = ("the map runs its pure-torch path, roughly 30x slower per mapping iteration "
                "(docs/MAP_PERFORMANCE.md: 26,000 vs 742,000 field samples/s on one core)")
    from ramensim.agents.map.config import resolve_device

    if resolve_device(cfg.device, check=False).type != "cpu":  # the run's rule: auto is cuda where torch sees one
        return NativeStatus(False, f"map.device = {cfg.device}: the C kernels are for the CPU")
    if not cfg.native:
        return NativeStatus(False, "map.native = false in the scenario", slowdown, "to fix: set map.native: true")
    if native_disabled():
        return NativeStatus(False, "RAMENSIM_NO_NATIVE is set", slowdown, "to fix: unset RAMENSIM_NO_NATIVE")
    compiler = _native._compiler()  # noqa: SLF001
    if _native.get_lib() is not None:
        return NativeStatus(True)
    if not compiler or shutil.which(compiler[0]) is None:
        why = f"no C compiler: {' '.join(compiler) or '$CC'} was not found" + \
              (" ($CC)" if os.environ.get("CC") else " (set CC to use another)")
    else:
        why = f"the kernels did not build with {' '.join(compiler)} (the warning above says why)"
    return NativeStatus(False, why, slowdown, fix)


def backend_lines(cfg: Any) -> list[str]:
    """One line per backend: map kernels, CUDA, ray casting, rerun, threads."""
    import torch
    import trimesh

    st = native_status(cfg)
    if st.in_use:
        lines = ["map kernels: native C (OpenMP), compiled for this CPU"]
    else:
        lines = [f"map kernels: FALLBACK, pure torch: {st.why}"]
        if st.slowdown:
            lines.append(f"  WARNING: {st.slowdown}; {st.fix}")
    if torch.cuda.is_available():
        names = ", ".join(torch.cuda.get_device_name(i) for i in range(torch.cuda.device_count()))
        lines.append(f"CUDA: available, CUDA {torch.version.cuda}, {names}; the map runs on "
                     f"map.device = {cfg.device}")
    elif torch.version.cuda is None:
        lines.append(f"CUDA: none (torch {torch.__version__} is a CPU build); the map runs on the CPU")
    else:
        lines.append(f"CUDA: torch built for CUDA {torch.version.cuda} but no GPU is visible; the map "
                     f"runs on the CPU")
    if trimesh.ray.has_embree:
        lines.append(f"ray casting (camera, culling, path-loss walls): Embree (embreex {_version('embreex')})")
    else:
        lines.append("ray casting: Embree MISSING (package 'embreex'): RGB-D frames cannot be rendered; "
                     "to fix: pip install embreex")
    rerun = _version("rerun-sdk")
    lines.append(f"rerun: rerun-sdk {rerun}" if rerun else
                 "rerun: not installed (recording.mode other than 'off' will fail; pip install 'rerun-sdk==0.41.*')")
    omp = os.environ.get("OMP_NUM_THREADS")
    lines.append(f"threads: {os.cpu_count()} logical cores; torch {torch.get_num_threads()} intra-op, "
                 f"{torch.get_num_interop_threads()} inter-op; OMP_NUM_THREADS={omp if omp else 'unset'}; "
                 f"map.threads = {cfg.threads or 'auto (measured per stage, below)'}")
    return lines


@dataclass
class MapSpeed:
    """Measured speed of whole mapping iterations."""

    samples_per_s: float
    """Field samples per wall-clock second."""
    ms_per_iter: float
    """Median wall time of one iteration (ms)."""
    samples_per_iter: int
    iters: int


def measure_map_speed(cfg: Any, budget_s: float = 2.0, max_iters: int = 30) -> MapSpeed:
    """Time whole mapping iterations (sample rays, encode, decode, render, losses, backward,
    Adam step) of one map with settings ``cfg`` on a small analytic scene, for about
    ``budget_s`` seconds after two warm-up iterations (at least 3 timed). Samples per
    iteration = map.n_rays x (map.n_stratified + map.n_surface); the figure is the samples
    of one iteration over the median iteration time. Decoders are seeded random weights
    (same cost as trained ones)."""
    import statistics

    import torch

    from ramensim.agents.map import NeuralMap, synthetic
    from ramensim.agents.map.decoders import init_decoders
    from ramensim.core.alloc import keep_freed_memory

    keep_freed_memory()  # as a run does
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1), torch.Generator().manual_seed(2))
    for i, f in enumerate(synthetic.frames(8, 160, 120)):
        m.add_frame(f, keyframe=(i % 2 == 0))
    for _ in range(2):
        m.optimizer_step(m.loss_and_grad()[1])
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < 3 or (time.perf_counter() - start < budget_s and len(times) < max_iters):
        t0 = time.perf_counter()
        m.optimizer_step(m.loss_and_grad()[1])
        times.append(time.perf_counter() - t0)
    per_iter = cfg.n_rays * (cfg.n_stratified + cfg.n_surface)
    med = statistics.median(times)
    return MapSpeed(per_iter / med, med * 1e3, per_iter, len(times))


def cache_health(cache: "os.PathLike[str] | str") -> list[str]:
    """Lines on the kernel cache's health: every cached kernel (``*.so``) is loaded once to see
    whether it still loads (a truncated or corrupt one is rebuilt at its next use), every
    backend choice (``backend_*.json``) is checked as a run checks it (an invalid one is
    measured again at its next use)."""
    import ctypes
    import json
    from pathlib import Path

    from ramensim.agents.map import backend

    root = Path(cache)
    if not root.is_dir():
        return [f"cache {root}: empty (kernels are built and backends measured at first use)"]
    sos = sorted(root.glob("*.so"))
    bad_so = []
    for so in sos:
        try:
            ctypes.CDLL(str(so))
        except OSError:
            bad_so.append(so.name)
    choices = sorted(root.glob("backend_*.json"))
    bad_json = []
    for path in choices:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            bad_json.append(f"{path.name} (not JSON)")
            continue
        problem = backend._cache_problem(data) if isinstance(data, dict) else "not a JSON object"
        if problem is not None:
            bad_json.append(f"{path.name} ({problem})")
    size = sum(p.stat().st_size for p in root.iterdir() if p.is_file())
    lines = [f"cache {root}: {len(sos)} kernels, {len(choices)} backend choices, {size / 2**20:.1f} MiB"]
    lines.append(f"  kernels: {'all load' if not bad_so else f'{len(bad_so)} do not load, rebuilt at next use: ' + ', '.join(bad_so)}")
    lines.append(f"  backend choices: {'all valid' if not bad_json else f'{len(bad_json)} invalid, measured again at next use: ' + '; '.join(bad_json)}")
    return lines
