"""Where and from what a run was computed: the host (CPU model, SIMD level, cores, GPU, a short
fingerprint of these) and the build (git commit of the ramensim source and whether it had
uncommitted changes, the ramensim, torch and Python versions). :func:`ramensim.observe.build_info`
adds these keys to ``RunResult.build`` (metrics.json's ``build``):

==============  ==========================================================================
``cpu``         CPU model name (``/proc/cpuinfo``), ``"unknown"`` if unreadable
``simd``        widest SIMD level the kernels can use: ``avx512f``, ``avx2``, ``baseline``, ``unknown``
``cores``       logical CPUs of the machine (``os.cpu_count()``), None if unknown
``gpu``         the CUDA device's name when the maps ran on one, else None
``host``        12 hex digits of SHA-256 over (cpu, simd, cores, gpu): two runs with the same
                value ran on the same kind of machine. No hostname, address or machine id
                goes in: machines of one model and size share a fingerprint, by design
``commit``      ``git rev-parse HEAD`` of the checkout ramensim was imported from; None when git
                is not installed, the source is not a git checkout (an installed wheel) or git
                fails or takes over :data:`GIT_TIMEOUT_S`
``dirty``       True when the package's source folders (:data:`SOURCE_PATHS`) differ from that
                commit (changed or new files); None when ``commit`` is None
``ramensim``    ``ramensim.__version__``
``python``      ``platform.python_version()``
``plugins``     only when plugin files were loaded: ``[{"path", "sha256"}]``, each file's
                absolute path and the SHA-256 of its source (a copy is in the run folder's
                ``plugins/``); ``ramensim compare`` warns when two runs' differ
==============  ==========================================================================

Everything is looked up once per process (:func:`host_info`, :func:`source_info` are cached), so
a sweep's runs or a run's periodic flushes pay for git at most once.

Runs archived before 2026-11-27 carry no ``host`` (and those before 2026-11-25 no ``build`` at
all): :func:`same_host` compares what they do carry. The paper's claims (``ramensim claims``,
ramensim/paper/) mark a trial whose compared runs ran on different hosts with it.
"""
from __future__ import annotations

import functools
import hashlib
import logging
import os
import platform
import shutil
import subprocess
from pathlib import Path
from typing import Any, Mapping

log = logging.getLogger(__name__)

GIT_TIMEOUT_S = 5.0
"""Longest a git call may take (s); past it the commit is recorded as None."""
SOURCE_PATHS = ("core", "world", "channels", "agents", "evaluation", "ramensim", "pyproject.toml")
"""The folders pip installs as the ramensim package (pyproject.toml), relative to the checkout's
root: ``dirty`` looks at these only, not at docs/, tests/ or results."""


def _simd(flags: set[str]) -> str:
    return next((f for f in ("avx512f", "avx2") if f in flags), "baseline" if flags else "unknown")


def fingerprint(cpu: str, simd: str, cores: int | None, gpu: str | None) -> str:
    """12 hex digits of SHA-256 over the host's description (no hostname or machine id)."""
    text = "|".join((cpu, simd, str(cores), gpu or ""))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


@functools.lru_cache(maxsize=None)
def _cpu() -> tuple[str, str, int | None]:
    from ramensim.core.native import cpu_flags, cpu_model

    model = next((ln.split(":", 1)[1].strip() for ln in cpu_model().splitlines() if ln.startswith("model name")),
                 "unknown")
    return model, _simd(cpu_flags()), os.cpu_count()


@functools.lru_cache(maxsize=None)
def _gpu_name(device: str) -> str | None:
    if not device.startswith("cuda"):
        return None
    try:
        import torch

        return str(torch.cuda.get_device_name(torch.device(device)))
    except Exception as exc:  # a CUDA device that cannot be named still ran the run
        log.debug("could not name %s: %s", device, exc)
        return None


def host_info(device: str = "cpu") -> dict[str, Any]:
    """The host's ``cpu``, ``simd``, ``cores``, ``gpu`` (for a ``cuda`` ``device``) and their
    ``host`` fingerprint; cached per process."""
    cpu, simd, cores = _cpu()
    gpu = _gpu_name(str(device))
    return {"cpu": cpu, "simd": simd, "cores": cores, "gpu": gpu, "host": fingerprint(cpu, simd, cores, gpu)}


