"""The visibility kernel of the evaluation's culling (``csrc/visibility.c``), built with the C
compiler at first use by :mod:`ramensim.core.native` and called through ``ctypes``.

:func:`get_lib` gives ``None`` (with one warning naming the slowdown and the fix) when the
kernel cannot be built or ``RAMENSIM_NO_NATIVE`` is set; :mod:`.cull` then uses its numpy
path, which gives the same masks (tests/evaluation/test_evaluation_visibility.py).
"""
from __future__ import annotations

import ctypes
import functools
import logging
import os
import sys
from pathlib import Path

from ramensim.core.native import (BASE_FLAGS, F64, I64, INT, PTR, Signature, compile_shared, declare,
                                  native_disabled, try_build, with_march)

log = logging.getLogger(__name__)

SOURCE = Path(__file__).resolve().with_name("csrc") / "visibility.c"
"""The kernel's C source (package data of ``ramensim.evaluation``)."""

_SLOWDOWN = ("the evaluation culls meshes with its numpy path instead, several times slower "
             "(docs/BENCHMARKS.md, evaluation)")


_CAMERA: Signature = (("fx", F64), ("fy", F64), ("cx", F64), ("cy", F64), ("width", INT), ("height", INT),
                     ("near", F64), ("far", F64))
_DEPTH: Signature = (("depth", PTR), ("dh", INT), ("dw", INT), ("stride", INT), ("measured", INT), ("eps", F64))
SIGNATURES: dict[str, Signature] = {  # csrc/visibility.c
    "visible": (("pts", PTR), ("n", I64), ("w2c", PTR), ("n_poses", I64), *_CAMERA, *_DEPTH, ("seen", PTR),
                ("nthreads", INT)),
    "visible_clustered": (("pts", PTR), ("start", PTR), ("n_clusters", I64), ("sphere", PTR), ("w2c", PTR),
                          ("n_poses", I64), *_CAMERA, *_DEPTH, ("margin", F64), ("cmax", PTR), ("ch", INT),
                          ("cw", INT), ("cb", INT), ("seen", PTR), ("nthreads", INT)),
    "spheres_may_see": (("sphere", PTR), ("n_spheres", I64), ("w2c", PTR), ("n_poses", I64), *_CAMERA,
                        ("depth", PTR), ("dh", INT), ("dw", INT), ("stride", INT), ("eps", F64), ("margin", F64),
                        ("cmax", PTR), ("ch", INT), ("cw", INT), ("cb", INT), ("may", PTR), ("nthreads", INT)),
}
"""The kernel's signatures by name (checked against the C prototypes)."""


def _build() -> ctypes.CDLL:
    lib = compile_shared(SOURCE, "visibility", with_march(BASE_FLAGS))
    declare(lib, SIGNATURES)
    return lib


@functools.cache
def get_lib() -> ctypes.CDLL | None:
    """The compiled kernel, built on first use (once per process); ``None`` if unavailable."""
    return None if native_disabled() else try_build(_build, "native visibility kernel", _SLOWDOWN, log)


def nthreads() -> int:
    """Threads the kernel uses: torch's intra-op count when torch is loaded (a run), else the
    CPUs this process may use."""
    torch = sys.modules.get("torch")
    if torch is not None:
        return max(1, int(torch.get_num_threads()))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)
