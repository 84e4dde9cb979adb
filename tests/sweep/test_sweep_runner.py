"""The sweep runner: failures recorded and the sweep goes on, resume runs only what is
missing, a kill -9 in the middle leaves no half-written result, a dead worker is survived."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

from ramensim.core.errors import InputError
from ramensim.sweep import runner, store
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, hard_crash, validate_dict

# A hang guard only (pytest-timeout), far above any honest run of these tests on a loaded
# machine: the tests check states (which points ran, which were interrupted), never seconds.
pytestmark = pytest.mark.timeout(900)

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


def _plan(tmp_path: Path, axes: dict, fixed: dict | None = None):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "base": "base.yaml", "set": fixed or {}, "axes": axes},
                                   sort_keys=False))
    return plan_sweep(path, validate_fn=validate_dict)


def _log_lines(path: Path) -> list:
    return [json.loads(x) for x in path.read_text().splitlines()] if path.exists() else []


def test_failed_and_diverged_runs_are_recorded_and_the_sweep_goes_on(tmp_path):
    log = tmp_path / "calls.log"
    plan = _plan(tmp_path, {"fail": [False, True], "diverge": [False, True]},
                 {"log_file": str(log), "write_metrics": True})
    out = tmp_path / "out"
    res = run_sweep(plan, out, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert sorted(res.ok) == ["fail=false__diverge=false"]
    assert sorted(res.diverged) == ["fail=false__diverge=true"]
    assert sorted(res.failed) == ["fail=true__diverge=false", "fail=true__diverge=true"]
    assert "RuntimeError: injected failure" in res.failed["fail=true__diverge=false"]
    failed_dir = out / "runs" / "fail=true__diverge=false"
    st = json.loads((failed_dir / "status.json").read_text())
    assert st["status"] == "failed" and "injected failure" in st["error"] and st["axes"]["fail"] is True
    assert "Traceback" in (failed_dir / "error.txt").read_text()
    assert not (failed_dir / "metrics.json").exists()
    div = json.loads((out / "runs" / "fail=false__diverge=true" / "status.json").read_text())
    assert div["status"] == "diverged" and div["diverged_agents"] == [0]
    assert json.loads((out / "sweep.json").read_text())["axes"] == {"fail": [False, True], "diverge": [False, True]}
    assert len(_log_lines(log)) == 4
    # resume: complete points are not run again; failed ones only when asked to retry
    res2 = run_sweep(plan, out, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False,
                     retry_failed=False)
    assert res2.skipped == 4 and not res2.ok and not res2.failed and len(_log_lines(log)) == 4
    res3 = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert res3.skipped == 2 and len(res3.failed) == 2 and len(_log_lines(log)) == 6
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]


def test_an_interrupted_run_is_not_a_result(tmp_path):
    plan = _plan(tmp_path, {"interrupted": [False, True]})
    out = tmp_path / "out"
    res = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert res.ok == ["interrupted=false"]
    assert "status 'interrupted'" in res.failed["interrupted=true"]
    assert not store.is_complete(out / "runs" / "interrupted=true")


def test_changed_scenario_makes_stored_results_stale(tmp_path):
    out = tmp_path / "out"
    plan = _plan(tmp_path, {"seed": [0, 1]}, {"duration": 1})
    assert len(run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False).ok) == 2
    same = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert same.skipped == 2 and not same.ok
    changed = _plan(tmp_path, {"seed": [0, 1]}, {"duration": 2})
    again = run_sweep(changed, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert again.skipped == 0 and len(again.ok) == 2


def test_a_point_finished_elsewhere_while_the_sweep_runs_is_not_run_again(tmp_path):
    """A result copied into the folder after the sweep planned (e.g. run on a GPU machine) counts."""
    log, hold = tmp_path / "calls.log", tmp_path / "hold"
    plan = _plan(tmp_path, {"tag": ["a", "b"]}, {"log_file": str(log), "write_metrics": True, "hold_while": str(hold)})
    elsewhere = run_sweep(plan, tmp_path / "elsewhere", workers=1, run_fn=fake_run, validate_fn=validate_dict,
                          progress=False)
    assert sorted(elsewhere.ok) == ["tag=a", "tag=b"] and len(_log_lines(log)) == 2
    out = tmp_path / "out"
    hold.write_text("")  # point a runs until the result of b has been copied in

    def copy_b_in() -> None:  # point a holds (at most 120 s, sweep_testfuncs) until b is copied in
        while not any(p.name.startswith(".partial-tag=a") for p in (out / "runs").glob(".partial-*")):
            time.sleep(0.05)
        shutil.copytree(tmp_path / "elsewhere" / "runs" / "tag=b", out / "runs" / "tag=b")
        hold.unlink()

    copier = threading.Thread(target=copy_b_in, daemon=True)
    copier.start()
    res = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    copier.join()
    assert res.ok == ["tag=a"] and res.skipped == 1 and not res.failed
    assert _log_lines(log)[2:] == ["a"]  # b was not run a second time
    assert store.is_complete(out / "runs" / "tag=b")


def test_a_sweep_that_cannot_take_the_folder_lock_to_plan_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "PLAN_LOCK_WAIT_S", 0.3)
    out = tmp_path / "out"
    plan = _plan(tmp_path, {"seed": [0]})
    with store.SweepLock(out):
        with pytest.raises(InputError, match="another sweep is running"):
            run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)


def _wait_for_partial(out: Path, name: str, *sweeps: threading.Thread) -> None:
    """Until point ``name`` has started; fails if a sweep ends first (its points hold at most
    120 s, sweep_testfuncs), never on a clock (a busy machine only makes it slower)."""
    while not any(p.name.startswith(f".partial-{name}-") for p in (out / "runs").glob(".partial-*")):
        assert all(t.is_alive() for t in sweeps), f"a sweep ended before point {name} started"
        time.sleep(0.05)


def _in_thread(results: dict, key: str, *args, **kwargs) -> threading.Thread:
    def target() -> None:
        try:
            results[key] = run_sweep(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - handed to the test
            results[key] = exc
    thread = threading.Thread(target=target)
    thread.start()
    return thread


def test_two_sweeps_of_one_plan_in_one_folder_share_its_points(tmp_path):
    """The second sweep joins the first: it passes over the point the first is running, runs
    another, and every point runs exactly once."""
    log, hold = tmp_path / "calls.log", tmp_path / "hold"
    plan = _plan(tmp_path, {"tag": ["a", "b", "c"]}, {"log_file": str(log), "write_metrics": True,
                                                       "hold_while": str(hold)})
    out, results = tmp_path / "out", {}
    hold.write_text("")  # both sweeps' first points run until both have started
    kwargs = dict(workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    first = _in_thread(results, "first", plan, out, **kwargs)
    _wait_for_partial(out, "tag=a", first)
    second = _in_thread(results, "second", plan, out, **kwargs)
    _wait_for_partial(out, "tag=b", first, second)  # the second passed over a, which the first holds
    hold.unlink()
    first.join(120)
    second.join(120)
    one, two = results["first"], results["second"]
    assert not isinstance(one, Exception) and not isinstance(two, Exception), results
    assert sorted(_log_lines(log)) == ["a", "b", "c"]  # every point ran exactly once
    assert "tag=a" in one.ok and "tag=b" in two.ok and "tag=a" in two.elsewhere
    assert sorted(one.ok + two.ok) == ["tag=a", "tag=b", "tag=c"] and not one.failed and not two.failed
    assert all(store.is_complete(out / "runs" / f"tag={t}") for t in "abc")
    assert not [p.name for p in (out / "runs").iterdir() if p.name.startswith(".")]  # no claim or temp left


def test_a_sweep_of_another_plan_is_refused_while_one_runs_in_the_folder(tmp_path):
    hold = tmp_path / "hold"
    plan = _plan(tmp_path, {"tag": ["a"]}, {"hold_while": str(hold)})
    out, results = tmp_path / "out", {}
    hold.write_text("")
    first = _in_thread(results, "first", plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict,
                       progress=False)
    try:
        _wait_for_partial(out, "tag=a", first)
        (tmp_path / "other").mkdir()
        other = _plan(tmp_path / "other", {"tag": ["x"]})
        with pytest.raises(InputError, match="another sweep with a different plan is running.*runs tag=a"):
            run_sweep(other, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
        assert any(p.name.startswith(".partial-tag=a-") for p in (out / "runs").iterdir())  # left running
    finally:
        hold.unlink()
        first.join(120)
    assert results["first"].ok == ["tag=a"]
    assert json.loads((out / "sweep.json").read_text())["axes"] == {"tag": ["a"]}  # its plan kept


def test_leftovers_of_a_point_another_sweep_runs_are_kept(tmp_path):
    runs = tmp_path / "runs"
    (runs / ".partial-tag=a-0123abcd").mkdir(parents=True)
    (runs / ".partial-tag=b-0123abcd").mkdir()
    (runs / ".claim-tag=c").write_text("")  # left by a sweep killed with -9: free
    claim = store.PointClaim(runs, "tag=a")
    assert claim.try_acquire()
    try:
        assert store.claimed_points(runs) == ["tag=a"]
        assert store.clean_leftovers(runs) == 1  # b's only: a is claimed
        assert sorted(p.name for p in runs.iterdir()) == [".claim-tag=a", ".partial-tag=a-0123abcd"]
        assert not store.PointClaim(runs, "tag=a").try_acquire()
    finally:
        claim.release()
    assert store.clean_leftovers(runs) == 1 and not list(runs.iterdir())


def test_a_worker_that_dies_is_replaced_and_its_point_recorded_as_failed(tmp_path):
    plan = _plan(tmp_path, {"crash": [False, True], "seed": [0, 1]})
    out = tmp_path / "out"
    res = run_sweep(plan, out, workers=1, run_fn=hard_crash, validate_fn=validate_dict, progress=False)
    assert sorted(res.ok) == ["crash=false__seed=0", "crash=false__seed=1"]
    assert sorted(res.failed) == ["crash=true__seed=0", "crash=true__seed=1"]
    assert "died" in res.failed["crash=true__seed=0"]
    st = store.read_status(out / "runs" / "crash=true__seed=1")
    assert st["status"] == "failed"


_DRIVER = """
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict
plan = plan_sweep({sweep!r}, validate_fn=validate_dict)
run_sweep(plan, {out!r}, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False)
"""


def _committed(out: Path) -> set[str]:
    runs = out / "runs"
    return {p.name for p in runs.iterdir() if not p.name.startswith(".")} if runs.is_dir() else set()


def test_kill_9_in_the_middle_then_resume_runs_only_the_missing_points(tmp_path):
    n = 8
    log = tmp_path / "calls.log"
    plan = _plan(tmp_path, {"tag": list(range(n))}, {"sleep_s": 0.4, "log_file": str(log)})
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(HERE)])}
    script = _DRIVER.format(sweep=str(tmp_path / "sweep.yaml"), out=str(out))
    proc = subprocess.Popen([sys.executable, "-c", script], env=env, cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    while len(_committed(out)) < 2 or len(_log_lines(log)) <= len(_committed(out)):
        assert proc.poll() is None, proc.stderr.read().decode()  # the sweep ended first
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=10)
    time.sleep(0.5)  # workers die with their parent (PR_SET_PDEATHSIG); give the kernel a moment
    done_before = _committed(out)
    assert 2 <= len(done_before) < n, done_before
    for name in done_before:  # whatever is published is complete: never a half-written result
        assert store.is_complete(out / "runs" / name)
    calls_before = len(_log_lines(log))
    assert calls_before > len(done_before)  # some points were in flight when killed
    res = run_sweep(plan, out, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    rerun = _log_lines(log)[calls_before:]
    expected = sorted(int(name.split("=")[1]) for name in _committed(out) - done_before)
    assert sorted(rerun) == sorted(set(range(n)) - {int(x.split("=")[1]) for x in done_before}) == expected
    assert res.skipped == len(done_before) and len(res.ok) == n - len(done_before)
    assert _committed(out) == {f"tag={i}" for i in range(n)}
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]


_TERM_DRIVER = """
import sys
from ramensim.commands.sweep import _TermAsInterrupt
from ramensim.sweep.runner import SweepInterrupted, run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict
plan = plan_sweep({sweep!r}, validate_fn=validate_dict)
try:
    with _TermAsInterrupt():
        run_sweep(plan, {out!r}, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False)