def _git(root: Path, *args: str) -> str | None:
    """stdout of ``git -C root args`` (stripped), None on any failure or timeout. Optional locks
    are off, so a run never takes the index lock of a checkout someone is committing in."""
    git = shutil.which("git")
    if git is None:
        return None
    env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0", "GIT_TERMINAL_PROMPT": "0", "LC_ALL": "C"}
    try:
        done = subprocess.run([git, "--no-optional-locks", "-C", str(root), *args], capture_output=True,
                              text=True, timeout=GIT_TIMEOUT_S, env=env, stdin=subprocess.DEVNULL, check=False)
    except (OSError, subprocess.SubprocessError) as exc:
        log.debug("git %s in %s failed: %s", " ".join(args), root, exc)
        return None
    if done.returncode != 0:
        return None
    return done.stdout.strip()


def source_root() -> Path:
    """The folder holding the package folders: the checkout's root for an editable install, the
    site-packages folder for a wheel."""
    return Path(__file__).resolve().parents[1]


@functools.lru_cache(maxsize=None)
def _source(root: Path) -> tuple[str | None, bool | None]:
    top = _git(root, "rev-parse", "--show-toplevel")
    # a wheel inside a virtual environment inside some checkout is not that checkout's source
    if top is None or Path(top).resolve() != root.resolve():
        return None, None
    commit = _git(root, "rev-parse", "HEAD")
    if commit is None:
        return None, None
    status = _git(root, "status", "--porcelain", "--untracked-files=normal", "--", *SOURCE_PATHS)
    return commit, (None if status is None else bool(status))


def source_info(root: Path | None = None) -> dict[str, Any]:
    """The build: ``commit`` and ``dirty`` of the checkout at ``root`` (default
    :func:`source_root`; None, None when it is no git checkout or git is missing or fails), and
    the ``ramensim``, ``torch`` and ``python`` versions. Cached per process and root."""
    import torch

    from ramensim import __version__

    commit, dirty = _source(Path(root) if root is not None else source_root())
    return {"commit": commit, "dirty": dirty, "ramensim": __version__, "torch": torch.__version__,
            "python": platform.python_version()}


def provenance(device: str = "cpu") -> dict[str, Any]:
    """:func:`host_info` and :func:`source_info` in one dict (keys listed in the module's doc),
    plus ``plugins`` when plugin files are loaded (:func:`ramensim.plugins.loaded_files`)."""
    from ramensim.plugins import loaded_files

    plugins = loaded_files()
    return {**host_info(device), **source_info(), **({"plugins": plugins} if plugins else {})}


def plugin_code_differs(build_a: Mapping[str, Any] | None, build_b: Mapping[str, Any] | None) -> list[str]:
    """The plugin files (by file name) that two runs' ``build`` records both list with different
    SHA-256: the same plugin, edited between the runs."""
    def by_name(b: Mapping[str, Any] | None) -> dict[str, str]:
        return {Path(p["path"]).name: p["sha256"] for p in (b or {}).get("plugins", []) if "path" in p}

    a, b = by_name(build_a), by_name(build_b)
    return sorted(n for n in a.keys() & b.keys() if a[n] != b[n])


def same_host(build_a: Mapping[str, Any] | None, build_b: Mapping[str, Any] | None) -> bool:
    """Whether two runs' ``build`` records (metrics.json) name the same kind of host.

    Both with a ``host`` fingerprint: those are equal. Otherwise (runs archived 2026-11-25 to
    2026-11-27) the ``cpu``, ``simd`` and device kind (``cpu`` or ``cuda``) they both carry are
    equal. False when either record is missing (runs before 2026-11-25): an unknown host is not
    known to be the same, so a claim comparing such runs is marked as it would be for two hosts.
    """
    if not build_a or not build_b:
        return False
    if build_a.get("host") and build_b.get("host"):
        return build_a["host"] == build_b["host"]

    def old(b: Mapping[str, Any]) -> tuple[Any, Any, str]:
        return b.get("cpu"), b.get("simd"), str(b.get("device") or "").split(":")[0]

    a, b = old(build_a), old(build_b)
    return None not in a[:2] and a == b
