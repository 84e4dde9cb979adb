"""Backend choice by measurement for the map's hot stages (docs/MAP_PERFORMANCE.md, "Backend
selection").

Three stages have more than one implementation with one contract:

- ``decoder``: the frozen decoders' forward and backward to the grid features
  (docs/ALGORITHM.md section 1): ``c`` = the fused OpenMP kernel of ``csrc/mapmlp.c``
  (vectorised for the build target: 16 lanes with AVX-512, 8 with AVX2), ``torch`` = the
  same maths as batched matrix products (torch's BLAS / oneDNN GEMM) with a hand-written
  backward (no autograd graph);
- ``grid``: the hash-grid encoding and its scatter backward: ``c`` = ``csrc/hashgrid.c``,
  ``torch`` = the fused all-levels torch path of ``hashgrid.py``;
- ``objective``: rendering weights, compositing and the observation losses with their gradient
  w.r.t. the decoder outputs (``objective.py``): ``c`` = ``render_loss`` of
  ``csrc/render.c`` (one pass per ray, hand-written backward), ``torch`` = the same maths
  through torch autograd. Its thread count is also the one the rest of
  ``NeuralMap.loss_and_grad``'s torch ops (ray and smoothness sampling) run on.

Which one is fastest depends on the machine (an AVX-512 machine runs the C decoder ~2x
faster than torch's GEMM at these widths; an AVX2 machine may not), so the choice is made
where the code runs: at first use, each available candidate runs forward + backward on a
small batch (``BENCH_SAMPLES`` samples), interleaved and repeated (median of ``REPEATS``), and
the fastest wins. Each candidate is timed on 1 thread and on the process's torch thread
count, and the stage then runs on the winning count. The figures and the choice are cached as JSON in ``_native.cache_dir()``,
keyed by CPU model and flags, torch version, build target (``RAMENSIM_MARCH``), thread
count, device and stage shape; later processes on the same machine read the cache, so the
choice is deterministic per machine given the cache (all candidates agree with the reference
to float rounding: tests/map/test_map_backends.py). ``map.decoder_backend``,
``map.grid_backend`` and ``map.objective_backend`` (``auto`` | ``c`` | ``torch``) force a choice;
``map.native: false`` forces ``torch`` for all three. ``ramensim doctor`` prints the choices and the figures.

Extending: a candidate is an entry of ``CANDIDATES[stage]``: an availability test
``(device, shape) -> reason or None`` and a timing function ``(device, shape, n) -> seconds``
of one forward + backward. A CUDA candidate (the GPU issue) adds an entry whose availability
test requires ``device.type == "cuda"``; the selector, cache and doctor need no change.
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import tempfile
import statistics
import time
from dataclasses import dataclass, field
from typing import Callable

import torch

from . import _native
from .decoder_kernel import DecoderKernel
from .threads import thread_count

log = logging.getLogger(__name__)

STAGES = ("decoder", "grid", "objective")
BENCH_SAMPLES = 8192
"""Samples per timed call of a candidate (the default iteration has 32,768)."""
REPEATS = 7
"""Timed rounds per candidate (interleaved with the others; the median counts: on a
shared machine the typical time, contention included, is what a run pays, not the
luckiest)."""
PRUNE = 3.0
"""A candidate more than this factor slower than the best after the first timed round is
not timed again (its first time is kept)."""
SCHEMA = 5
"""Version of the cached measurement (3: the decoder is timed with kept ReLU masks; 4: more
than one thread must be ``MULTI_THREAD_GAIN`` faster; 5: the ``objective`` stage, with a C
candidate, replaced the torch-only ``autograd`` stage)."""


@dataclass
class Choice:
    """The backend of one stage, how it was chosen, and the timings (ms per forward +
    backward of ``BENCH_SAMPLES`` samples) behind it."""

    stage: str
    backend: str
    how: str  # "measured", "cache", "forced by <key>", "only candidate"
    timings_ms: dict[str, float] = field(default_factory=dict)
    """'<backend>@<threads>' -> best ms per forward + backward of BENCH_SAMPLES samples."""
    unavailable: dict[str, str] = field(default_factory=dict)
    threads: int = 0
    """Threads the stage runs on (0: the process's torch thread count)."""

    def describe(self) -> str:
        figs = ", ".join(f"{k} {v:.2f} ms" for k, v in sorted(self.timings_ms.items()))
        miss = "; ".join(f"{k}: {v}" for k, v in self.unavailable.items())
        thr = f" on {self.threads} thread(s)" if self.threads else ""
        out = f"{self.stage}: {self.backend}{thr} ({self.how})"
        if figs:
            out += f" [{figs} per fwd+bwd of {BENCH_SAMPLES} samples]"
        if miss:
            out += f" unavailable: {miss}"
        return out


def thread_options() -> list[int]:
    """Thread counts tried per candidate: 1 and the process's torch thread count. On a
    machine shared with other busy processes one thread can be several times faster
    than two (OpenMP threads spin at barriers while their partner waits for a core:
    docs/MAP_PERFORMANCE.md)."""
    n = _native.nthreads()
    return [1] if n == 1 else [1, n]


# ------------------------------------------------------------------ candidates
# shapes: decoder (NG, NP, GH, GO, CH); grid (L, F, log2_T, base_resolution)
GRID_BENCH_FINEST = 300.0
"""Finest resolution of the timed grid (the scene's own differs; the cost barely does)."""

def _decoder_weights(shape: tuple[int, ...], device: torch.device) -> dict[str, torch.Tensor]:
    ng, np_, gh, go, ch = shape
    g = torch.Generator().manual_seed(0)
    dims = {"geo.0": (gh, ng + np_), "geo.1": (go, gh), "color.0": (ch, np_ + go - 1),
            "color.1": (3, ch)}
    return {k: ((torch.rand(o, i, generator=g) * 2 - 1) / math.sqrt(i)).to(device)
            for k, (o, i) in dims.items()}


def _decoder_inputs(shape: tuple[int, ...], n: int, device: torch.device):
    ng, np_ = shape[0], shape[1]
    g = torch.Generator().manual_seed(1)
    feats = (torch.rand(n, ng, generator=g) * 2 - 1) * 0.1
    pe = torch.rand(n, np_, generator=g)
    ds, dr = torch.randn(n, generator=g), torch.randn(n, 3, generator=g)
    return [t.to(device) for t in (feats, pe, ds, dr)]


def _decoder_kernel(backend: str, shape: tuple[int, ...], device: torch.device, threads: int):

    return DecoderKernel(backend, _decoder_weights(shape, device), shape[0], shape[1], device,
                         threads)


def _c_decoder_unavailable(device: torch.device, shape: tuple[int, ...]) -> str | None:
    if device.type != "cpu":
        return "CPU only"
    if _native.get_mlp_lib(*shape) is None:
        return "kernel did not build (see the warning above)"
    return None


def _torch_unavailable(device: torch.device, shape: tuple[int, ...]) -> str | None:
    return None


def _time_decoder(backend: str) -> Callable[..., Callable[[], None]]:
    def make(device: torch.device, shape: tuple[int, ...], n: int,
             threads: int) -> Callable[[], None]:
        k = _decoder_kernel(backend, shape, device, threads)
        feats, pe, ds, dr = _decoder_inputs(shape, n, device)

        def run() -> None:  # as in a mapping iteration: the backward reads the kept masks
            k.forward(feats, pe, keep=True)
            k.backward(feats, pe, ds, dr, kept=True)
        return run
    return make


def _grid_spec(shape: tuple[int, ...]):
    from .hashgrid import GridSpec

    L, F, log2_T, base = shape
    return GridSpec.build(int(L), int(F), int(log2_T), int(base), GRID_BENCH_FINEST)


def _c_grid_unavailable(device: torch.device, shape: tuple[int, ...]) -> str | None:
    if device.type != "cpu":
        return "CPU only"
    if _native.get_lib() is None:
        return "kernels did not build (see the warning above)"
    return None


def _time_grid(native: bool) -> Callable[..., Callable[[], None]]:
    def make(device: torch.device, shape: tuple[int, ...], n: int,
             threads: int) -> Callable[[], None]:
        from .hashgrid import accumulate_grad, encode

        spec = _grid_spec(shape)
        g = torch.Generator().manual_seed(2)
        xn = torch.rand(n, 3, generator=g).to(device)
        table = ((torch.rand(spec.n_params, generator=g) * 2 - 1) * 1e-4).to(device)
        gout = torch.randn(n, spec.out_dim, generator=g).to(device)
        grad = torch.zeros(spec.n_params, device=device)

        def run() -> None:
            with thread_count(threads):
                encode(xn, table, spec, native, threads=threads)
                accumulate_grad(xn, gout, spec, grad, native, threads=threads)
        return run
    return make


def _c_objective_unavailable(device: torch.device, shape: tuple[int, ...]) -> str | None:
    from .objective import c_unavailable

    return c_unavailable(device, int(shape[0]))


def _time_objective(backend: str) -> Callable[..., Callable[[], None]]:
    def make(device: torch.device, shape: tuple[int, ...], n: int,
             threads: int) -> Callable[[], None]:
        """Rendering weights, compositing and the observation losses, forward and gradient
        (``objective.observation_grads``), on ``n`` samples as (R, S) rays."""
        from .objective import observation_grads

        (S,) = shape
        R = max(1, n // S)
        g = torch.Generator().manual_seed(3)
        z = torch.sort(torch.rand(R, S, generator=g) * 4.0, dim=1)[0].to(device)
        depth = (torch.rand(R, generator=g) * 3.0 + 0.5).to(device)
        sdf = ((depth[:, None] - z) / 0.1).clamp(-1, 1).to(device)
        raw = torch.randn(R, S, 3, generator=g).to(device)
        rgb_t = torch.rand(R, 3, generator=g).to(device)

        def run() -> None:
            with thread_count(threads):
                observation_grads(sdf, raw, z, rgb_t, depth, 0.1, (5.0, 0.1, 1000.0, 10.0),
                                  backend, threads)
        return run
    return make


@dataclass(frozen=True)
class Candidate:
    """One implementation of a stage: why it cannot run here (``None`` = it can), and a
    factory ``(device, shape, n_samples, threads) -> run()`` of one timed forward + backward."""

    unavailable: Callable[[torch.device, tuple[int, ...]], str | None]
    make_run: Callable[[torch.device, tuple[int, ...], int, int], Callable[[], None]]


CANDIDATES: dict[str, dict[str, Candidate]] = {
    "decoder": {"c": Candidate(_c_decoder_unavailable, _time_decoder("c")),
                "torch": Candidate(_torch_unavailable, _time_decoder("torch"))},
    "grid": {"c": Candidate(_c_grid_unavailable, _time_grid(True)),
             "torch": Candidate(_torch_unavailable, _time_grid(False))},
    # the rest of the iteration's torch ops run on this stage's thread count too
    "objective": {"c": Candidate(_c_objective_unavailable, _time_objective("c")),
               "torch": Candidate(_torch_unavailable, _time_objective("torch"))},
}
"""stage -> backend name -> candidate, in order of preference on a tie."""


# ------------------------------------------------------------------ cache
def cache_key(stage: str, shape: tuple[int, ...], device: torch.device) -> str:
    """What the measurement depends on: CPU model + flags, torch version, build target,
    thread count, device, stage and shape (hashed)."""
    text = "\0".join([_native._cpu_model(), torch.__version__, _native.march(),
                      str(_native.nthreads()), str(device), stage, repr(tuple(shape)),
                      str(SCHEMA), os.environ.get("CC", "gcc")])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _cache_path(stage: str, key: str):
    return _native.cache_dir() / f"backend_{stage}_{key}.json"


def _read_cache(stage: str, key: str) -> dict | None:
    """The cached choice, or None (then it is measured again): a missing, unreadable, older
    or invalid file (wrong types or values, e.g. hand-edited) is ignored, with a warning
    naming it when it is there but invalid."""
    path = _cache_path(stage, key)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        return None
    problem = _cache_problem(data)
    if problem is not None:
        log.warning("backend choice cache %s is invalid (%s); ignoring it and measuring again", path, problem)
        return None
    return data


def _cache_problem(data: dict) -> str | None:
    """Why a cached choice cannot be used (types and ranges of its fields), or None."""
    timings = data.get("timings_ms")
    if not isinstance(data.get("backend"), str):
        return f"'backend' is {data.get('backend')!r}, expected a backend name"
    threads = data.get("threads", 0)
    if isinstance(threads, bool) or not isinstance(threads, int) or not 0 <= threads <= 4096:
        return f"'threads' is {threads!r}, expected a whole number of threads"
    if not isinstance(timings, dict) or not all(
            isinstance(k, str) and "@" in k and isinstance(v, (int, float)) and not isinstance(v, bool)
            and math.isfinite(v) and v >= 0 for k, v in timings.items()):
        return "'timings_ms' is not a mapping of '<backend>@<threads>' to milliseconds"
    return None


def _write_cache(stage: str, key: str, data: dict) -> None:
    path = _cache_path(stage, key)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=path.parent, delete=False,
                                         suffix=".tmp", encoding="utf-8") as fh:
            json.dump(data, fh, indent=1)
        os.replace(fh.name, path)  # atomic: parallel processes never read half a file
    except OSError as exc:
        log.warning("could not cache the %s backend choice in %s (%s); it will be measured "
                    "again in the next process", stage, path, exc)


# ------------------------------------------------------------------ selection
def measure(stage: str, shape: tuple[int, ...], device: torch.device,
            names: list[str], n: int = BENCH_SAMPLES, repeats: int = REPEATS,
            threads: list[int] | None = None) -> dict[str, float]:
    """Median of ``repeats`` timings (seconds) of one forward + backward per candidate and
    thread count
    (keys ``'<name>@<threads>'``), the candidates interleaved so that load from other
    processes falls on all of them alike; candidates ``PRUNE`` times slower than the best
    after the first round keep that one time."""
    thr = threads or (thread_options() if device.type == "cpu" else [0])
    runs = {f"{nm}@{t}": CANDIDATES[stage][nm].make_run(device, shape, n, t)
            for nm in names for t in thr}
    times: dict[str, list[float]] = {k: [] for k in runs}
    for run in runs.values():  # warm-up: first-touch allocations, lazy inits
        run()
    for rep in range(repeats):
        if rep == 1:  # after one timed round, stop timing the clearly slower ones
            lead = min(t[0] for t in times.values())
            runs = {k: r for k, r in runs.items() if times[k][0] <= PRUNE * lead}
        for k, run in runs.items():
            if device.type == "cuda":
                torch.cuda.synchronize(device)
            t0 = time.perf_counter()
            run()
            if device.type == "cuda":
                torch.cuda.synchronize(device)
            times[k].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


MULTI_THREAD_GAIN = 0.85
"""A candidate on more than one thread wins only if it takes at most this fraction of the
best single-thread time: extra threads must earn their keep, because on a machine that
other processes load, OpenMP threads spin at barriers while their partner waits for a core
(measured: 2 threads 5-30x slower than 1 at load average 8-12 on 2 cores), so a near tie
measured in a quiet moment is not worth that risk."""


def pick(ms: dict[str, float]) -> tuple[str, int]:
    """(backend, threads) from ``'<backend>@<threads>' -> ms``: the fastest single-thread
    candidate unless a multi-thread one is faster by the margin ``MULTI_THREAD_GAIN``; on
    a tie, candidate order."""
    order = list(ms)
    key = lambda k: (ms[k], order.index(k))  # noqa: E731
    single = [k for k in order if int(k.split("@")[1]) <= 1]
    multi = [k for k in order if int(k.split("@")[1]) > 1]
    best = min(single, key=key) if single else min(order, key=key)
    if multi:
        m = min(multi, key=key)
        if not single or ms[m] <= MULTI_THREAD_GAIN * ms[best]:
            best = m
    return best.split("@")[0], int(best.split("@")[1])


_memo: dict[tuple[str, str], Choice] = {}


def select(stage: str, shape: tuple[int, ...], device: torch.device, forced: str = "auto",
           *, remeasure: bool = False, threads: int = 0) -> Choice:
    """The backend for ``stage`` at ``shape`` on ``device``: ``forced`` unless ``auto``,
    else the cached or freshly measured fastest available candidate. ``threads`` > 0
    (``map.threads``) fixes the thread count; the backend is then the forced one, or the
    faster at that count."""
    if stage not in CANDIDATES:
        raise ValueError(f"unknown map stage {stage!r}; expected one of {list(CANDIDATES)}")
    cands = CANDIDATES[stage]
    unavailable = {nm: why for nm, c in cands.items()
                   if (why := c.unavailable(device, shape)) is not None}
    avail = [nm for nm in cands if nm not in unavailable]
    if threads > 0:
        if forced == "auto" and len(avail) > 1:
            ms = {k: v * 1e3 for k, v in measure(stage, shape, device, avail,
                                                    threads=[threads]).items()}
            forced = min(avail, key=lambda nm: (ms[f"{nm}@{threads}"], avail.index(nm)))
            return Choice(stage, forced, f"measured at map.threads = {threads}", ms,
                          unavailable, threads)
        ch = select(stage, shape, device, forced if forced != "auto" else avail[0])
        ch.threads = threads
        ch.how += f", map.threads = {threads}"
        return ch
    if forced != "auto":
        if forced not in cands:
            raise ValueError(f"map.{stage}_backend = {forced!r} is not a backend; expected "
                             f"'auto' or one of {list(cands)}")
        if forced in unavailable:
            log.warning("map.%s_backend = %s is unavailable here (%s); using torch instead",
                        stage, forced, unavailable[forced])
            return Choice(stage, "torch", f"forced {forced} unavailable", {}, unavailable)
        return Choice(stage, forced, f"forced by map.{stage}_backend", {}, unavailable)
    if len(avail) == 1 and (device.type != "cpu" or len(thread_options()) == 1):
        return Choice(stage, avail[0], "only candidate", {}, unavailable)
    key = cache_key(stage, shape, device)
    if not remeasure:
        if (stage, key) in _memo:
            return _memo[(stage, key)]
        data = _read_cache(stage, key)
        # a choice measured among other candidates is not reused: a process without the C
        # kernels (no compiler, RAMENSIM_NO_NATIVE) caches 'torch' from torch alone, and a
        # later process that has them would otherwise keep the ~30x slower path
        measured = {k.split("@")[0] for k in (data or {}).get("timings_ms", {})}
        if data is not None and data.get("backend") in avail and measured == set(avail):
            ch = Choice(stage, data["backend"], "cache", dict(data.get("timings_ms", {})),
                        unavailable, int(data.get("threads", 0)))
            _memo[(stage, key)] = ch
            return ch
    secs = measure(stage, shape, device, avail)
    ms = {nm: s * 1e3 for nm, s in secs.items()}
    winner, threads = pick(ms)
    ch = Choice(stage, winner, "measured", ms, unavailable, threads)
    log.info("map backend chosen by measurement: %s", ch.describe())
    _write_cache(stage, key, {"schema": SCHEMA, "stage": stage, "backend": winner,
                              "threads": threads, "timings_ms": ms, "shape": list(shape),
                              "device": str(device), "torch": torch.__version__,
                              "march": _native.march(), "process_threads": _native.nthreads(),
                              "measured_at": time.time()})
    _memo[(stage, key)] = ch
    return ch


def decoder_shape(cfg) -> tuple[int, int, int, int, int]:
    """(NG, NP, GH, GO, CH) of a MapConfig's decoders."""
    return (cfg.n_levels * cfg.features_per_level, 3 * cfg.oneblob_bins, cfg.geo_hidden,
            1 + cfg.geo_feat_dim, cfg.color_hidden)


def objective_shape(cfg) -> tuple[int]:
    """(samples per ray,) of a MapConfig's training rays."""
    return (cfg.samples_per_ray,)


def grid_shape(cfg) -> tuple[int, int, int, int]:
    """(L, F, log2_T, base_resolution) of a MapConfig's hash grid."""
    return (cfg.n_levels, cfg.features_per_level, cfg.log2_hashmap_size, cfg.base_resolution)
