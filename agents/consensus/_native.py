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

from ramensim.core.native import (BASE_FLAGS, F32, I64, INT, PTR, Signature, compile_shared, declare,
                                  native_disabled, read_define, try_build, with_march)

log = logging.getLogger(__name__)

SOURCE = Path(__file__).resolve().with_name("csrc") / "ramenedge.c"
"""The kernel's C source (package data of ``ramensim.agents``)."""
SUM_BLOCK = read_define(SOURCE, "SUM_BLOCK")
"""Parameters per partial sum in the kernel (its ``SUM_BLOCK``, read from the C file)."""

_SLOWDOWN = ("RAMEN computes its per-edge weights and duals with torch ops instead, ~25 passes "
             "over the parameters per neighbour (docs/BENCHMARKS.md, RAMEN vs DiNNO)")


SIGNATURES: dict[str, Signature] = {  # csrc/ramenedge.c
    "usum_minmax": (("ui", PTR), ("uj", PTR), ("n", I64), ("lo_hi", PTR), ("nthreads", INT)),
    "ramen_edge": (("ui", PTR), ("uj", PTR), ("n", I64), ("eps", F32), ("zeta", F32), ("beta_l", F32),
                   ("beta_u", F32), ("theta_t", PTR), ("theta_j", PTR), ("h2", PTR), ("t", PTR), ("d", PTR),
                   ("a", PTR), ("sums", PTR), ("part", PTR), ("nthreads", INT)),
}
"""The kernel's signatures by name (checked against the C prototypes)."""


def _build() -> ctypes.CDLL:
    lib = compile_shared(SOURCE, "ramenedge", with_march(BASE_FLAGS))
    declare(lib, SIGNATURES)
    return lib


@functools.cache
def get_lib() -> ctypes.CDLL | None:
    """The compiled kernel, built on first use (once per process); ``None`` if unavailable."""
    return None if native_disabled() else try_build(_build, "native RAMEN edge kernel", _SLOWDOWN, log)
