"""The thread count of a block of map work: torch's intra-op pool, which the C kernels read too."""
from __future__ import annotations

import contextlib
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
