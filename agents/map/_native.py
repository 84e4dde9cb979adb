"""Small OpenMP C kernels for the map's hot path, built with the C compiler at first use.

Sources (real files, shipped as package data next to this module):

- ``csrc/mapkernels.c``: hash-grid encoding forward (eq. of docs/ALGORITHM.md section 1), its
  backward (a scatter into the flat table, parallel over levels so no two threads touch
  the same entries and the sum order is fixed: deterministic), OneBlob, a fused Adam step
  and the visit counter of eq. 18;
- ``csrc/mapmlp.c``: the frozen decoders fused (forward, and backward to the grid
  features), one shared object per decoder shape: the sizes are passed as
  ``-DNG= -DNP= -DGH= -DGO= -DCH=`` (the file has defaults, so an editor parses it alone);
  a training step keeps the forward's ReLU masks (``mlp_fwd_keep``) and runs the backward
  from them (``mlp_bwd_masks``) instead of a second forward.

Called through ``ctypes`` on the raw storage of contiguous CPU float32 / int32 tensors.

Build step: ``$CC`` (default ``gcc``) is run directly, ``-O3 -march=native -fopenmp
-Wall -Wextra -g`` (``-g`` changes no code; it lets ``perf annotate`` / gdb show the
source lines of ``csrc/*.c``), on a private copy of the exact bytes that were hashed, with
``-fdebug-prefix-map`` pointing the debug info back at the package's ``csrc/`` folder.
Compiler warnings of a successful build are logged at INFO; the sources build warning-free
with gcc 12 (tests/map/test_map_native_build.py checks with ``-Werror``). The shared
object is cached under ``$RAMENSIM_CACHE_DIR/native`` (default ``~/.cache/ramensim``),
named ``<kernel>_<key>.so`` with key = hash of the source bytes, the compiler command, the
flags (the shape macros of the MLP kernel included) and the CPU model, and moved into place
atomically, so concurrent processes never load half a file.

Why not ``torch.utils.cpp_extension.load``: measured on the 2-core dev machine (same
flags, cold cache, best of 4), its first build of ``mapkernels.c`` took 0.47 s with ninja
against 0.27 s for this step (cached loads are instant both ways), and ``load()`` has no
setuptools fallback: without the ``ninja`` executable it raises "Ninja is required to load
C++ extensions" (the setuptools path only exists for ``setup.py`` builds). It would also
compile the files as C++20 (``extern "C"`` needed to keep the ctypes symbols), link
libtorch, libc10 and libtorch_python into kernels that need none of them, and key its
cache by extension name and sources, not by CPU model, so a ``-march=native`` object could
be reused on a different CPU sharing the home directory. The direct compiler step keeps
the ctypes calling convention, the C language and the cache's keying (source, flags, CPU;
now also the compiler command) as they were.

Anything that goes wrong (no compiler, a failed build, no write access, a missing source
file, a failed load) gives ``None`` with a warning naming the slowdown and the fix, and the
callers use the pure-torch path; ``RAMENSIM_NO_NATIVE=1`` forces that path.

The kernels link ``libgomp.so.1``; torch (imported first) already loaded its own copy
under that soname, so both share one OpenMP runtime and thread pool.
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

import torch

log = logging.getLogger(__name__)

CSRC = Path(__file__).resolve().with_name("csrc")
"""Folder of the C sources (package data of ``ramensim.agents``)."""
KERNELS_SOURCE = CSRC / "mapkernels.c"
MLP_SOURCE = CSRC / "mapmlp.c"

WARNING_FLAGS = ["-Wall", "-Wextra"]
_FLAGS = ["-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-fopenmp",
          "-shared", "-fPIC", "-g", *WARNING_FLAGS]
# FMA contraction allowed in the decoder kernel (results are checked against torch to 1e-5)
_MLP_FLAGS = [f if f != "-ffp-contract=off" else "-ffp-contract=fast" for f in _FLAGS]

_SLOWDOWN = ("the map uses its pure-torch path instead, roughly 30x slower per mapping "
             "iteration (docs/MAP_PERFORMANCE.md)")
_MLP_SLOWDOWN = ("the map evaluates its decoders with torch matmuls instead, roughly 1.8x "
                 "slower per mapping iteration (docs/MAP_PERFORMANCE.md)")

_lib: ctypes.CDLL | None = None
_tried = False


def _cpu_model() -> str:
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
    for line in _cpu_model().splitlines():
        if line.startswith("flags"):
            return set(line.split(":", 1)[1].split())
    return set()


def march() -> str:
    """Target of the ``-march=`` build flag: ``$RAMENSIM_MARCH`` (e.g. ``x86-64-v3`` to build
    the AVX2 + FMA code an AVX-512 machine would not pick itself), default ``native``."""
    return os.environ.get("RAMENSIM_MARCH", "").strip() or "native"


def _flags(base: list[str]) -> list[str]:
    return [f"-march={march()}" if f == "-march=native" else f for f in base]


def _compiler() -> list[str]:
    return shlex.split(os.environ.get("CC", "") or "gcc")


def cache_dir() -> Path:
    """Where the shared objects are cached: ``$RAMENSIM_CACHE_DIR/native``."""
    root = os.environ.get("RAMENSIM_CACHE_DIR") or Path.home() / ".cache" / "ramensim"
    return Path(root) / "native"


def _fix_hint() -> str:
    return (f"to fix: install gcc with OpenMP (or set CC to such a C compiler), make "
            f"{cache_dir()} writable (or point RAMENSIM_CACHE_DIR elsewhere), and leave "
            f"RAMENSIM_NO_NATIVE unset")


def _compile(source: Path, name: str, flags: list[str],
             defines: dict[str, int] | None = None) -> ctypes.CDLL:
    """Compile ``source`` into the cache (once per source, compiler, flags, macros and CPU)
    and load it."""
    try:
        code = source.read_bytes()
    except OSError as exc:
        raise RuntimeError(f"kernel source {source} unreadable ({exc}); the package "
                           f"install is incomplete, reinstall ramensim") from exc
    cc = _compiler()
    flags = [*flags, *(f"-D{k}={int(v)}" for k, v in (defines or {}).items())]
    key_text = "\0".join([" ".join(cc), " ".join(flags), _cpu_model()])
    key = hashlib.sha256(code + key_text.encode()).hexdigest()[:16]
    cache = cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    so_path = cache / f"{name}_{key}.so"
    if not so_path.exists():
        with tempfile.TemporaryDirectory(dir=cache) as tmp:
            # compile the exact bytes hashed (an edit mid-build cannot poison the cache);
            # the debug info names the package's source file
            src = Path(tmp) / source.name
            src.write_bytes(code)
            out = Path(tmp) / f"{name}.so"
            cmd = [*cc, *flags, f"-fdebug-prefix-map={tmp}={source.parent}", str(src),
                   "-o", str(out), "-lm"]
            try:
                res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
            except FileNotFoundError as exc:
                raise RuntimeError(f"C compiler {cc[0]!r} not found") from exc
            except subprocess.TimeoutExpired as exc:
                raise RuntimeError(f"{cc[0]} timed out building {source.name}") from exc
            if res.returncode != 0:
                raise RuntimeError(f"{cc[0]} failed on {source.name}: "
                                   f"{res.stderr.strip()[:2000]}")
            if res.stderr.strip():
                log.info("compiler warnings building %s:\n%s", source.name, res.stderr.strip())
            os.replace(out, so_path)  # atomic: parallel builders never see half a file
        log.info("built %s into %s", source.name, so_path)
    return ctypes.CDLL(str(so_path))


def _build() -> ctypes.CDLL:
    """Build (or load from the cache) ``csrc/mapkernels.c`` and declare its signatures."""
    lib = _compile(KERNELS_SOURCE, "mapkernels", _flags(_FLAGS))
    P, I64, I = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int
    Fl = ctypes.c_float
    lib.hash_fwd.argtypes = [P, I64, P, I, I, I64, P, P, P, P, I]
    lib.hash_bwd.argtypes = [P, I64, P, I, I, I64, P, P, P, P, I]
    lib.oneblob.argtypes = [P, I64, I, P, I]
    lib.adam_step.argtypes = [P, P, P, P, I64, Fl, Fl, Fl, Fl, Fl, Fl, I]
    lib.count_visits.argtypes = [P, P, I64, I]
    for fn in (lib.hash_fwd, lib.hash_bwd, lib.oneblob, lib.adam_step, lib.count_visits):
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
    if os.environ.get("RAMENSIM_NO_NATIVE", "") not in ("", "0"):
        log.warning("RAMENSIM_NO_NATIVE is set: %s; unset it to use the compiled kernels",
                    _SLOWDOWN)
        return None
    try:
        _lib = _build()
    except Exception as exc:  # noqa: BLE001 - any failure means: use the torch path
        log.warning("native map kernels unavailable (%s); %s; %s", exc, _SLOWDOWN, _fix_hint())
        _lib = None
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
        try:
            lib = _build_mlp(ng, np_, gh, go, ch)
        except Exception as exc:  # noqa: BLE001 - fall back to torch decoders
            log.warning("fused decoder kernel unavailable (%s); %s; %s", exc, _MLP_SLOWDOWN,
                        _fix_hint())
            lib = None
    _mlp_libs[key] = lib
    return lib
