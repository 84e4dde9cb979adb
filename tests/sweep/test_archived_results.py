"""The archived sweeps under docs/results/ hold every run their tables list.

docs/RESULTS.md tells a user on a fresh machine to resume the paper-horizon protocol by copying
an archive's ``runs/`` into ``runs/sweeps/<sweep>/runs``: that works only if each run folder the
archive's ``runs.csv`` names is in the repository (CI runs this on a clean clone, so a folder
kept out by ``.gitignore`` fails here).
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import yaml

RESULTS = Path(__file__).resolve().parents[2] / "docs" / "results"
ARCHIVES = sorted(p.parent for p in RESULTS.rglob("runs.csv"))


def test_there_are_archives_to_check():
    assert len(ARCHIVES) >= 5, f"expected the paper and cause archives under {RESULTS}"


@pytest.mark.parametrize("archive", ARCHIVES, ids=[str(p.relative_to(RESULTS)) for p in ARCHIVES])
def test_every_run_an_archive_lists_is_in_the_repository(archive: Path):
    with open(archive / "runs.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert rows, f"{archive}/runs.csv lists no run"
    for row in rows:
        run = archive / "runs" / row["name"]
        for name in ("status.json", "metrics.json", "scenario.yaml"):
            assert (run / name).is_file(), f"{run / name} is missing: the archive cannot be resumed from"
        status = json.loads((run / "status.json").read_text(encoding="utf-8"))
        assert status["status"] == row["status"]
        metrics = json.loads((run / "metrics.json").read_text(encoding="utf-8"))
        scenario = yaml.safe_load((run / "scenario.yaml").read_text(encoding="utf-8"))
        periodic = (scenario.get("evaluation") or {}).get("every_s", 30.0) is not None
        if row["status"] == "ok" and periodic:  # a run made with evaluation.every_s: null has no curve
            assert metrics.get("timeline"), f"{run}/metrics.json has no timeline"
    done = {p.name for p in (archive / "runs").iterdir() if (p / "status.json").is_file()}
    assert done == {r["name"] for r in rows}, f"{archive}: run folders and runs.csv differ"
