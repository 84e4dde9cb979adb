"""Small OpenMP C kernels for the map's hot path, built with the C compiler at first use.

Sources (real files, shipped as package data next to this module), one C file per concern,
built together into one shared object, with two headers (``lanes.h``: the vector width;
``hashgrid.h``: the hash primes, which ``hashgrid.py`` reads from it):

- ``csrc/hashgrid.c``: hash-grid encoding forward (eq. of docs/ALGORITHM.md section 1) and
  backward (a scatter into the flat table, parallel over levels so no two threads touch
  the same entries and the sum order is fixed: deterministic);
- ``csrc/oneblob.c``: OneBlob; ``csrc/adam.c``: a fused Adam step and Adam + the consensus
  proximal step; ``csrc/visits.c``: the visit counter of eq. 18;
- ``csrc/render.c``: the training rays' sample depths and positions (``ray_samples``, see
  ``render.py``) and the rendering + observation losses with their gradients
  (``render_loss``, see ``objective.py``); ``csrc/smooth.c``: the smoothness term;
- ``csrc/mapmlp.c``: the frozen decoders fused (forward, and backward to the grid
  features), one shared object per decoder shape: the sizes are passed as
  ``-DNG= -DNP= -DGH= -DGO= -DCH=`` (the file has defaults, so an editor parses it alone);
  a training step keeps the forward's ReLU masks (``mlp_fwd_keep``) and runs the backward
  from them (``mlp_bwd_masks``) instead of a second forward; ``mlp_sdf`` gives the SDF
  alone (no colour layers) for mesh extraction, bit-identical to the forward's.

Called through ``ctypes`` on the raw storage of contiguous CPU float32 / int32 tensors.

Build step and cache: :mod:`ramensim.core.native` (shared with the evaluation's visibility kernel).

Anything that goes wrong (no compiler, a failed build, no write access, a missing source
file, a failed load) gives ``None`` with a warning naming the slowdown and the fix, and the
callers use the pure-torch path; ``RAMENSIM_NO_NATIVE=1`` forces that path.

The kernels link ``libgomp.so.1``; torch (imported first) already loaded its own copy
under that soname, so both share one OpenMP runtime and thread pool.
"""
from __future__ import annotations

import ctypes
import logging
from pathlib import Path

import torch

from ramensim.core.native import BASE_FLAGS, WARNING_FLAGS, cache_dir, cpu_flags, march  # noqa: F401 - re-exported
from ramensim.core.native import compile_shared as _compile
from ramensim.core.native import compiler as _compiler  # noqa: F401 - read by doctor and tests
from ramensim.core.native import cpu_model as _cpu_model  # noqa: F401 - read by backend and doctor
from ramensim.core.native import F32, I64, INT, PTR, Signature, declare, native_disabled, try_build
from ramensim.core.native import with_march as _flags

log = logging.getLogger(__name__)

CSRC = Path(__file__).resolve().with_name("csrc")
"""Folder of the C sources (package data of ``ramensim.agents``)."""
KERNEL_SOURCES = tuple(CSRC / f for f in ("hashgrid.c", "oneblob.c", "adam.c", "visits.c", "render.c", "smooth.c"))
"""One C file per concern, built together into one shared object (headers: lanes.h, hashgrid.h)."""
MLP_SOURCE = CSRC / "mapmlp.c"

SIGNATURES: dict[str, Signature] = {  # C file: the entry points' arguments, in order
    # hashgrid.c
    "hash_fwd": (("xn", PTR), ("n", I64), ("table", PTR), ("L", INT), ("F", INT), ("T", I64), ("scales", PTR),
                 ("res", PTR), ("dense", PTR), ("out", PTR), ("nthreads", INT)),
    "hash_bwd": (("xn", PTR), ("n", I64), ("grad_out", PTR), ("L", INT), ("F", INT), ("T", I64), ("scales", PTR),
                 ("res", PTR), ("dense", PTR), ("grad_table", PTR), ("nthreads", INT)),
    "hash_fwd_grid": (("xa", PTR), ("nx", I64), ("ya", PTR), ("ny", I64), ("za", PTR), ("nz", I64), ("table", PTR),
                      ("L", INT), ("F", INT), ("T", I64), ("scales", PTR), ("res", PTR), ("dense", PTR), ("out", PTR),
                      ("nthreads", INT)),
    # oneblob.c
    "oneblob": (("xn", PTR), ("n", I64), ("nb", INT), ("out", PTR), ("nthreads", INT)),
    # adam.c
    "adam_step": (("p", PTR), ("g", PTR), ("m", PTR), ("v", PTR), ("n", I64), ("lr", F32), ("b1", F32), ("b2", F32),
                  ("eps", F32), ("bc1", F32), ("bc2sqrt", F32), ("nthreads", INT)),
    "adam_prox": (("p", PTR), ("g", PTR), ("m", PTR), ("v", PTR), ("n", I64), ("lr", F32), ("b1", F32), ("b2", F32),
                  ("eps", F32), ("bc1", F32), ("bc2sqrt", F32), ("k1", F32), ("k2", F32), ("A", PTR),
                  ("a_scalar", F32), ("c", PTR), ("nthreads", INT)),
    # visits.c
    "count_visits": (("g", PTR), ("visits", PTR), ("n", I64), ("nthreads", INT)),
    # render.c
    "render_loss": (("sdf", PTR), ("raw", PTR), ("z", PTR), ("rgb_obs", PTR), ("depth_obs", PTR), ("R", I64),
                    ("S", INT), ("tr", F32), ("lw", PTR), ("losses", PTR), ("d_sdf", PTR), ("d_raw", PTR),
                    ("part", PTR), ("nthreads", INT)),
    "ray_samples": (("rows", PTR), ("R", I64), ("strat", PTR), ("ns", INT), ("off", PTR), ("nf", INT),
                    ("nodepth", PTR), ("rnd", PTR), ("lo", PTR), ("ext", PTR), ("z", PTR), ("xn", PTR),
                    ("nthreads", INT)),
    # smooth.c
    "smooth_loss": (("f", PTR), ("n", INT), ("C", INT), ("weight", F32), ("loss", PTR), ("grad", PTR), ("part", PTR),
                    ("nthreads", INT)),
}
"""The map kernels' signatures by name (core.native.declare; checked against the C prototypes)."""

