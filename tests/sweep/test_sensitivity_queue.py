"""``tools/sensitivity_queue.sh``, the sensitivity rows' second run seed as one resumable queue:
every step is a valid selection of its sweep file (``ramensim sweep --dry-run`` accepts it),
layout 0 of every file comes before any of layout 1, every file is archived into the folder the
sensitivity page reads after its sweep, and together the steps cover exactly the planned points
of run seed 1. ``RAMENSIM=echo`` makes the script print its steps instead of running them."""
from __future__ import annotations

import os
import shlex
import subprocess
from pathlib import Path

from ramensim.sweep.spec import plan_sweep, select_points

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "tools" / "sensitivity_queue.sh"


def commands() -> list[list[str]]:
    r = subprocess.run(["bash", str(SCRIPT)], cwd=REPO, capture_output=True, text=True,
                       env={**os.environ, "RAMENSIM": "echo", "RESTORE": "echo restore"})
    assert r.returncode == 0, r.stderr
    return [shlex.split(line) for line in r.stdout.splitlines() if line.startswith(("sweep ", "archive "))]


def test_queue_covers_run_seed_one_layout_zero_first_and_archives_each_file():
    cmds = commands()
    sweeps = [c for c in cmds if c[0] == "sweep"]
    first_layout_one = next(i for i, c in enumerate(sweeps) if "world.scene.seed=1" in c)
    assert first_layout_one > 0 and all("world.scene.seed=0" in c for c in sweeps[:first_layout_one])
    assert all("world.scene.seed=1" in c for c in sweeps[first_layout_one:])
    files = sorted(str(p.relative_to(REPO)) for p in (REPO / "scenarios/sweeps/sensitivity").glob("*.yaml"))
    assert sorted({c[1] for c in sweeps}) == files
    covered: set[tuple[str, str]] = set()
    for c in sweeps:
        plan = plan_sweep(REPO / c[1])
        only = [c[i + 1] for i, a in enumerate(c) if a == "--only"]
        chosen = select_points(plan, only)
        assert chosen, c
        covered |= {(c[1], n) for n in chosen}
        out = Path(c[c.index("--out") + 1])
        assert out.name == plan.name
        archive = cmds[cmds.index(c) + 1]
        assert archive[0] == "archive" and archive[1:] == [str(out), f"docs/results/sensitivity/{plan.name}"]
    wanted = {(f, n) for f in files for n in select_points(plan_sweep(REPO / f), ["seed=1"])}
    assert covered == wanted
