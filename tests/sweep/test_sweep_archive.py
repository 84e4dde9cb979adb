"""``ramensim archive SWEEP DEST --plan FILE`` (``ramensim.sweep.archive``): the finished points of a
sweep made in batches kept with the whole experiment's plan (--plan), so the archive's report counts
every planned run; a batch whose points are not the plan's (another scenario) is refused."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import yaml

from ramensim.commands.archive import main as archive_main
from ramensim.core.errors import InputError
from ramensim.sweep import archive as archive_sweep
from ramensim.sweep.report import make_report
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep, select_points
from sweep_testfuncs import fake_run, validate_dict


def _write(tmp_path: Path, name: str, seeds: list[int], fixed: dict | None = None) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / name
    path.write_text(yaml.safe_dump({"name": "exp", "base": "base.yaml", "set": fixed or {"duration": 30},
                                    "axes": {"seed": seeds, "method": ["ramen", "dinno"]}}, sort_keys=False))
    return path


def test_archive_keeps_the_whole_plan(tmp_path):
    batch, full = _write(tmp_path, "batch.yaml", [0]), _write(tmp_path, "full.yaml", [0, 1, 2])
    out, dest = tmp_path / "out", tmp_path / "kept"
    run_sweep(plan_sweep(batch, validate_fn=validate_dict), out, workers=1, run_fn=fake_run,
              validate_fn=validate_dict, progress=False)
    assert archive_sweep.archive(out, dest) == 2
    assert len(json.loads((dest / "sweep.json").read_text())["points"]) == 2  # the batch's plan
    assert archive_sweep.keep_plan(full, dest) == 6
    kept = json.loads((dest / "sweep.json").read_text())
    assert len(kept["points"]) == 6 and kept["axes"]["seed"] == [0, 1, 2]
    other = _write(tmp_path, "other.yaml", [0, 1], fixed={"duration": 45})  # another scenario
    with pytest.raises(InputError, match="no result of the scenario"):
        archive_sweep.keep_plan(other, dest)
    assert json.loads((dest / "sweep.json").read_text()) == kept  # nothing written


def test_archive_redraws_a_report_that_misses_archived_runs(tmp_path):
    """A second batch run without a report (``--no-report``) into its own folder: archiving it
    beside the first batch leaves the archive's runs.csv listing every finished run it holds."""
    full = _write(tmp_path, "full.yaml", [0, 1])
    first, second, dest = tmp_path / "first", tmp_path / "second", tmp_path / "kept"
    plan = plan_sweep(full, validate_fn=validate_dict)
    for out, seed in ((first, 0), (second, 1)):
        run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False,
                  only=select_points(plan, {"seed": seed}))
    make_report(first, formats=("png",))
    assert archive_main([str(first), str(dest)]) == 0
    assert archive_sweep.report_is_current(dest)
    before = {r["name"] for r in csv.DictReader((dest / "runs.csv").open())}
    assert len(before) == 2
    assert archive_main([str(second), str(dest)]) == 0  # the second folder has no report of its own
    after = {r["name"] for r in csv.DictReader((dest / "runs.csv").open())}
    assert len(after) == 4 and before < after
    assert archive_sweep.report_is_current(dest)
    assert {p.suffix for p in (dest / "plots").iterdir()} == {".png"}  # the formats it had
    (dest / "runs.csv").write_text("name\n")
    assert not archive_sweep.report_is_current(dest)


def test_archive_redraws_with_the_options_the_report_was_drawn_with(tmp_path, monkeypatch, caplog):
    """A report drawn with a reference sweep (``--references``) and linked figures is redrawn with
    them when a later batch makes the archive's report stale (the reference resolved from the
    archive's place, relative as it was to the sweep folder); a reference gone is named and left out."""
    import ramensim.sweep.report as report_mod

    full = _write(tmp_path, "full.yaml", [0, 1])
    plan = plan_sweep(full, validate_fn=validate_dict)
    first, second, dest, refs = tmp_path / "first", tmp_path / "second", tmp_path / "kept", tmp_path / "refs"
    for out, seed in ((first, 0), (second, 1), (refs, 0)):
        run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False,
                  only=select_points(plan, {"seed": seed}))
    make_report(first, formats=("png",), references=[refs], html="linked")
    assert json.loads((first / "report.json").read_text())["references"] == ["../refs"]
    assert archive_main([str(first), str(dest)]) == 0
    assert (dest / "report.json").is_file()
    calls = []
    real = report_mod.make_report
    monkeypatch.setattr(report_mod, "make_report", lambda d, **kw: calls.append(kw) or real(d, **kw))
    assert archive_main([str(second), str(dest)]) == 0  # stale: redrawn with the report's own options
    [kw] = calls
    assert [Path(r).resolve() for r in kw["references"]] == [refs.resolve()]
    assert kw["html"] == "linked" and list(kw["formats"]) == ["png"]
    assert json.loads((dest / "report.json").read_text())["references"] == ["../refs"]
    # the reference gone: redrawn without it, and said so
    refs.rename(tmp_path / "refs_moved")
    (dest / "runs.csv").write_text("name\n")
    caplog.set_level("WARNING")
    archive_sweep.redraw_report(dest)
    assert calls[-1]["references"] == [] and "../refs, which is not there" in caplog.text
