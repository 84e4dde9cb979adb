"""A full disk (issue 28): a run writes its small results first and every file atomically, so on
ENOSPC it keeps a valid metrics.json, leaves no torn or temp file, names the file that did not
fit and the bytes it needed, and exits non-zero; a sweep point whose folder cannot be written is
failed in memory and the sweep goes on. Once with an injected ENOSPC (always), once on a real
1 MiB tmpfs (where this machine lets the test mount one)."""
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


def test_a_sweep_point_whose_folder_cannot_be_written_fails_in_memory(tmp_path, monkeypatch):
    """The worker's own bookkeeping hits ENOSPC: the point is failed with the reason, the
    sweep's worker function returns instead of raising, and nothing half-made is published."""
    from ramensim.sweep import store
    from ramensim.sweep.worker import PointTask, execute_point, record_failure

    monkeypatch.syspath_prepend(str(ROOT / "tests" / "sweep"))
    from sweep_testfuncs import fake_run, validate_dict

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    runs = tmp_path / "runs"
    runs.mkdir()
    task = PointTask(name="seed=0", axes={"seed": 0}, data={"seed": 0, "fail": True}, fingerprint="f",
                     source=str(tmp_path / "base.yaml"), runs_dir=str(runs), run_fn=fake_run,
                     validate_fn=validate_dict, fixed={})
    real_json = store.atomic_write_json
    calls = {"n": 0}

    def full_after_start(path, data, sort_keys=False):  # the 'running' status fits, nothing after
        calls["n"] += 1
        if calls["n"] > 1:
            full()
        real_json(path, data, sort_keys)

    monkeypatch.setattr(store, "atomic_write_text", full)
    monkeypatch.setattr(store, "atomic_write_json", full_after_start)
    res = execute_point(task)
    assert res.status == "failed" and "injected failure" in res.error and "could not be written" in res.error
    assert not (runs / "seed=0").exists()
    monkeypatch.setattr(store, "atomic_write_json", full)
    res = record_failure(task, "the worker died")
    assert res.status == "failed" and res.error == "the worker died"
    assert not (runs / "seed=0").exists()


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


def test_a_sweep_onto_a_full_tmpfs_keeps_its_finished_points_and_resumes(tmp_path, monkeypatch):
    """A 1 MiB tmpfs, 6 points of 150 kB each, 600 kB of it taken by another file: the first
    points commit, the others fail with ENOSPC, the sweep finishes (no crash) with every
    failure recorded; once the other file is gone, a resume runs only the failed points."""
    from ramensim.sweep import store
    from ramensim.sweep.runner import run_sweep
    from ramensim.sweep.spec import plan_sweep

    monkeypatch.syspath_prepend(str(ROOT / "tests" / "sweep"))
    from sweep_testfuncs import blob_run, validate_dict

    mnt = tmp_path / f"disk-{uuid.uuid4().hex[:6]}"
    if not _mount_tmpfs(mnt, "1m"):
        pytest.skip("cannot mount a tmpfs here (needs root on Linux)")
    try:
        ballast = mnt / "ballast.bin"
        ballast.write_bytes(b"\0" * 600_000)
        (tmp_path / "base.yaml").write_text("method: ramen\n")
        (tmp_path / "sweep.yaml").write_text("name: t\nbase: base.yaml\nset: {blob_bytes: 150000}\n"
                                             "axes: {seed: [0, 1, 2, 3, 4, 5]}\n")
        plan = plan_sweep(tmp_path / "sweep.yaml", validate_fn=validate_dict)
        out = mnt / "sweep"
        res = run_sweep(plan, out, workers=1, run_fn=blob_run, validate_fn=validate_dict, progress=False)
        assert res.ok and res.failed and len(res.ok) + len(res.failed) == 6
        assert any("No space left" in e or "could not" in e for e in res.failed.values()), res.failed
        kept = sorted(res.ok)
        for name in kept:
            assert store.is_complete(out / "runs" / name)
        ballast.unlink()
        res2 = run_sweep(plan, out, workers=1, run_fn=blob_run, validate_fn=validate_dict, progress=False)
        assert res2.skipped == len(kept) and sorted(res2.ok) == sorted(res.failed) and not res2.failed
        assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
