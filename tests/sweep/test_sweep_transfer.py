"""Bringing a finished point folder from a Ray node into the sweep folder (no Ray needed):
pack/unpack, the manifest check, the storage path, and a point whose files do not arrive is
failed, not ok."""
from __future__ import annotations

import io
import json
import os
import tarfile
import time
from collections import deque
from concurrent.futures import Future
from pathlib import Path

import pytest

from ramensim.sweep import store, transfer
from ramensim.sweep.runner import SweepOutcome, _Bar, _drain, _storage_dir
from ramensim.sweep.worker import PointResult, PointTask, execute_point_shipped
from ramensim.core.errors import InputError
from sweep_testfuncs import fake_run, validate_dict


def _task(tmp_path: Path, name: str = "seed=0", **data) -> PointTask:
    runs = tmp_path / "out" / "runs"
    runs.mkdir(parents=True, exist_ok=True)
    return PointTask(name=name, axes={"seed": 0}, data={"seed": 0, **data}, fingerprint="f" * 8,
                     source=str(tmp_path / "base.yaml"), runs_dir=str(runs), run_fn=fake_run,
                     validate_fn=validate_dict)


def test_shipped_through_ray_archive_arrives_whole(tmp_path, monkeypatch):
    node_tmp = tmp_path / "node_tmp"
    node_tmp.mkdir()
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", str(node_tmp))  # the node's temp dir
    task = _task(tmp_path)
    shipment = execute_point_shipped(task)
    assert shipment.result.status == "ok" and shipment.archive and shipment.location is None
    assert set(shipment.manifest) == {"metrics.json", "scenario.json", "status.json", "where.json"}
    assert not list(node_tmp.iterdir())  # the node's temp folder is removed once packed
    assert not (Path(task.runs_dir) / task.name).exists()  # nothing written to the driver's path by the node
    transfer.receive(shipment, Path(task.runs_dir), task.name)
    folder = Path(task.runs_dir) / task.name
    assert store.is_complete(folder, task.fingerprint)
    assert transfer.manifest(folder) == shipment.manifest
    assert not [p for p in Path(task.runs_dir).iterdir() if p.name.startswith(".")]


def test_shipped_through_storage_moves_and_cleans(tmp_path):
    task = _task(tmp_path, fail=True)
    storage = tmp_path / "storage"
    shipment = execute_point_shipped(task, str(storage))
    assert shipment.result.status == "failed" and shipment.archive is None
    assert Path(shipment.location).is_dir() and "error.txt" in shipment.manifest
    transfer.receive(shipment, Path(task.runs_dir), task.name)
    assert store.read_status(Path(task.runs_dir) / task.name)["status"] == "failed"
    assert list(storage.iterdir()) == []  # the storage copy is gone once committed


def test_storage_the_driver_cannot_read_is_an_error_and_keeps_no_folder(tmp_path):
    task = _task(tmp_path)
    gone = transfer.Shipment(PointResult(task.name, "ok"), {"status.json": 10}, "node-7",
                             location=str(tmp_path / "elsewhere" / task.name))
    with pytest.raises(transfer.TransferError, match=r"node-7 .*cannot read.*same path on every node"):
        transfer.receive(gone, Path(task.runs_dir), task.name)
    assert list(Path(task.runs_dir).iterdir()) == []


def test_missing_or_resized_files_fail_the_check(tmp_path):
    task = _task(tmp_path)
    shipment = execute_point_shipped(task)
    shipment.manifest["plots/missing.png"] = 5
    shipment.manifest["metrics.json"] += 1
    with pytest.raises(transfer.TransferError, match=r"1 missing \(plots/missing.png\); 1 with another size"):
        transfer.receive(shipment, Path(task.runs_dir), task.name)
    assert list(Path(task.runs_dir).iterdir()) == []


def test_archive_with_paths_outside_the_folder_is_refused(tmp_path):
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as tar:
        info = tarfile.TarInfo("../escape.txt")
        info.size = 2
        tar.addfile(info, io.BytesIO(b"hi"))
    with pytest.raises(transfer.TransferError, match="not plain relative files"):
        transfer.unpack(buf.getvalue(), tmp_path)
    assert not (tmp_path.parent / "escape.txt").exists()


def test_a_point_whose_files_do_not_arrive_is_failed_not_ok(tmp_path):
    task = _task(tmp_path)
    outcome = SweepOutcome(out_dir=tmp_path / "out", total=1)

    def submit(t: PointTask) -> Future:
        fut: Future = Future()
        fut.set_result("shipment")
        return fut

    def receive(t: PointTask, value: object) -> PointResult:
        raise transfer.TransferError("disk full")

    _drain(deque([task]), 1, submit, outcome, _Bar(1, 0, False, "t"), "ray task failed: ", receive=receive)
    assert not outcome.ok and list(outcome.failed) == [task.name]
    assert "did not reach the sweep folder" in outcome.failed[task.name]
    status = store.read_status(Path(task.runs_dir) / task.name)
    assert status["status"] == "failed" and "disk full" in status["error"]


def test_storage_option_checks(tmp_path):
    with pytest.raises(InputError, match="only used with --executor ray"):
        _storage_dir(tmp_path, "local")
    with pytest.raises(InputError, match="URLs such as s3:// are not supported"):
        _storage_dir("s3://bucket/x", "ray")
    assert _storage_dir("rel/store", "ray").is_absolute()


def test_a_dead_tasks_temp_folder_is_removed_by_the_next_task(tmp_path):
    """A Ray task killed mid-run leaves ``ramensim-point-*`` behind (it grows with the run);
    the next task on the node removes every such folder whose owner process is gone (or, with
    no readable owner, that is older than a day) and nothing else."""
    import subprocess
    import sys as _sys

    from ramensim.sweep import worker
    from ramensim.sweep.worker import OWNER, POINT_DIR_PREFIX, PointTask, execute_point_shipped

    dead = subprocess.run([_sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    storage = tmp_path / "storage"
    storage.mkdir()
    host = worker.socket.gethostname()
    folders = {}
    for tag, owner in (("dead", {"pid": int(dead), "host": host}), ("alive", {"pid": os.getpid(), "host": host}),
                       ("other-host", {"pid": int(dead), "host": host + "-elsewhere"}), ("no-owner-new", None),
                       ("no-owner-old", None)):
        d = storage / f"{POINT_DIR_PREFIX}{tag}-x"
        (d / "p").mkdir(parents=True)
        (d / "p" / "mesh.ply").write_bytes(b"x" * 1000)
        if owner is not None:
            (d / OWNER).write_text(json.dumps(owner))
        folders[tag] = d
    old = time.time() - 2 * worker.STALE_S
    os.utime(folders["no-owner-old"], (old, old))
    task = PointTask(name="seed=0", axes={"seed": 0}, data={"seed": 0}, fingerprint="f",
                     source=str(tmp_path / "base.yaml"), runs_dir=str(tmp_path / "unused"), run_fn=fake_run,
                     validate_fn=validate_dict, fixed={})
    shipment = execute_point_shipped(task, str(storage))
    assert shipment.result.status == "ok"
    left = {p.name for p in storage.iterdir()}
    assert folders["dead"].name not in left and folders["no-owner-old"].name not in left
    assert {folders[t].name for t in ("alive", "other-host", "no-owner-new")} <= left
