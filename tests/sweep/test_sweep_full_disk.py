"""A sweep on a full disk (issue 28): a sweep point whose folder cannot be written is failed in
memory and the sweep goes on; on a real 1 MiB tmpfs (where this machine lets the test mount one)
the finished points are kept and a resume runs only the failed ones. (A single run on a full
disk: tests/e2e/test_e2e_full_disk.py.)"""
from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from sweep_testfuncs import blob_run, fake_run, validate_dict


def test_a_sweep_point_whose_folder_cannot_be_written_fails_in_memory(tmp_path, monkeypatch):
    """The worker's own bookkeeping hits ENOSPC: the point is failed with the reason, the
    sweep's worker function returns instead of raising, and nothing half-made is published."""
    from ramensim.sweep import store
    from ramensim.sweep.worker import PointTask, execute_point, record_failure

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


def test_a_sweep_onto_a_full_tmpfs_keeps_its_finished_points_and_resumes(tmp_path):
    """A 1 MiB tmpfs, 6 points of 150 kB each, 600 kB of it taken by another file: the first
    points commit, the others fail with ENOSPC, the sweep finishes (no crash) with every
    failure recorded; once the other file is gone, a resume runs only the failed points."""
    from ramensim.sweep import store
    from ramensim.sweep.runner import run_sweep
    from ramensim.sweep.spec import plan_sweep

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
