"""The C allocator's settings for a simulation process (docs/MAP_PERFORMANCE.md, "Page faults").

A mapping iteration allocates and frees a few dozen tensors of 0.1-8 MiB (grid features,
OneBlob encodings, decoder outputs, gradients). With glibc's defaults, free memory at the
top of the heap beyond a trim threshold (twice the largest block freed so far, a few tens
of MiB here) goes back to the operating system, and the next iteration faults it back in,
zero-filled page by page: measured 3,300-3,550 minor page faults and 7-8 ms of system time
per mapping iteration of 14 ms of user time on a 2-core Zen 4 (``benchmarks/bench_map.py``).
:func:`keep_freed_memory` makes malloc serve blocks up to ``MMAP_THRESHOLD`` from the heap
and keep up to ``TRIM_THRESHOLD`` of free heap: 0-26 faults per iteration, system time
0.3 ms. The price: the process keeps its high-water mark of heap (at most ``TRIM_THRESHOLD``
more than it uses), which the run's memory check (``ramensim.memory``) already budgets as
the peak.

Linux with glibc only; a user's own ``MALLOC_*`` environment settings or glibc malloc
tunables win (nothing is changed then). Other C libraries: nothing is changed.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import sys

log = logging.getLogger(__name__)

MMAP_THRESHOLD = 32 << 20
"""Bytes: blocks up to this size come from the heap, not from their own mapping (glibc's
ceiling for this setting on 64-bit)."""
TRIM_THRESHOLD = 256 << 20
"""Bytes of free memory at the top of the heap kept instead of returned to the OS."""
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameter numbers

_done: bool | None = None


def _user_tuned() -> bool:
    env = os.environ
    return (any(k in env for k in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_",
                                   "MALLOC_TOP_PAD_", "MALLOC_MMAP_MAX_"))
            or "glibc.malloc" in env.get("GLIBC_TUNABLES", ""))


def keep_freed_memory() -> bool:
    """Apply the settings once per process; returns whether they are in effect."""
    global _done
    if _done is not None:
        return _done
    _done = False
    if not sys.platform.startswith("linux") or _user_tuned():
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
        gnu = libc.gnu_get_libc_version  # glibc only: musl has a mallopt that does nothing
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    gnu.restype = ctypes.c_char_p
    # the mmap threshold first: setting either one ends glibc's dynamic adjustment
    _done = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    log.debug("glibc %s malloc: mmap threshold %d MiB, trim threshold %d MiB (%s)",
              gnu().decode(), MMAP_THRESHOLD >> 20, TRIM_THRESHOLD >> 20,
              "set" if _done else "refused")
    return _done
