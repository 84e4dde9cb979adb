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

from ramensim.core.native import BASE_FLAGS, compile_shared, native_disabled, try_build, with_march

log = logging.getLogger(__name__)

SOURCE = Path(__file__).resolve().with_name("csrc") / "visibility.c"
"""The kernel's C source (package data of ``ramensim.evaluation``)."""

_SLOWDOWN = ("the evaluation culls meshes with its numpy path instead, several times slower "
             "(docs/BENCHMARKS.md, evaluation)")


def _build() -> ctypes.CDLL:
    lib = compile_shared(SOURCE, "visibility", with_march(BASE_FLAGS))
    P, I64, I, D = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int, ctypes.c_double
    lib.visible.argtypes = [P, I64, P, I64, D, D, D, D, I, I, D, D, P, I, I, I, I, D, P, I]
    lib.visible.restype = None
    lib.visible_clustered.argtypes = [P, P, I64, P, P, I64, D, D, D, D, I, I, D, D, P, I, I, I, I, D, D,
                                      P, I, I, I, P, I]
    lib.visible_clustered.restype = None
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
