"""A full disk (issue 28): a run writes its small results first and every file atomically, so on
ENOSPC it keeps a valid metrics.json, leaves no torn or temp file, names the file that did not
fit and the bytes it needed, and exits non-zero. Once with an injected ENOSPC (always), once on a
real 1 MiB tmpfs (where this machine lets the test mount one). A sweep on a full disk:
tests/sweep/test_sweep_full_disk.py."""
from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from ramensim.cli import main
from ramensim.core.results import RunResult

from tiny_runs import ROOT, SCENARIO, TINY


def _args(out: Path, *extra: str) -> list[str]:
    args = ["-q", "run", str(SCENARIO), "--out", str(out)]
    for s in (*TINY, "duration=2", *extra):
        args += ["--set", s]
    return args


def _leftovers(out: Path) -> list[str]:
    return sorted(p.name for p in out.iterdir() if p.name.startswith(".") and p.name != ".run.lock")


def _check_kept(out: Path) -> RunResult:
    result = RunResult.read(out / "metrics.json")  # valid and complete: the final one, not a partial
    assert result.status == "ok" and result.per_agent["agent_0"].completion_ratio_pct is not None
    assert not _leftovers(out), _leftovers(out)
    return result


def test_enospc_on_the_meshes_keeps_metrics_and_names_the_file(tmp_path, monkeypatch, capsys):
    real = Path.write_bytes

    def half_then_full(self: Path, data: bytes) -> int:
        if self.name.startswith(".mesh_") and self.name.endswith(".tmp"):
            real(self, data[: len(data) // 2])  # a torn temp file, as a full disk leaves it
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", half_then_full)
    out = tmp_path / "run"
    assert main(_args(out)) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert f"{out / 'metrics.json'}" in err and "mesh_agent_0.ply: could not write" in err
    assert "bytes (No space left on device); free at least that much space" in err
    _check_kept(out)
    assert not list(out.glob("mesh_*.ply"))  # never a torn mesh under its final name
    log = (out / "run.log").read_text()
    assert "mesh_agent_1.ply: could not write" in log


def _mount_tmpfs(where: Path, size: str) -> bool:
    if sys.platform != "linux" or shutil.which("mount") is None:
        return False
    where.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                          capture_output=True, text=True)
    return proc.returncode == 0


def test_a_run_onto_a_1_mib_tmpfs_keeps_its_metrics(tmp_path):
    """The real thing: the meshes of this run (voxel 5 cm) need more than 1 MiB."""
    mnt = tmp_path / f"disk-{uuid.uuid4().hex[:6]}"
    if not _mount_tmpfs(mnt, "1m"):
        pytest.skip("cannot mount a tmpfs here (needs root on Linux)")
    try:
        out = mnt / "run"
        env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT))
        proc = subprocess.run([sys.executable, "-m", "ramensim", *_args(out, "evaluation.voxel_m=0.05")],
                              capture_output=True, text=True, env=env, timeout=600)
        assert proc.returncode == 2, proc.stderr
        assert "Traceback" not in proc.stderr and "Logging error" not in proc.stderr
        assert "could not write" in proc.stderr and "No space left on device" in proc.stderr
        _check_kept(out)
        for ply in out.glob("mesh_*.ply"):  # a mesh that fitted is whole
            assert ply.stat().st_size > 0 and json.loads((out / "metrics.json").read_text())
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
