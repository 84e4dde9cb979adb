"""Building small C kernels at first use: the compiler step and the cache shared by the map's
kernels (:mod:`ramensim.agents.map._native`) and the evaluation's visibility kernel
(:mod:`ramensim.evaluation._native`). Imports nothing of the project and no torch.

Build step: ``$CC`` (default ``gcc``) is run directly, ``-O3 -march=native -fopenmp
-Wall -Wextra -g`` (``-g`` changes no code; it lets ``perf annotate`` / gdb show the
source lines of ``csrc/*.c``), on a private copy of the exact bytes that were hashed, with
``-fdebug-prefix-map`` pointing the debug info back at the package's ``csrc/`` folder.
Compiler warnings of a successful build are logged at INFO; the sources build warning-free
with gcc 12 (tests/map/test_map_native_build.py checks with ``-Werror``). The shared
object is cached under ``$RAMENSIM_CACHE_DIR/native`` (default ``~/.cache/ramensim``),
named ``<kernel>_<key>.so`` with key = hash of the bytes of every file the build reads (its
sources, several built into one object for the map, and the ``*.h`` headers of their
folder), the compiler command, the flags (the shape macros of the MLP kernel included) and
the CPU model, and moved into place atomically, so concurrent processes never load half a
file. Each kernel declares its arguments by name (:func:`declare`), and constants C and
Python share are read from the C (:func:`read_define`).

Why not ``torch.utils.cpp_extension.load``: measured on the 2-core dev machine (same
flags, cold cache, best of 4), its first build of the map kernels (then one file, ``mapkernels.c``) took 0.47 s with ninja
against 0.27 s for this step (cached loads are instant both ways), and ``load()`` has no
setuptools fallback: without the ``ninja`` executable it raises "Ninja is required to load
C++ extensions" (the setuptools path only exists for ``setup.py`` builds). It would also
compile the files as C++20 (``extern "C"`` needed to keep the ctypes symbols), link
libtorch, libc10 and libtorch_python into kernels that need none of them, and key its
cache by extension name and sources, not by CPU model, so a ``-march=native`` object could
be reused on a different CPU sharing the home directory. The direct compiler step keeps
the ctypes calling convention, the C language and the cache's keying (source, flags, CPU;
now also the compiler command) as they were.
"""
from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import shlex
import subprocess
import tempfile
from pathlib import Path
from typing import Callable, Sequence

log = logging.getLogger(__name__)

WARNING_FLAGS = ["-Wall", "-Wextra"]
BASE_FLAGS = ["-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-fopenmp",
              "-shared", "-fPIC", "-g", *WARNING_FLAGS]
"""Flags of every kernel build (``-march=`` per :func:`march`); no FMA contraction."""


def cpu_model() -> str:
    """The CPU's model name and flags lines of /proc/cpuinfo (first core), '' if unreadable."""
    found: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                for key in ("model name", "flags"):
                    if line.startswith(key) and key not in found:
                        found[key] = line.strip()
                if len(found) == 2:
                    break
    except OSError:
        pass
    return "\n".join(found[k] for k in ("model name", "flags") if k in found)


def cpu_flags() -> set[str]:
    """The CPU's feature flags (e.g. ``avx2``, ``avx512f``); empty if unknown."""
    for line in cpu_model().splitlines():
        if line.startswith("flags"):
            return set(line.split(":", 1)[1].split())
    return set()


def march() -> str:
    """Target of the ``-march=`` build flag: ``$RAMENSIM_MARCH`` (e.g. ``x86-64-v3`` to build
    the AVX2 + FMA code an AVX-512 machine would not pick itself), default ``native``."""
    return os.environ.get("RAMENSIM_MARCH", "").strip() or "native"


def with_march(base: list[str]) -> list[str]:
    """``base`` with ``-march=native`` replaced by the target of :func:`march`."""
    return [f"-march={march()}" if f == "-march=native" else f for f in base]


