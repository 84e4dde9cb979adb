"""``tools/paper_queue.sh``, the paper-horizon protocol as one resumable queue: every step it
would run is a valid sweep selection (the sweep file exists, each ``--only`` value is on its
axis: checked with ``ramensim sweep --dry-run``), the two lanes together run exactly the whole
queue, and their own steps never share a sweep file (so never a sweep folder); after them each
lane goes over every whole file until none is left (joining the other lane's sweep of a file,
point by point), taking up on a later pass a file whose folder lock refused it. ``RAMENSIM=echo`` makes the script print its
steps instead of running them."""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "tools" / "paper_queue.sh"


def queue(lane: str) -> subprocess.CompletedProcess:
    """The script run for ``lane`` with its steps printed, not run."""
    return subprocess.run(["bash", str(SCRIPT), lane], cwd=REPO,
                          env={**os.environ, "RAMENSIM": "echo", "RESTORE": "echo restore", "PYTHON": "echo"},
                          capture_output=True, text=True)


def steps(lane: str, shared: bool = False) -> list[list[str]]:
    """The sweep command lines (arguments after ``ramensim``) the queue runs in ``lane``: its
    own steps, or (``shared``) those of the work-sharing passes after them."""
    r = queue(lane)
    assert r.returncode == 0, r.stderr
    out, in_shared = [], False
    for line in r.stdout.splitlines():
        if line.startswith("=== ") and not line.split()[-1].startswith("rc="):
            in_shared = line.endswith("(shared)")
        elif line.startswith("sweep ") and in_shared == shared:
            out.append(shlex.split(line))
    return out


def test_lanes_split_the_queue_without_sharing_a_sweep():
    a, b, whole = steps("a"), steps("b"), steps("all")
    assert a and b
    assert sorted(map(tuple, a + b)) == sorted(map(tuple, whole))
    assert not {s[1] for s in a} & {s[1] for s in b}


def test_each_lane_then_goes_over_every_whole_file_once_when_none_is_held():
    files = sorted(str(p.relative_to(REPO)) for p in (REPO / "scenarios/sweeps/paper").glob("*.yaml"))
    for lane in "ab":
        tail = steps(lane, shared=True)
        assert sorted(s[1] for s in tail) == files
        assert all("--only" not in s for s in tail)
    assert steps("a", shared=True)[0] != steps("b", shared=True)[0]  # they start on different files
    assert steps("all", shared=True) == []


def test_a_file_held_by_the_other_lane_is_taken_up_on_a_later_pass(tmp_path):
    """A fake ``ramensim`` refuses lane b's first call of the whole fig5 file (lane a's), as the
    sweep lock does while lane a runs it: lane b goes on with the other files, comes back for
    fig5 and stops when a pass had nothing refused."""
    fake = tmp_path / "ramensim"
    fake.write_text(f"""#!/bin/bash
echo "$@" >> {tmp_path}/calls
if [ "$3" = --no-report ] && [[ "$2" == *fig5.yaml ]]; then
  echo x >> {tmp_path}/whole_fig5
  if [ "$(wc -l < {tmp_path}/whole_fig5)" = 1 ]; then
    echo "error: runs/sweeps/paper_fig5: another sweep is running in this output folder (it holds x)"; exit 2
  fi
fi
echo "sweep x: 0 ok, 0 diverged, 0 failed, 6 already done -> runs/sweeps/x"
""")
    fake.chmod(0o755)
    assert not any(s[1].endswith("fig5.yaml") for s in steps("b"))  # not one of lane b's own steps
    r = subprocess.run(["bash", str(SCRIPT), "b"], cwd=REPO, capture_output=True, text=True, timeout=60,
                       env={**os.environ, "RAMENSIM": str(fake), "RESTORE": "", "SHARE_WAIT": "0",
                            "PYTHON": "echo"})
    assert r.returncode == 0, r.stderr
    calls = [c.split()[1] for c in (tmp_path / "calls").read_text().splitlines()]
    n_own = len(steps("b"))
    shared = calls[n_own:]
    n_files = len(list((REPO / "scenarios/sweeps/paper").glob("*.yaml")))
    assert len(shared) == 2 * n_files  # the pass with the refusal, then one with none
    assert sum(c.endswith("fig5.yaml") for c in shared) == 2


def test_the_authors_split_four_robot_runs_are_taken_over_by_the_round_count_file(tmp_path):
    """Lane a hands the authors' split's finished 4-robot RAMEN runs (status ok, metrics there) to
    tools/adopt_runs.py for fig7_authors_rounds.yaml before each of that file's steps; an
    unfinished run is not handed over, and lane b adopts nothing."""
    work = tmp_path / "repo"
    shutil.copytree(REPO / "tools", work / "tools")
    runs = work / "runs" / "sweeps" / "paper_fig7_authors_split" / "runs"
    for name, status in (("seed=0__world.scene.seed=0__agents.count=4__method=ramen", "ok"),
                         ("seed=0__world.scene.seed=1__agents.count=4__method=ramen", "running"),
                         ("seed=0__world.scene.seed=0__agents.count=6__method=ramen", "ok")):
        (runs / name).mkdir(parents=True)
        (runs / name / "metrics.json").write_text("{}")
        (runs / name / "status.json").write_text(f'{{"status": "{status}"}}')
    env = {**os.environ, "RAMENSIM": "echo", "RESTORE": "", "PYTHON": "echo"}
    a = subprocess.run(["bash", "tools/paper_queue.sh", "a"], cwd=work, env=env, capture_output=True, text=True)
    adopted = [ln for ln in a.stdout.splitlines() if ln.startswith("tools/adopt_runs.py")]
    assert adopted and all(ln.split()[1:3] == ["runs/sweeps/paper_fig7_authors_split/runs/"
                                               "seed=0__world.scene.seed=0__agents.count=4__method=ramen", "--plan"]
                           and ln.endswith("--into runs/sweeps/fig7_authors_rounds") for ln in adopted)
    b = subprocess.run(["bash", "tools/paper_queue.sh", "b"], cwd=work, env=env, capture_output=True, text=True)
    assert not [ln for ln in b.stdout.splitlines() if ln.startswith("tools/adopt_runs.py")]


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
