"""ramensim/provenance.py: the host and build a run records in metrics.json. The git lookup gives
None (never an error) with no git, outside a checkout, for a wheel inside someone's checkout,
and when git fails or hangs; it looks only at the package's source folders; it runs once per
process. same_host compares fingerprints, or older records' CPU, SIMD and device."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from ramensim import provenance as prov

HAS_GIT = shutil.which("git") is not None


@pytest.fixture(autouse=True)
def _fresh_caches():
    prov._source.cache_clear()
    yield
    prov._source.cache_clear()


def _git(root: Path, *args: str) -> str:
    env = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@example.org", "HOME": str(root), "PATH": "/usr/bin:/bin"}
    return subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True, text=True,
                          env=env).stdout.strip()


@pytest.fixture
def checkout(tmp_path: Path) -> Path:
    """A git checkout laid out like the project: a source folder and a docs folder."""
    if not HAS_GIT:
        pytest.skip("git is not installed")
    root = tmp_path / "repo"
    (root / "ramensim").mkdir(parents=True)
    (root / "docs").mkdir()
    (root / "ramensim" / "mod.py").write_text("X = 1\n")
    (root / "docs" / "page.md").write_text("text\n")
    _git(root, "init", "-q")
    _git(root, "add", ".")
    _git(root, "commit", "-q", "-m", "first")
    return root


def test_checkout_commit_and_dirty_flag_of_the_source_only(checkout: Path) -> None:
    head = _git(checkout, "rev-parse", "HEAD")
    info = prov.source_info(checkout)
    assert info["commit"] == head and info["dirty"] is False
    (checkout / "docs" / "page.md").write_text("changed\n")  # results and docs are not the build
    prov._source.cache_clear()
    assert prov.source_info(checkout)["dirty"] is False
    (checkout / "ramensim" / "new.py").write_text("Y = 2\n")  # a new source file is
    prov._source.cache_clear()
    assert prov.source_info(checkout) == {**info, "dirty": True}


def test_versions_recorded(tmp_path: Path) -> None:
    import platform

    import torch

    import ramensim

    info = prov.source_info(tmp_path)
    assert info["ramensim"] == ramensim.__version__ and info["torch"] == torch.__version__
    assert info["python"] == platform.python_version()


def test_no_git_installed_records_none(checkout: Path, monkeypatch) -> None:
    monkeypatch.setattr(prov.shutil, "which", lambda name: None)
    info = prov.source_info(checkout)
    assert info["commit"] is None and info["dirty"] is None


def test_not_a_checkout_records_none(tmp_path: Path) -> None:
    info = prov.source_info(tmp_path)  # /tmp/...: no repository above it
    assert info["commit"] is None and info["dirty"] is None


def test_wheel_inside_a_checkout_is_not_that_checkout(checkout: Path) -> None:
    site = checkout / ".venv" / "lib" / "site-packages"  # the package installed in a venv in a repo
    site.mkdir(parents=True)
    assert prov.source_info(site)["commit"] is None


def test_git_failing_or_hanging_records_none(checkout: Path, monkeypatch) -> None:
    def hang(*args, **kwargs):
        raise subprocess.TimeoutExpired(args[0], kwargs.get("timeout"))

    monkeypatch.setattr(prov.subprocess, "run", hang)
    assert prov.source_info(checkout)["commit"] is None
    prov._source.cache_clear()

    def fail(*args, **kwargs):
        raise OSError("exec format error")

    monkeypatch.setattr(prov.subprocess, "run", fail)
    assert prov.source_info(checkout)["commit"] is None


def test_git_runs_once_per_process(checkout: Path, monkeypatch) -> None:
    calls: list[tuple[str, ...]] = []
    real = prov._git
    monkeypatch.setattr(prov, "_git", lambda root, *a: calls.append(a) or real(root, *a))
    first = prov.source_info(checkout)
    n = len(calls)
    assert n >= 2 and all(prov.source_info(checkout) == first for _ in range(5))
    assert len(calls) == n


def test_host_info_and_fingerprint() -> None:
    h = prov.host_info("cpu")
    assert set(h) == {"cpu", "simd", "cores", "gpu", "host"} and h["gpu"] is None
    assert h["simd"] in ("avx512f", "avx2", "baseline", "unknown")
    assert h["host"] == prov.fingerprint(h["cpu"], h["simd"], h["cores"], None)
    assert len(h["host"]) == 12 and int(h["host"], 16) >= 0
    assert prov.fingerprint(h["cpu"], h["simd"], (h["cores"] or 1) + 1, None) != h["host"]
    assert prov.fingerprint(h["cpu"], h["simd"], h["cores"], "NVIDIA H100") != h["host"]


def test_same_host() -> None:
    amd = {"cpu": "AMD EPYC", "simd": "avx512f", "device": "cpu", "host": "aaaaaaaaaaaa"}
    intel = {"cpu": "Intel Xeon", "simd": "avx512f", "device": "cpu", "host": "bbbbbbbbbbbb"}
    assert prov.same_host(amd, dict(amd)) and not prov.same_host(amd, intel)
    # records from before the fingerprint: CPU, SIMD and device kind
    old_amd = {"cpu": "AMD EPYC", "simd": "avx512f", "device": "cpu"}
    assert prov.same_host(old_amd, dict(old_amd)) and prov.same_host(old_amd, amd)
    assert not prov.same_host(old_amd, {**old_amd, "device": "cuda:0"})
    assert not prov.same_host(old_amd, {**old_amd, "simd": "avx2"})
    # no record: not known to be the same
    assert not prov.same_host(None, amd) and not prov.same_host({}, {})
    assert not prov.same_host({"device": "cpu"}, {"device": "cpu"})