def compiler() -> list[str]:
    """The C compiler command: ``$CC`` split like a shell would, default ``gcc``."""
    return shlex.split(os.environ.get("CC", "") or "gcc")


def cache_root() -> Path:
    """The per-user cache folder: ``$RAMENSIM_CACHE_DIR``, default ``~/.cache/ramensim``
    (kernels under ``native/``, camera frames under ``frames/``: ``ramensim.world.frame_cache``)."""
    return Path(os.environ.get("RAMENSIM_CACHE_DIR") or Path.home() / ".cache" / "ramensim")


def cache_dir() -> Path:
    """Where the shared objects are cached: ``$RAMENSIM_CACHE_DIR/native``."""
    return cache_root() / "native"


def fix_hint() -> str:
    """What to do when a kernel cannot be built, in words."""
    return (f"to fix: install gcc with OpenMP (or set CC to such a C compiler), make "
            f"{cache_dir()} writable (or point RAMENSIM_CACHE_DIR elsewhere), and leave "
            f"RAMENSIM_NO_NATIVE unset")


def kernel_files(sources: Sequence[Path]) -> list[Path]:
    """Every file a build of ``sources`` reads: the sources, then the headers (``*.h``) of
    their folders, sorted (the files a source may ``#include "..."``)."""
    headers = sorted({h for s in sources for h in Path(s).parent.glob("*.h")})
    return [*map(Path, sources), *headers]


def compile_shared(source: Path | Sequence[Path], name: str, flags: list[str],
                   defines: dict[str, int] | None = None) -> ctypes.CDLL:
    """Compile ``source`` (one C file, or several built into one shared object) into the cache
    (once per content of every file it reads -- sources and their folder's headers --,
    compiler, flags, macros and CPU) and load it."""
    sources = [Path(source)] if isinstance(source, (str, Path)) else [Path(s) for s in source]
    files = kernel_files(sources)
    try:
        blobs = [(f, f.read_bytes()) for f in files]
    except OSError as exc:
        raise RuntimeError(f"kernel source {exc.filename} unreadable ({exc.strerror or exc}); the package "
                           f"install is incomplete, reinstall ramensim") from exc
    cc = compiler()
    flags = [*flags, *(f"-D{k}={int(v)}" for k, v in (defines or {}).items())]
    key_text = "\0".join([" ".join(cc), " ".join(flags), cpu_model()])
    digest = hashlib.sha256()
    for f, code in blobs:
        digest.update(f.name.encode() + b"\0" + hashlib.sha256(code).digest())
    digest.update(key_text.encode())
    key = digest.hexdigest()[:16]
    cache = cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    so_path = cache / f"{name}_{key}.so"
    if not so_path.exists():
        _compile_into(cc, flags, blobs, len(sources), name, so_path)
    try:
        return ctypes.CDLL(str(so_path))
    except OSError as exc:
        # a cached object that does not load (truncated, corrupt): build it again once, into a
        # fresh file replacing it atomically, rather than falling back for ever
        log.warning("cached kernel %s does not load (%s); rebuilding it", so_path, exc)
        _compile_into(cc, flags, blobs, len(sources), name, so_path)
        return ctypes.CDLL(str(so_path))


def _compile_into(cc: list[str], flags: list[str], blobs: list[tuple[Path, bytes]], n_sources: int, name: str,
                  so_path: Path) -> None:
    """Compile the first ``n_sources`` of ``blobs`` (file, the bytes hashed) into ``so_path``,
    atomically; the other blobs are the headers they include."""
    folder = blobs[0][0].parent
    with tempfile.TemporaryDirectory(dir=so_path.parent) as tmp:
        # compile the exact bytes hashed (an edit mid-build cannot poison the cache);
        # the debug info names the package's source folder
        for f, code in blobs:
            (Path(tmp) / f.name).write_bytes(code)
        srcs = [str(Path(tmp) / f.name) for f, _ in blobs[:n_sources]]
        what = ", ".join(f.name for f, _ in blobs[:n_sources])
        out = Path(tmp) / f"{name}.so"
        cmd = [*cc, *flags, f"-fdebug-prefix-map={tmp}={folder}", *srcs, "-o", str(out), "-lm"]
        try:
            res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        except FileNotFoundError as exc:
            raise RuntimeError(f"C compiler {cc[0]!r} not found") from exc
        except subprocess.TimeoutExpired as exc:
            raise RuntimeError(f"{cc[0]} timed out building {what}") from exc
        if res.returncode != 0:
            raise RuntimeError(f"{cc[0]} failed on {what}: "
                               f"{res.stderr.strip()[:2000]}")
        if res.stderr.strip():
            log.info("compiler warnings building %s:\n%s", what, res.stderr.strip())
        # a fresh name in the same folder, then replace: a process that has the old file
        # loaded keeps its mapping, and parallel builders never see half a file
        os.replace(out, so_path)
    log.info("built %s into %s", what, so_path)


