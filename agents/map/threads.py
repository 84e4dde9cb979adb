"""The thread count of a block of map work: torch's intra-op pool, which the C kernels read too."""
from __future__ import annotations

import contextlib
import threading
from typing import Iterator

import torch


@contextlib.contextmanager
def thread_count(threads: int) -> Iterator[None]:
    """Run torch's intra-op pool (and the C kernels, which read it) on ``threads`` threads
    for the block (0 or the current count: no change)."""
    old = torch.get_num_threads()
    if threads <= 0 or threads == old:
        yield
        return
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(old)


_local = threading.local()


def thread_cap() -> int:
    """This thread's cap on every map stage's thread count (0: none). The team engine's worker
    threads run with a cap of 1 (``agents/rounds/threads.py``), so that two rounds at once use two cores."""
    return getattr(_local, "cap", 0)


def set_thread_cap(cap: int) -> None:
    """Cap every map stage's thread count on the calling thread at ``cap`` (0: no cap) and set
    torch's intra-op count to it (the stages' results do not depend on the count)."""
    _local.cap = max(0, int(cap))
    if cap > 0:
        torch.set_num_threads(int(cap))


def capped(threads: int) -> int:
    """``threads`` (0 = torch's count) under the calling thread's cap."""
    cap = thread_cap()
    if cap <= 0:
        return threads
    return cap if threads <= 0 else min(threads, cap)
