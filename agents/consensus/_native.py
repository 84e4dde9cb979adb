"""RAMEN's per-edge kernel (``csrc/ramenedge.c``), built with the C compiler at first use by
:mod:`ramensim.core.native` and called through ``ctypes``.

:func:`get_lib` gives ``None`` (with one warning naming the slowdown and the fix) when the
kernel cannot be built or ``RAMENSIM_NO_NATIVE`` is set; :class:`.ramen.RamenMethod` then
uses its torch path, which gives the same consensus state (tests/consensus/test_consensus_native.py).
"""
from __future__ import annotations

import ctypes
import functools
import logging
from pathlib import Path

from ramensim.core.native import BASE_FLAGS, compile_shared, native_disabled, try_build, with_march

log = logging.getLogger(__name__)

SOURCE = Path(__file__).resolve().with_name("csrc") / "ramenedge.c"
"""The kernel's C source (package data of ``ramensim.agents``)."""
SUM_BLOCK = 65536
"""Parameters per partial sum in the kernel (its ``SUM_BLOCK``)."""

_SLOWDOWN = ("RAMEN computes its per-edge weights and duals with torch ops instead, ~25 passes "
             "over the parameters per neighbour (docs/BENCHMARKS.md, RAMEN vs DiNNO)")


def _build() -> ctypes.CDLL:
    lib = compile_shared(SOURCE, "ramenedge", with_march(BASE_FLAGS))
    P, I64, I, Fl = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int, ctypes.c_float
    lib.usum_minmax.argtypes = [P, P, I64, P, I]
    lib.ramen_edge.argtypes = [P, P, I64, Fl, Fl, Fl, Fl, P, P, P, P, P, P, P, P, I]
    lib.usum_minmax.restype = lib.ramen_edge.restype = None
    return lib


@functools.cache
def get_lib() -> ctypes.CDLL | None:
    """The compiled kernel, built on first use (once per process); ``None`` if unavailable."""
    return None if native_disabled() else try_build(_build, "native RAMEN edge kernel", _SLOWDOWN, log)
