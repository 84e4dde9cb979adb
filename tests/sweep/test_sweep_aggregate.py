"""Aggregation numbers against hand-computed mean/std, tables, figures, and the report command."""
from __future__ import annotations

import argparse
import csv
import io
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

from ramensim.evaluation.tables import format_mean_std, mean_std, to_csv, to_markdown
from ramensim.commands import report as report_cmd
from ramensim.commands import sweep as sweep_cmd
from ramensim.sweep.aggregate import RunRecord, aggregate, run_values, summary_tables, table_metrics
from ramensim.sweep.report import make_report
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict


def test_mean_std_is_population_std_over_finite_values():
    m, s, n = mean_std([1.0, 2.0, 3.0, 4.0, math.nan])
    assert (m, n) == (2.5, 4) and s == pytest.approx(math.sqrt(1.25))
    assert math.isnan(mean_std([])[0]) and mean_std([math.nan])[2] == 0
    assert format_mean_std(2.5, 1.118034) == "2.50 ± 1.12"
    assert format_mean_std(math.nan, 1.0) == "–"


@pytest.mark.parametrize("mean, std, cell", [
    (0.01523, 4.15e-4, "0.0152 ± 0.0004"),      # a consensus error: 3 significant figures, std alike
    (0.00394, 1.57e-4, "0.00394 ± 0.00016"),
    (0.2, 4.24e-3, "0.20 ± 0.004"),             # a std that would round to 0.00 keeps one figure
    (1.0, 0.0, "1.00 ± 0.00"),
    (4.47e10, 1.77e7, "4.47e+10 ± 1.77e+07"),   # bytes
    (4.49e10, 0.0, "4.49e+10 ± 0"),
    (3, 1.0, "3 ± 1.00"),
    (0.5, None, "0.50"),
    (None, 1.0, "–"),
])
def test_mean_std_cells_keep_the_means_precision(mean, std, cell):
    assert format_mean_std(mean, std) == cell


@pytest.mark.parametrize("metrics, expected", [
    ({"agents": [{"id": 0, "artifacts_cm": 1.0}, {"id": 1, "artifacts_cm": 3.0}], "bytes": 10},
     {"artifacts_cm": [1.0, 3.0], "bytes": [10.0]}),
    ({"agents": {"0": {"metrics": {"holes_cm": 2.0}}, "1": {"metrics": {"holes_cm": 4.0}}}},
     {"holes_cm": [2.0, 4.0]}),
    ({"per_agent": [{"completion_ratio_pct": 50}], "mean": {"completion_ratio_pct": 50}},
     {"completion_ratio_pct": [50.0]}),
    ({"artifacts_cm": {"per_agent": [1, None], "mean": 1, "std": 0}, "holes_cm": {"mean": 2.5, "std": 1},
      "completion_ratio_pct": [90, 80], "diverged": [], "channel": {"bytes_sent": 5, "ok": True}},
     {"artifacts_cm": [1.0, math.nan], "holes_cm": [2.5], "completion_ratio_pct": [90.0, 80.0],
      "channel.bytes_sent": [5.0]}),
])
def test_run_values_reads_the_shapes_a_metrics_file_may_have(metrics, expected):
    got = run_values(metrics)
    assert got.keys() == expected.keys()
    for k, v in expected.items():
        assert [("nan" if math.isnan(x) else x) for x in got[k]] == [("nan" if math.isnan(x) else x) for x in v]


