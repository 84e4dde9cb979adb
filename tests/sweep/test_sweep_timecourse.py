"""Completion over time and time to consensus from run timelines (``ramensim.sweep.timecourse``),
on a sweep folder written by hand with known curves."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from ramensim.sweep.report import make_report
from ramensim.sweep.timecourse import (RunCurve, condition_label, load_curves, matching_references, run_curve,
                                      time_to_consensus)

TIMES = [30.0, 60.0, 90.0, 120.0]
# team completion (%) per method at TIMES, and at the end (t = 120 from per_agent)
CURVES = {
    "centralised": [60.0, 70.0, 74.0, 76.0],
    "ramen": [50.0, 66.0, 70.0, 73.0],      # within 5 of centralised from t = 60 on
    "dinno": [50.0, 66.0, 64.0, 69.0],      # in at 60, out at 90 and 120: never
    "local": [45.0, 50.0, 52.0, 53.0],
}


def _metrics(method: str, offset: float, with_timeline: bool = True) -> dict:
    agents = 1 if method == "centralised" else 2
    timeline = []
    for t, v in zip(TIMES, CURVES[method]):
        for k in range(agents):  # agents at v - 1 and v + 1: team mean v
            dv = 0.0 if agents == 1 else (-1.0 if k == 0 else 1.0)
            timeline.append({"t": t, "agent": k, "completion_ratio_pct": v + offset + dv,
                             "completion_unseen_pct": v + offset - 10})
    final = CURVES[method][-1] + offset
    per_agent = {f"agent_{k}": {"completion_ratio_pct": final + (0.0 if agents == 1 else (-1.0 if k == 0 else 1.0)),
                                "completion_unseen_pct": final - 10, "artifacts_cm": 4.0, "holes_cm": 5.0,
                                "own_coverage_pct": 40.0} for k in range(agents)}
    return {"status": "ok", "method": method, "sim_time_s": 120.0, "wall_time_s": 10.0, "per_agent": per_agent,
            "consensus_error": 0.01, "consensus_error_weighted": 0.001,
            "timeline": timeline if with_timeline else [], "consensus_timeline": []}


def _sweep(root: Path, methods=("ramen", "dinno", "local", "centralised"), seeds=(0, 1), layouts=(0, 1),
           skip=(), no_timeline=()) -> Path:
    points = []
    for s in seeds:
        for lay in layouts:
            for m in methods:
                axes = {"seed": s, "world.scene.seed": lay, "method": m}
                name = f"seed={s}__world.scene.seed={lay}__method={m}"
                points.append({"name": name, "axes": axes, "fingerprint": "x"})
                if name in skip:
                    continue
                d = root / "runs" / name
                d.mkdir(parents=True)
                (d / "status.json").write_text(json.dumps({"status": "ok", "axes": axes, "fingerprint": "x"}))
                (d / "metrics.json").write_text(json.dumps(_metrics(m, 0.5 * s + lay, name not in no_timeline)))
    plan = {"name": "tc", "axes": {"seed": list(seeds), "world.scene.seed": list(layouts), "method": list(methods)},
            "points": points}
    (root / "sweep.json").write_text(json.dumps(plan))
    return root


def test_run_curve_takes_team_means_and_the_final_evaluation():
    c = run_curve("r", {"method": "ramen"}, _metrics("ramen", 0.0))
    assert c.times == TIMES and c.values["completion_ratio_pct"] == CURVES["ramen"]
    assert c.final["completion_ratio_pct"] == 73.0 and c.final["consensus_error_weighted"] == 0.001
    assert run_curve("r", {}, _metrics("ramen", 0.0, with_timeline=False)) is None


def test_time_to_consensus_is_the_first_time_it_stays_within_the_margin():
    ref = RunCurve("c", {}, TIMES, {"completion_ratio_pct": CURVES["centralised"]})
    run = RunCurve("r", {}, TIMES, {"completion_ratio_pct": CURVES["ramen"]})
    assert time_to_consensus(run, ref) == 60.0
    assert time_to_consensus(RunCurve("d", {}, TIMES, {"completion_ratio_pct": CURVES["dinno"]}), ref) is None
    assert time_to_consensus(run, ref, margin=2.0) is None
    assert time_to_consensus(run, ref, margin=20.0) == 30.0


def test_condition_labels_name_their_axes_and_end_with_the_method():
    axes = {"seed": 1, "agents.compute.jitter": 0.5, "channel.success_rate": 0.2, "method": "dsgt"}
    assert condition_label(axes, ["method", "agents.compute.jitter"]) == "compute.jitter=0.5, dsgt"
    assert condition_label(axes, ["channel.success_rate", "method"]) == "channel.success_rate=0.2, dsgt"
    assert condition_label(axes, ["method"]) == "dsgt"
    assert condition_label(axes, []) == "all"


def test_report_writes_completion_over_time_and_time_to_consensus(tmp_path):
    root = _sweep(tmp_path / "sw")
    rep = make_report(root, formats=["png"])
    assert (root / "plots" / "completion_over_time.png").stat().st_size > 10_000
    assert (root / "plots" / "consensus_weighted_timeline.png").exists() is False  # no probes in these runs
    with open(root / "time_to_consensus.csv", newline="") as f:
        rows = {r["condition"]: r for r in csv.DictReader(f)}
    assert set(rows) == {"ramen", "dinno"}  # local and centralised are the references
    assert rows["ramen"]["trials"] == "4" and rows["ramen"]["reached"] == "4"
    assert float(rows["ramen"]["t_consensus_mean_s"]) == 60.0
    assert rows["dinno"]["reached"] == "0" and rows["dinno"]["per_trial_s"] == "never never never never"
    assert float(rows["ramen"]["final_gap_to_centralised_pts"]) == pytest.approx(-3.0)
    with open(root / "runs_timeline.csv", newline="") as f:
        wide = list(csv.DictReader(f))
    assert len(wide) == 16
    r = next(w for w in wide if w["name"] == "seed=1__world.scene.seed=1__method=ramen")
    assert float(r["completion_ratio_pct@60"]) == 66.0 + 1.5 and float(r["final_completion_ratio_pct"]) == 74.5
    assert "16 of 16 planned runs done" in (root / "summary.md").read_text()
    assert rep.missing_timeline == []


def test_partly_finished_sweep_says_what_is_missing(tmp_path):
    root = _sweep(tmp_path / "sw", skip={"seed=1__world.scene.seed=1__method=dinno"},
                  no_timeline={"seed=0__world.scene.seed=0__method=local"})
    rep = make_report(root, formats=["png"])
    text = (root / "summary.md").read_text()
    assert "15 of 16 planned runs done" in text and "seed=1__world.scene.seed=1__method=dinno" in text
    assert rep.missing_timeline == ["seed=0__world.scene.seed=0__method=local"]
    assert (root / "plots" / "completion_over_time.png").exists()


def test_references_come_from_another_sweep(tmp_path):
    refs = _sweep(tmp_path / "table1", methods=("local", "centralised"))
    root = _sweep(tmp_path / "fig5", methods=("ramen",))
    make_report(root, formats=["png"], references=[refs])
    with open(root / "time_to_consensus.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["condition"] for r in rows] == ["ramen"] and rows[0]["reached"] == "4"
    assert not math.isnan(float(rows[0]["t_consensus_mean_s"]))


def test_references_drawn_are_those_of_the_sweeps_own_trials(tmp_path):
    """Fig. 5's first trial against Table I's four: the floor and ceiling beside it are those of
    seed 0, layout 0 alone (a reference averaged over trials the sweep has not run would not be
    the same houses)."""
    from ramensim.sweep.aggregate import load_runs

    refs_dir = _sweep(tmp_path / "table1", methods=("local", "centralised"))
    root = _sweep(tmp_path / "fig5", methods=("ramen",), seeds=(0,), layouts=(1,))
    refs, _ = load_curves(refs_dir, load_runs(refs_dir)[1])
    curves, _ = load_curves(root, load_runs(root)[1])
    drawn = matching_references(refs, curves)
    assert len(refs) == 8 and sorted(c.name for c in drawn) == [
        "seed=0__world.scene.seed=1__method=centralised", "seed=0__world.scene.seed=1__method=local"]
    assert matching_references(refs, []) == []


def test_report_html_is_self_contained(tmp_path):
    import base64
    import re

    root = _sweep(tmp_path / "sw", skip={"seed=1__world.scene.seed=1__method=dinno"})
    (root / "runs" / "seed=0__world.scene.seed=0__method=ramen" / "scenario.yaml").write_text("method: ramen\n")
    make_report(root, formats=["png"])
    page = (root / "report.html").read_text()
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert images and all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in images)
    assert "15 of 16 planned runs done" in page and "Time to consensus" in page
    assert "href='runs/seed=0__world.scene.seed=0__method=ramen/'" in page
    assert "method: ramen" in page  # the scenario of a condition
    assert 'src="http' not in page and "<script" not in page  # nothing fetched, nothing run


def test_report_html_linked_reads_figures_from_plots(tmp_path):
    """``html="linked"``: every figure the embedded page carries is referenced as plots/NAME.png,
    each such file exists, and the page is a small fraction of the embedded one."""
    import re

    root = _sweep(tmp_path / "sw")
    make_report(root, formats=["png"])
    embedded = (root / "report.html").read_text()
    make_report(root, formats=["png"], html="linked")
    page = (root / "report.html").read_text()
    srcs = re.findall(r'<img alt="[^"]*" src="([^"]+)"', page)
    assert len(srcs) == embedded.count('src="data:image/png;base64,') > 0
    assert all(s.startswith("plots/") and (root / s).is_file() for s in srcs)
    assert "data:image" not in page and len(page) * 10 < len(embedded)
    with pytest.raises(ValueError, match="html='inline'"):
        make_report(root, formats=["png"], html="inline")


@pytest.mark.skipif(__import__("shutil").which("chromium") is None,
                    reason="headless Chromium not installed (Debian's chromium; .ci/run installs it)")
def test_report_html_renders_in_headless_chromium(tmp_path):
    """The page as a browser shows it, offline: the screenshot holds the plots' colours."""
    import subprocess

    import numpy as np
    from PIL import Image

    root = _sweep(tmp_path / "sw")
    make_report(root, formats=["png"])
    shot = tmp_path / "shot.png"
    res = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                          "--disable-background-networking", "--disable-component-update", "--disable-sync",
                          f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1280,2600",
                          f"--screenshot={shot}", (root / "report.html").as_uri()],
                         capture_output=True, text=True, timeout=120)
    assert shot.is_file(), res.stderr[-2000:]
    img = np.asarray(Image.open(shot).convert("RGB")).reshape(-1, 3)
    # tab10 blue and orange of the method lines are on screen only if the embedded plots loaded (2600 px:
    # the figures come after the results table, the intervals over trials and the paired comparisons)
    blue = np.all(np.abs(img.astype(int) - (31, 119, 180)) < 12, axis=1).sum()
    orange = np.all(np.abs(img.astype(int) - (255, 127, 14)) < 12, axis=1).sum()
    assert blue > 200 and orange > 200
