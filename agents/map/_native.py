"""Small OpenMP C kernels for the map's hot path, built with the C compiler at first use.

Sources (real files, shipped as package data next to this module):

- ``csrc/mapkernels.c``: hash-grid encoding forward (eq. of docs/ALGORITHM.md section 1), its
  backward (a scatter into the flat table, parallel over levels so no two threads touch
  the same entries and the sum order is fixed: deterministic), OneBlob, a fused Adam step,
  the visit counter of eq. 18, and the objective's terms with their gradients (rendering
  + observation losses ``render_loss``, smoothness ``smooth_loss``; see ``objective.py``),
  and the training rays' sample depths and positions (``ray_samples``, see ``render.py``);
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
from ramensim.core.native import native_disabled, try_build
from ramensim.core.native import with_march as _flags

log = logging.getLogger(__name__)

CSRC = Path(__file__).resolve().with_name("csrc")
"""Folder of the C sources (package data of ``ramensim.agents``)."""
KERNELS_SOURCE = CSRC / "mapkernels.c"
MLP_SOURCE = CSRC / "mapmlp.c"

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
    """Build (or load from the cache) ``csrc/mapkernels.c`` and declare its signatures."""
    lib = _compile(KERNELS_SOURCE, "mapkernels", _flags(_FLAGS))
    P, I64, I = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int
    Fl = ctypes.c_float
    lib.hash_fwd.argtypes = [P, I64, P, I, I, I64, P, P, P, P, I]
    lib.hash_bwd.argtypes = [P, I64, P, I, I, I64, P, P, P, P, I]
    lib.oneblob.argtypes = [P, I64, I, P, I]
    lib.adam_step.argtypes = [P, P, P, P, I64, Fl, Fl, Fl, Fl, Fl, Fl, I]
    lib.adam_prox.argtypes = [P, P, P, P, I64, Fl, Fl, Fl, Fl, Fl, Fl, Fl, Fl, P, Fl, P, I]
    lib.count_visits.argtypes = [P, P, I64, I]
    lib.render_loss.argtypes = [P, P, P, P, P, I64, I, Fl, P, P, P, P, P, I]
    lib.smooth_loss.argtypes = [P, I, I, Fl, P, P, P, I]
    lib.ray_samples.argtypes = [P, I64, P, I, P, I, P, P, P, P, P, P, I]
    for fn in (lib.hash_fwd, lib.hash_bwd, lib.oneblob, lib.adam_step, lib.adam_prox,
               lib.count_visits, lib.render_loss, lib.smooth_loss, lib.ray_samples):
        fn.restype = None
    return lib


def _build_mlp(ng: int, np_: int, gh: int, go: int, ch: int) -> ctypes.CDLL:
    """Build (or load from the cache) ``csrc/mapmlp.c`` for one decoder shape."""
    lib = _compile(MLP_SOURCE, "mapmlp", _flags(_MLP_FLAGS),
                   {"NG": ng, "NP": np_, "GH": gh, "GO": go, "CH": ch})
    P, I64, I = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int
    lib.mlp_fwd.argtypes = [P, P, I64, P, P, P, P, P, P, P, I]
    lib.mlp_bwd.argtypes = [P, P, I64, P, P, P, P, P, P, P, P, P, P, P, P, I]
    lib.mlp_fwd_keep.argtypes = [P, P, I64, P, P, P, P, P, P, P, P, I]
    lib.mlp_bwd_masks.argtypes = [P, I64, P, P, P, P, P, P, P, I]
    lib.mlp_sdf.argtypes = [P, P, I64, P, P, P, P, I]
    lib.mlp_sdf.restype = None
    lib.mlp_mask_bytes.argtypes = [I64]
    lib.mlp_mask_bytes.restype = I64
    lib.mlp_fwd.restype = lib.mlp_bwd.restype = None
    lib.mlp_fwd_keep.restype = lib.mlp_bwd_masks.restype = None
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