def test_aggregate_pools_agents_and_seeds_per_point_and_counts_failures():
    recs = [
        RunRecord("a0", {"method": "ramen", "seed": 0}, "ok", values={"holes_cm": [1.0, 2.0], "bytes": [10.0]}),
        RunRecord("a1", {"method": "ramen", "seed": 1}, "diverged", values={"holes_cm": [3.0, 6.0], "bytes": [30.0]}),
        RunRecord("a2", {"method": "ramen", "seed": 2}, "failed", error="boom"),
        RunRecord("b0", {"method": "dinno", "seed": 0}, "ok", values={"holes_cm": [5.0, math.nan]}),
    ]
    rows, names = aggregate(recs, {"method": ["ramen", "dinno"], "seed": [0, 1, 2]})
    assert names == ["holes_cm", "bytes"]
    assert [r["method"] for r in rows] == ["ramen", "dinno"] and "seed" not in rows[0]
    r = rows[0]
    assert (r["runs"], r["ok"], r["diverged"], r["failed"]) == (3, 1, 1, 1)
    assert r["holes_cm_mean"] == pytest.approx(3.0) and r["holes_cm_n"] == 4
    assert r["holes_cm_std"] == pytest.approx(math.sqrt((4 + 1 + 0 + 9) / 4))
    assert r["bytes_mean"] == pytest.approx(20.0) and r["bytes_std"] == pytest.approx(10.0)
    d = rows[1]
    assert d["holes_cm_mean"] == 5.0 and d["holes_cm_std"] == 0.0 and d["holes_cm_n"] == 1
    assert math.isnan(d["bytes_mean"]) and d["bytes_n"] == 0


def test_asking_for_a_metric_no_run_wrote_is_an_input_error():
    from ramensim.core.errors import InputError

    recs = [RunRecord("a0", {"method": "ramen", "seed": 0}, "ok", values={"holes_cm": [1.0]})]
    with pytest.raises(InputError, match=r"'bogus' is not among the metrics.*holes_cm"):
        aggregate(recs, {"method": ["ramen"], "seed": [0]}, ["holes_cm", "bogus"])
    rows, names = aggregate(recs, {"method": ["ramen"], "seed": [0]}, ["holes_cm"])
    assert names == ["holes_cm"] and rows[0]["holes_cm_mean"] == 1.0


def test_tables_render_csv_and_markdown():
    rows = [{"method": "ramen", "x": 0.5, "m": "1.00 ± 0.50", "n": 3, "z": math.nan}]
    text = to_csv(rows, ["method", "x", "n", "z"])
    assert text == "method,x,n,z\nramen,0.5,3,\n"
    md = to_markdown(rows, ["method", "m", "z"], headers={"m": "Holes (cm)"})
    assert md.splitlines() == ["| method | Holes (cm) | z |", "|---|---|---|", "| ramen | 1.00 ± 0.50 | – |"]


def test_the_far_part_column_follows_the_unseen_part_only_where_a_run_has_one():
    """A path graph's maps have a far part (docs/ALGORITHM.md section 5); a complete graph's
    record None for it, which pools to nothing, so the summary shows no empty column."""
    path = {"per_agent": [{"completion_ratio_pct": 70.0, "completion_unseen_pct": 68.0,
                           "completion_far_pct": 64.0},
                          {"completion_ratio_pct": 72.0, "completion_unseen_pct": 70.0,
                           "completion_far_pct": 66.0}]}
    complete = {"per_agent": [{"completion_ratio_pct": 74.0, "completion_unseen_pct": 75.0,
                               "completion_far_pct": None}]}
    recs = [RunRecord("p", {"method": "ramen"}, "ok", values=run_values(path))]
    rows, names = aggregate(recs, {"method": ["ramen"]})
    assert table_metrics(names) == ["completion_ratio_pct", "completion_unseen_pct", "completion_far_pct"]
    _, md = summary_tables(rows, ["method"], names)
    header = md.splitlines()[0]
    assert header.index("part only teammates saw") < header.index("far part")
    assert "| 65.00 ± 1.00 |" in md
    assert "completion_far_pct" not in run_values(complete)
    rows, names = aggregate([RunRecord("c", {"method": "ramen"}, "ok", values=run_values(complete))],
                            {"method": ["ramen"]})
    assert "far part" not in summary_tables(rows, ["method"], names)[1]


def _sweep(tmp_path: Path) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump({"name": "fig5", "base": "base.yaml", "axes": {
        "method": ["ramen", "dinno"], "channel.success_rate": [1.0, 0.5], "seed": [0, 1]}}, sort_keys=False))
    return path


