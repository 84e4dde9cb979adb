"""Put the runs archived under docs/results/ back into the sweep folders, so that the protocol
resumes on a fresh machine from what is already done (the inverse of ``archive_sweep.py``).

    python tools/restore_archives.py                    # docs/results -> runs/sweeps
    python tools/restore_archives.py ARCHIVES SWEEPS

For every archive ``ARCHIVES/<group>/<archive>/`` with a ``sweep.json`` (its plan names the
sweep, e.g. ``paper_fig5``), each finished run in its ``runs/`` that ``SWEEPS/<name>/runs/``
does not hold yet is copied there (status.json, metrics.json, scenario.yaml: what
``ramensim sweep`` needs to count the point done when its resolved scenario is unchanged). A
run already in the sweep folder is never touched, so this is safe to repeat and to run from two
queues at once: each copy is made under a temporary name and renamed into place.
``tools/paper_queue.sh`` runs it before its first step.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import sys
import tempfile
from pathlib import Path

log = logging.getLogger("restore_archives")


def restore(archives: Path, sweeps: Path) -> dict[str, int]:
    """Copy the archived runs missing from the sweep folders; returns runs restored per sweep."""
    from ramensim.sweep import store

    done: dict[str, int] = {}
    for plan_file in sorted(archives.glob(f"*/*/{store.PLAN}")):
        archive = plan_file.parent
        try:
            name = json.loads(plan_file.read_text(encoding="utf-8"))["name"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise SystemExit(f"error: {plan_file}: not a sweep plan with a 'name' ({exc}); expected the sweep.json "
                             f"that tools/archive_sweep.py keeps.") from None
        runs = archive / store.RUNS
        if not runs.is_dir():
            continue
        target = sweeps / str(name) / store.RUNS
        n = 0
        for point in sorted(p for p in runs.iterdir() if p.is_dir() and store.is_complete(p)):
            if (target / point.name).exists():
                continue
            target.mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=f".restore-{point.name}-", dir=target))
            for f in point.iterdir():
                if f.is_file():
                    shutil.copy2(f, tmp / f.name)
            try:
                os.rename(tmp, target / point.name)  # atomic; fails if another queue put it there first
                n += 1
            except OSError:
                shutil.rmtree(tmp, ignore_errors=True)
        if n:
            done[str(name)] = n
    return done


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("archives", nargs="?", type=Path, default=Path("docs/results"),
                    help="the folder of archive groups (default: docs/results)")
    ap.add_argument("sweeps", nargs="?", type=Path, default=Path("runs/sweeps"),
                    help="where 'ramensim sweep' keeps its folders (default: runs/sweeps)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if not args.archives.is_dir():
        log.error("restore_archives: %s is not a folder; expected the archives' folder, e.g. docs/results.",
                  args.archives)
        return 2
    done = restore(args.archives, args.sweeps)
    log.info("restored %d archived run(s) into %s%s", sum(done.values()), args.sweeps,
             "".join(f"; {k}: {v}" for k, v in sorted(done.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