except SweepInterrupted as stop:
    print("interrupted:", ",".join(sorted(stop.outcome.interrupted)), "ok:", len(stop.outcome.ok), flush=True)
    sys.exit(130)
"""


def test_sigterm_stops_a_sweep_without_waiting_for_its_running_points(tmp_path):
    """SIGTERM to a sweep with two running points: it exits while they still run (they hold
    until the test removes the hold file, after the sweep has exited; a sweep that waited for
    them would see them finish 'ok' after their 120-s cap), says which points it stopped,
    marks them 'interrupted' on disk (no temp folder published, finished points kept), and a
    resume runs exactly those. Checked by state, not by a clock."""
    log = tmp_path / "calls.log"
    hold = tmp_path / "hold"
    hold.write_text("")
    plan = _plan(tmp_path, {"tag": [0, 1, 2]}, {"hold_while": str(hold), "log_file": str(log)})
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(HERE)])}
    script = _TERM_DRIVER.format(sweep=str(tmp_path / "sweep.yaml"), out=str(out))
    proc = subprocess.Popen([sys.executable, "-c", script], env=env, cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    while len(_log_lines(log)) < 2:  # both workers are inside a point
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate()
    assert proc.returncode == 130, stderr.decode()
    running = sorted(f"tag={t}" for t in _log_lines(log))
    assert f"interrupted: {','.join(running)} ok: 0" in stdout.decode()
    for name in running:
        st = store.read_status(out / "runs" / name)
        assert st["status"] == "interrupted" and "stopped" in st["error"]
        assert not store.is_complete(out / "runs" / name)
    assert "tag=2" not in _committed(out)  # never started
    hold.unlink()
    res = run_sweep(plan, out, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert sorted(res.ok) == ["tag=0", "tag=1", "tag=2"] and res.skipped == 0
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]


def test_corrupt_committed_points_are_run_again_and_reported_failed(tmp_path, caplog):
    """A committed point whose metrics.json does not parse, or whose status.json is unreadable,
    is no result: the report counts it failed (naming why), the resume's plan lists it to run,
    and the resume runs exactly those two."""
    from ramensim.sweep.aggregate import load_runs
    from ramensim.sweep.runner import pending_points

    log = tmp_path / "calls.log"
    plan = _plan(tmp_path, {"tag": [0, 1, 2]}, {"log_file": str(log), "write_metrics": True})
    out = tmp_path / "out"
    run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    (out / "runs" / "tag=0" / "metrics.json").write_text('{"agents": [')  # torn
    (out / "runs" / "tag=1" / "status.json").write_bytes(b"\x00\xff")
    with caplog.at_level("WARNING"):
        _, records = load_runs(out)
    states = {r.name: (r.status, r.error) for r in records}
    assert states["tag=0"] == ("failed", "metrics.json missing or unreadable")
    assert states["tag=1"] == ("failed", "status.json missing or unreadable")
    assert states["tag=2"][0] == "ok"
    assert "tag=1" in caplog.text
    todo, done = pending_points(plan, out)
    assert todo == ["tag=0", "tag=1"] and done == 1
    calls = len(_log_lines(log))
    res = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert sorted(_log_lines(log)[calls:]) == [0, 1] and res.skipped == 1
    assert all(store.is_complete(out / "runs" / f"tag={t}") for t in range(3))


def test_a_sweep_of_another_plan_is_refused_before_the_running_one_claims_a_point(tmp_path):
    """From the end of its planning a sweep marks the folder (``.sweeping``): no window in which
    another plan could take the folder over while the first validates its points."""
    out = tmp_path / "out"
    first = _plan(tmp_path, {"tag": ["a"]})
    (out / "runs").mkdir(parents=True)
    store.atomic_write_json(out / "sweep.json", first.to_json())
    presence = store.SweepPresence(out)
    presence.hold()
    try:
        (tmp_path / "other").mkdir()
        other = _plan(tmp_path / "other", {"tag": ["x"]})
        with pytest.raises(InputError, match="different plan is running.*it is starting"):
            run_sweep(other, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    finally:
        presence.release()
    res = run_sweep(other, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert res.ok == ["tag=x"]