def _csv_rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def test_sweep_report_numbers_tables_and_figures(tmp_path):
    plan = plan_sweep(_sweep(tmp_path), validate_fn=validate_dict)
    out = tmp_path / "out"
    run_sweep(plan, out, workers=2, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    rep = make_report(out)
    rows = _csv_rows(out / "summary.csv")
    assert [(r["method"], r["channel.success_rate"]) for r in rows] == [
        ("ramen", "1.0"), ("ramen", "0.5"), ("dinno", "1.0"), ("dinno", "0.5")]
    r = rows[1]  # ramen @ 0.5: completion = 45 + seed + agent -> [45, 46, 46, 47]
    assert float(r["completion_ratio_pct_mean"]) == pytest.approx(46.0)
    assert float(r["completion_ratio_pct_std"]) == pytest.approx(math.sqrt(0.5))
    assert r["completion_ratio_pct_n"] == "4" and r["runs"] == "2" and r["failed"] == "0"
    assert float(r["artifacts_cm_mean"]) == pytest.approx(2.0)      # 1 + agent + seed
    assert float(r["holes_cm_std"]) == pytest.approx(1.0)           # [2, 4, 2, 4]
    assert float(r["consensus_error_mean"]) == pytest.approx(0.25)  # one value per run: [0, 0.5]
    assert float(r["consensus_error_peak_mean"]) == pytest.approx(1.5)  # max over probes and final: [1, 2]
    d = rows[3]  # dinno @ 0.5: 35 + seed + agent -> [35, 36, 36, 37]
    assert float(d["completion_ratio_pct_mean"]) == pytest.approx(36.0)
    md = (out / "summary.md").read_text()
    assert "| ramen | 0.5 | 2 | 0 | 2.00 ± 0.71 | 3.00 ± 1.00 | 46.00 ± 0.71 | 0.25 ± 0.25 |" in md
    assert "Completion ratio (%)" in md
    assert len(_csv_rows(out / "runs.csv")) == 8
    names = sorted(p.name for p in rep.figures)
    assert names == ["bars_method.png", "bars_method.svg", "consensus_timeline.png", "consensus_timeline.svg",
                     "vs_channel.success_rate.png", "vs_channel.success_rate.svg"]
    svg = (out / "plots" / "consensus_timeline.svg").read_text()
    # one line per condition, named in words (fractions in percent), the legend's title naming the keys
    assert all(f"{r}, {m}" in svg for m in ("ramen", "dinno") for r in ("100 %", "50 %"))
    assert "Communication success rate, method" in svg and "success_rate=" not in svg
    for p in rep.figures:
        assert p.stat().st_size > 1000
    assert (out / "plots" / "vs_channel.success_rate.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ET.parse(out / "plots" / "bars_method.svg")  # well-formed SVG


def test_a_metric_the_trial_alone_sets_is_left_out_of_the_vs_axis_figure():
    """Own coverage depends on the camera paths, not the channel: one value per trial whatever
    the success rate, so its panel against the rate would be a flat line."""
    from ramensim.sweep.report import _varies_along

    def rec(name, rate, seed, status="ok", **values):
        return RunRecord(name, {"method": "ramen", "channel.success_rate": rate, "seed": seed}, status,
                         values=values)

    recs = [rec("a", 1.0, 0, own=[30.0, 40.0], comp=[70.0, 71.0]),
            rec("b", 0.2, 0, own=[30.0, 40.0], comp=[68.0, 69.0]),
            rec("c", 1.0, 1, own=[35.0, 45.0], comp=[72.0, 73.0]),
            rec("d", 0.2, 1, "failed", own=[99.0, 99.0])]  # a failed run's numbers are not read
    assert not _varies_along(recs, "own", "channel.success_rate")
    assert _varies_along(recs, "comp", "channel.success_rate")
    assert _varies_along(recs, "own", "seed")  # another trial, other paths
    # Partly run: seed 1 only at 1.0, seed 0 only at 0.2: no trial has two rates, nothing judged flat
    assert not _varies_along([recs[1], recs[2]], "own", "channel.success_rate")


def test_report_leaves_a_flat_panel_out_unless_asked_for(tmp_path):
    plan = plan_sweep(_sweep(tmp_path), validate_fn=validate_dict)
    out = tmp_path / "out"
    run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    make_report(out, formats=("svg",))
    svg = (out / "plots" / "vs_channel.success_rate.svg").read_text()
    # fake_run's artifacts (1 + agent + seed) and holes do not depend on the rate, completion does
    assert "Completion" in svg and "Artifacts" not in svg and "Holes" not in svg
    make_report(out, metrics=["artifacts_cm", "completion_ratio_pct"], formats=("svg",))
    assert "Artifacts" in (out / "plots" / "vs_channel.success_rate.svg").read_text()


def test_report_command_redraws_from_the_folder_alone(tmp_path):
    plan = plan_sweep(_sweep(tmp_path), validate_fn=validate_dict)
    out = tmp_path / "out"
    run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    make_report(out)
    before = (out / "summary.csv").read_text()
    svg_before = (out / "plots" / "bars_method.svg").read_bytes()
    (tmp_path / "sweep.yaml").unlink()
    (tmp_path / "base.yaml").unlink()
    for p in [out / "summary.csv", out / "summary.md", *(out / "plots").iterdir()]:
        p.unlink()
    parser = argparse.ArgumentParser()
    report_cmd.add_parser(parser.add_subparsers())
    args = parser.parse_args(["report", str(out)])
    assert args.func(args) == 0
    assert (out / "summary.csv").read_text() == before
    assert (out / "plots" / "bars_method.svg").read_bytes() == svg_before  # deterministic output
    assert (out / "plots" / "vs_channel.success_rate.png").is_file()


def test_report_of_a_folder_that_is_not_a_sweep_is_an_input_error(tmp_path):
    from ramensim.core.errors import InputError

    parser = argparse.ArgumentParser()
    report_cmd.add_parser(parser.add_subparsers())
    with pytest.raises(InputError, match="not a sweep folder"):
        args = parser.parse_args(["report", str(tmp_path)])
        args.func(args)


def test_sweep_command_dry_run_validates_and_runs_nothing(tmp_path, capsys):
    (tmp_path / "base.yaml").write_text("method: ramen\n")
    (tmp_path / "s.yaml").write_text("base: base.yaml\naxes: {method: [ramen, dinno], seed: [0, 1]}\n")
    parser = argparse.ArgumentParser()
    sweep_cmd.add_parser(parser.add_subparsers())
    out = tmp_path / "out"
    args = parser.parse_args(["sweep", str(tmp_path / "s.yaml"), "--out", str(out), "--dry-run"])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "4 points, 4 to run" in text and "method=dinno__seed=1" in text
    assert not out.exists()


def test_cli_sweep_and_report_through_ramensim_main(tmp_path, capsys):
    cli = pytest.importorskip("ramensim.cli")
    bad = tmp_path / "bad.yaml"
    bad.write_text("base: missing.yaml\naxes: {seed: [0]}\n")
    assert cli.main(["sweep", str(bad), "--dry-run"]) == 2
    assert "missing.yaml" in capsys.readouterr().err
    plan = plan_sweep(_sweep(tmp_path), validate_fn=validate_dict)
    out = tmp_path / "out"
    run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    capsys.readouterr()
    assert cli.main(["report", str(out), "--formats", "png"]) == 0
    assert (out / "plots" / "bars_method.png").is_file() and not (out / "plots" / "bars_method.svg").exists()
    printed = capsys.readouterr().out.splitlines()  # piped: the Markdown itself, each row one whole line
    md_rows = [line for line in (out / "summary.md").read_text().splitlines() if line.startswith("| ")]
    assert md_rows and all(row in printed for row in md_rows)
    assert cli.main(["report", str(tmp_path / "nope")]) == 2