_MLP_COMMON = (("feats", PTR), ("pe", PTR), ("n", I64), ("W0", PTR), ("W1", PTR))
MLP_SIGNATURES: dict[str, Signature] = {  # mapmlp.c
    "mlp_fwd": (*_MLP_COMMON, ("C0", PTR), ("C1", PTR), ("PT", PTR), ("sdf", PTR), ("rgb", PTR), ("nthreads", INT)),
    "mlp_fwd_keep": (*_MLP_COMMON, ("C0", PTR), ("C1", PTR), ("PT", PTR), ("sdf", PTR), ("rgb", PTR), ("masks", PTR),
                     ("nthreads", INT)),
    "mlp_bwd": (*_MLP_COMMON, ("C0", PTR), ("C1", PTR), ("PT", PTR), ("C1T", PTR), ("C0hT", PTR), ("W1T", PTR),
                ("W0gT", PTR), ("dsdf", PTR), ("drgb", PTR), ("dfeats", PTR), ("nthreads", INT)),
    "mlp_bwd_masks": (("masks", PTR), ("n", I64), ("C1T", PTR), ("C0hT", PTR), ("W1T", PTR), ("W0gT", PTR),
                      ("dsdf", PTR), ("drgb", PTR), ("dfeats", PTR), ("nthreads", INT)),
    "mlp_sdf": (*_MLP_COMMON, ("PT", PTR), ("sdf", PTR), ("nthreads", INT)),
    "mlp_mask_bytes": (("n", I64),),
}
"""The fused decoders' signatures by name (``mlp_mask_bytes`` returns an int64)."""

_FLAGS = BASE_FLAGS
# FMA contraction allowed in the decoder kernel (results are checked against torch to 1e-5)
_MLP_FLAGS = [f if f != "-ffp-contract=off" else "-ffp-contract=fast" for f in _FLAGS]

_SLOWDOWN = ("the map uses its pure-torch path instead, roughly 30x slower per mapping "
             "iteration (docs/MAP_PERFORMANCE.md)")
_MLP_SLOWDOWN = ("the map evaluates its decoders with torch matmuls instead, roughly 1.8x "
                 "slower per mapping iteration (docs/MAP_PERFORMANCE.md)")

_lib: ctypes.CDLL | None = None
_tried = False


def _build() -> ctypes.CDLL:
    """Build (or load from the cache) the kernels of ``csrc/`` and declare their signatures."""
    lib = _compile(KERNEL_SOURCES, "mapkernels", _flags(_FLAGS))
    declare(lib, SIGNATURES)
    return lib


def _build_mlp(ng: int, np_: int, gh: int, go: int, ch: int) -> ctypes.CDLL:
    """Build (or load from the cache) ``csrc/mapmlp.c`` for one decoder shape."""
    lib = _compile(MLP_SOURCE, "mapmlp", _flags(_MLP_FLAGS),
                   {"NG": ng, "NP": np_, "GH": gh, "GO": go, "CH": ch})
    declare(lib, MLP_SIGNATURES, {"mlp_mask_bytes": I64})
    return lib


def get_lib() -> ctypes.CDLL | None:
    """The compiled kernels, building them on first use; ``None`` if unavailable."""
    global _lib, _tried
    if _tried:
        return _lib
    _tried = True
    if native_disabled():
        log.warning("RAMENSIM_NO_NATIVE is set: %s; unset it to use the compiled kernels",
                    _SLOWDOWN)
        return None
    _lib = try_build(_build, "native map kernels", _SLOWDOWN, log)
    return _lib


def ptr(t: torch.Tensor) -> int:
    """Address of a contiguous CPU tensor's first element."""
    return t.data_ptr()


def nthreads() -> int:
    """Threads the kernels use: torch's intra-op thread count."""
    return max(1, torch.get_num_threads())


_mlp_libs: dict[tuple[int, ...], ctypes.CDLL | None] = {}


def get_mlp_lib(ng: int, np_: int, gh: int, go: int, ch: int) -> ctypes.CDLL | None:
    """Fused decoder kernels compiled for these sizes; ``None`` if unavailable."""
    key = (ng, np_, gh, go, ch)
    if key in _mlp_libs:
        return _mlp_libs[key]
    lib = None
    if get_lib() is not None:
        lib = try_build(lambda: _build_mlp(ng, np_, gh, go, ch), "fused decoder kernel", _MLP_SLOWDOWN, log)
    _mlp_libs[key] = lib
    return lib
