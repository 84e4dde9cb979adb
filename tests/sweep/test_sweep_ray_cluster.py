"""The Ray executor on a real (local) cluster: a head node and a worker node started with
``ray start`` in two different working directories, and a driver in a third one with a
relative output folder. Every point must come back into the driver's sweep folder (through
Ray, or through a storage folder), nothing may be written into the nodes' working
directories, and a point counts as ok only once its files are there.

Skipped when the optional 'ray' extra is not installed; slow (two ``ray start``)."""
from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

from ramensim.sweep import store

ray = pytest.importorskip("ray", reason="the optional 'ray' extra is not installed (pip install 'ramensim[ray]')")

pytestmark = [pytest.mark.slow, pytest.mark.timeout(1200),  # a hang guard only (a node that never comes up)
              pytest.mark.skipif(not Path(sys.executable).with_name("ray").is_file(),
                                 reason="the 'ray' command is not beside this Python")]

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
RAY_CLI = Path(sys.executable).with_name("ray")
READY = "This command will now block forever"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(args: list[str], cwd: Path, log: Path, env: dict[str, str]) -> subprocess.Popen:
    """``ray start ... --block`` in its own process group (so the test stops exactly what it
    started), waiting until the node says it is up or its command ends (no clock: the module's
    pytest-timeout mark is the hang guard)."""
    with log.open("wb") as fh:
        proc = subprocess.Popen([str(RAY_CLI), "start", *args, "--block", "--disable-usage-stats"], cwd=cwd,
                                env=env, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True)
    while proc.poll() is None:
        if READY in log.read_text(errors="replace"):
            return proc
        time.sleep(0.5)
    _stop(proc)
    pytest.fail(f"ray start {' '.join(args)} did not come up:\n{log.read_text(errors='replace')[-3000:]}")


def _stop(proc: subprocess.Popen) -> None:
    """Stop the node's process group: SIGTERM, then SIGKILL what is left after 5 s."""
    for sig, wait_s in ((signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            try:
                os.killpg(proc.pid, 0)
            except ProcessLookupError:
                proc.poll()
                return
            proc.poll()
            time.sleep(0.2)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A head without CPUs (nothing runs there) and a 2-CPU worker node, each in its own cwd."""
    root = tmp_path_factory.mktemp("cluster")
    head_cwd, node_cwd = root / "head_cwd", root / "node_cwd"
    head_cwd.mkdir()
    node_cwd.mkdir()
    ray_tmp = Path(tempfile.mkdtemp(prefix="rsray-", dir="/tmp"))  # short: Ray's socket paths are length-limited
    env = dict({k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")},
               RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(16), RAY_USAGE_STATS_ENABLED="0",
               PYTHONPATH=os.pathsep.join([str(REPO), str(HERE), os.environ.get("PYTHONPATH", "")]))
    port = _free_port()
    procs = []
    try:
        procs.append(_start(["--head", f"--port={port}", "--num-cpus=0", "--include-dashboard=false",
                             f"--temp-dir={ray_tmp}", f"--dashboard-agent-listen-port={_free_port()}"],
                            head_cwd, root / "head.log", env))
        procs.append(_start([f"--address=127.0.0.1:{port}", "--num-cpus=2",
                             f"--dashboard-agent-listen-port={_free_port()}"], node_cwd, root / "node.log", env))
        yield {"address": f"127.0.0.1:{port}", "env": env, "head_cwd": head_cwd, "node_cwd": node_cwd, "root": root}
    finally:
        for proc in reversed(procs):
            _stop(proc)
        shutil.rmtree(ray_tmp, ignore_errors=True)


def _sweep_file(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = folder / "s.yaml"
    path.write_text(yaml.safe_dump({"base": "base.yaml", "axes": {"fail": [False, True], "seed": [0, 1]}},
                                   sort_keys=False))
    return path


def _check_folder(out: Path, node_cwd: Path) -> None:
    for name in ("fail=false__seed=0", "fail=false__seed=1"):
        folder = out / "runs" / name
        assert store.is_complete(folder), name
        assert {p.name for p in folder.iterdir()} >= {"status.json", "metrics.json", "scenario.json", "where.json"}
        where = json.loads((folder / "where.json").read_text())
        assert where["cwd"] == str(node_cwd)  # it ran on the worker node, from that node's cwd
        assert where["omp_wait_policy"] == "PASSIVE"  # the driver's policy, not the node's (none)
    for name in ("fail=true__seed=0", "fail=true__seed=1"):
        status = store.read_status(out / "runs" / name)
        assert status["status"] == "failed" and "injected failure" in status["error"]
        assert (out / "runs" / name / "error.txt").is_file()
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]


DRIVER = """
import json, sys
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict

address, out, storage, retry = sys.argv[1], sys.argv[2], sys.argv[3] or None, sys.argv[4] == "1"
plan = plan_sweep("s.yaml", validate_fn=validate_dict)
res = run_sweep(plan, out, executor="ray", address=address, run_fn=fake_run, validate_fn=validate_dict,
                progress=False, storage=storage, retry_failed=retry)
print(json.dumps({"ok": sorted(res.ok), "failed": sorted(res.failed), "skipped": res.skipped}))
"""


def _drive(cluster, cwd: Path, out: str, storage: Path | None = None, retry: bool = True) -> dict:
    """The driver: its own process (Ray reads its settings when it is imported), its own cwd,
    a relative output folder."""
    proc = subprocess.run([sys.executable, "-c", DRIVER, cluster["address"], out, str(storage or ""),
                           "1" if retry else "0"], cwd=cwd, env={**cluster["env"], "OMP_WAIT_POLICY": "PASSIVE"},
                          capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_results_travel_back_to_the_driver_from_a_node_with_another_cwd(cluster, tmp_path):
    driver_cwd = tmp_path / "driver_cwd"
    _sweep_file(driver_cwd)
    res = _drive(cluster, driver_cwd, "out")
    assert res["ok"] == ["fail=false__seed=0", "fail=false__seed=1"]
    assert res["failed"] == ["fail=true__seed=0", "fail=true__seed=1"]
    _check_folder(driver_cwd / "out", cluster["node_cwd"])

    # through a storage folder the user names (here on the one machine's file system)
    storage = cluster["root"] / "storage"
    res = _drive(cluster, driver_cwd, "out_storage", storage)
    assert len(res["ok"]) == 2 and len(res["failed"]) == 2
    _check_folder(driver_cwd / "out_storage", cluster["node_cwd"])
    assert list(storage.iterdir()) == []  # moved into the sweep folder, nothing left behind

    again = _drive(cluster, driver_cwd, "out", retry=False)
    assert again["skipped"] == 4 and not again["ok"]
    # nothing written into the nodes' working directories
    assert list(cluster["node_cwd"].iterdir()) == []
    assert list(cluster["head_cwd"].iterdir()) == []