PTR, I64, INT, F32, F64 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int, ctypes.c_float, ctypes.c_double
"""The C argument types of the kernels' signature tables: a pointer (``void*``, the raw storage
of a contiguous array), ``int64_t``, ``int``, ``float`` and ``double``."""

Signature = tuple[tuple[str, object], ...]
"""A kernel's arguments as (name, ctypes type) pairs, in the C prototype's order."""


def declare(lib: ctypes.CDLL, signatures: dict[str, Signature], returns: dict[str, object] | None = None) -> None:
    """Set each entry point's ``argtypes`` from its named table (``void`` results unless
    ``returns`` names a ctypes type); tests/map/test_map_native_build.py checks every table
    against the C prototype, name by name."""
    for fn, args in signatures.items():
        entry = getattr(lib, fn)
        entry.argtypes = [t for _, t in args]
        entry.restype = (returns or {}).get(fn)


def read_define(header: Path, name: str) -> int:
    """The integer value of ``#define NAME value`` in a C header, so that a constant the C
    kernels and Python share is written once (e.g. the hash primes of ``hashgrid.h``)."""
    import re

    m = re.search(rf"^#define\s+{re.escape(name)}\s+(\d+)u?\b", Path(header).read_text(encoding="utf-8"), re.M)
    if m is None:
        raise RuntimeError(f"{header}: no '#define {name} <integer>'; the package install is incomplete")
    return int(m.group(1))


def native_disabled() -> bool:
    """True when ``RAMENSIM_NO_NATIVE`` asks for the pure-torch / numpy paths."""
    return os.environ.get("RAMENSIM_NO_NATIVE", "") not in ("", "0")


def try_build(build: Callable[[], ctypes.CDLL], what: str, slowdown: str,
              logger: logging.Logger = log) -> ctypes.CDLL | None:
    """``build()``, or None with one warning on ``logger`` naming ``what`` failed and why,
    the ``slowdown`` of the fallback and the fix (any failure means: use the fallback)."""
    try:
        return build()
    except Exception as exc:  # noqa: BLE001 - any failure means: use the fallback path
        logger.warning("%s unavailable (%s); %s; %s", what, exc, slowdown, fix_hint())
        return None


def prefer_passive_openmp() -> bool:
    """Ask the OpenMP runtime (libgomp, shared by torch and the C kernels) to put idle worker
    threads to sleep at once instead of spinning for a while (``OMP_WAIT_POLICY=PASSIVE``),
    unless the user set ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` themselves. It only takes
    effect before the runtime starts, so it is called by the CLI and the Python API before
    torch is imported; returns whether it was set here.

    Why (docs/BENCHMARKS.md, "OpenMP wait policy"): a simulated robot's work is a string of
    short parallel regions (kernels of a few ms, torch ops of a few hundred us) with Python in
    between; spinning workers burned 24 % of the default run's CPU time on an idle machine,
    and on a loaded one they spin while their partner thread is descheduled."""
    import sys

    if "torch" in sys.modules or "OMP_WAIT_POLICY" in os.environ or "GOMP_SPINCOUNT" in os.environ:
        return False
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
    return True
