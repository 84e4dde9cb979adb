"""``tools/paper_queue.sh``, the paper-horizon protocol as one resumable queue: every step it
would run is a valid sweep selection (the sweep file exists, each ``--only`` value is on its
axis: checked with ``ramensim sweep --dry-run``), the two lanes together run exactly the whole
queue, and they never share a sweep file (so never a sweep folder). ``RAMENSIM=echo`` makes
the script print its steps instead of running them."""
from __future__ import annotations

import os
import shlex
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "tools" / "paper_queue.sh"


def queue(lane: str) -> subprocess.CompletedProcess:
    """The script run for ``lane`` with its steps printed, not run."""
    return subprocess.run(["bash", str(SCRIPT), lane], cwd=REPO,
                          env={**os.environ, "RAMENSIM": "echo", "RESTORE": "echo restore"},
                          capture_output=True, text=True)


def steps(lane: str) -> list[list[str]]:
    """The sweep command lines (arguments after ``ramensim``) the queue runs in ``lane``."""
    r = queue(lane)
    assert r.returncode == 0, r.stderr
    return [shlex.split(line) for line in r.stdout.splitlines() if line.startswith("sweep ")]


def test_lanes_split_the_queue_without_sharing_a_sweep():
    a, b, whole = steps("a"), steps("b"), steps("all")
    assert a and b
    assert sorted(map(tuple, a + b)) == sorted(map(tuple, whole))
    assert not {s[1] for s in a} & {s[1] for s in b}


def test_the_archived_runs_are_restored_before_the_first_step():
    lines = [ln for ln in queue("a").stdout.splitlines() if not ln.startswith("===")]
    assert lines[0] == "restore" and lines[1].startswith("sweep ")


def test_a_failed_restore_stops_the_queue():
    r = subprocess.run(["bash", str(SCRIPT), "b"], cwd=REPO, env={**os.environ, "RAMENSIM": "echo", "RESTORE": "false"},
                       capture_output=True, text=True)
    assert r.returncode == 2 and "restoring the archived runs failed" in r.stderr
    assert "sweep " not in r.stdout


def test_unknown_lane_is_refused():
    r = queue("c")
    assert r.returncode == 2 and "expected a, b or all" in r.stderr


@pytest.mark.parametrize("cmd", steps("all"), ids=lambda c: " ".join(c[1:]).replace("scenarios/sweeps/", ""))
def test_every_step_is_a_valid_selection(cmd, tmp_path, monkeypatch):
    from ramensim.cli import main

    monkeypatch.chdir(REPO)
    assert cmd[0] == "sweep" and (REPO / cmd[1]).is_file()
    assert main([*cmd, "--dry-run", "--out", str(tmp_path / "sweep")]) == 0
