"""The allocator setting (core/alloc.py): what it is for (a loop that allocates,
writes and frees blocks of a few MiB, as a mapping iteration does, stops page-faulting: with
glibc's defaults it faults ~18 MiB back in every round), a user's own setting wins, and it
is applied once."""
from __future__ import annotations

import subprocess
import sys

import pytest

def _glibc() -> bool:
    import ctypes

    try:
        return sys.platform.startswith("linux") and hasattr(ctypes.CDLL(None), "gnu_get_libc_version")
    except OSError:
        return False


pytestmark = pytest.mark.skipif(not _glibc(), reason="glibc malloc only")

_PROBE = """
import ctypes, resource, sys
from ramensim.core.alloc import keep_freed_memory
tuned = keep_freed_memory() if sys.argv[1] == "1" else False
libc = ctypes.CDLL("libc.so.6")
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = [ctypes.c_size_t]
libc.free.argtypes = [ctypes.c_void_p]
libc.memset.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_size_t]
MB = 1 << 20
def work():  # as a mapping iteration: blocks of a few MiB allocated, written and freed
    ps = [libc.malloc(3 * MB) for _ in range(6)]
    for p in ps:
        libc.memset(p, 1, 3 * MB)
    for p in reversed(ps):
        libc.free(p)
p = libc.malloc(4 * MB)  # a 4-MiB block freed: glibc's dynamic trim threshold becomes 8 MiB
libc.memset(p, 1, 4 * MB)
libc.free(p)
for _ in range(3):
    work()
r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    work()
print(tuned, (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0) / 20)
"""


def _faults(tune: bool, env_extra: dict[str, str] | None = None) -> tuple[bool, float]:
    import os

    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    env.update(env_extra or {})
    out = subprocess.run([sys.executable, "-c", _PROBE, "1" if tune else "0"], env=env,
                         capture_output=True, text=True, check=True, timeout=120).stdout.split()
    return out[0] == "True", float(out[1])


def test_freed_memory_is_kept_so_iterations_do_not_fault():
    tuned, faults = _faults(True)
    assert tuned
    assert faults < 50  # 0 measured: the blocks are reused from the heap
    untuned, faults_default = _faults(False)
    assert not untuned
    assert faults_default > 1000  # 4,576 measured: the 18 MiB go back to the OS every round


def test_a_users_own_malloc_setting_wins():
    tuned, _ = _faults(True, {"MALLOC_TRIM_THRESHOLD_": "131072"})
    assert not tuned


def test_applied_once(monkeypatch):
    from ramensim.core import alloc

    monkeypatch.setattr(alloc, "_done", None)
    for k in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TOP_PAD_",
              "MALLOC_MMAP_MAX_", "GLIBC_TUNABLES"):
        monkeypatch.delenv(k, raising=False)
    calls = []
    monkeypatch.setattr(alloc.ctypes, "CDLL", lambda *a: calls.append(a) or (_ for _ in ()).throw(OSError("x")))
    assert alloc.keep_freed_memory() is False and len(calls) == 1  # no libc: nothing changed
    assert alloc.keep_freed_memory() is False and len(calls) == 1  # not tried again
