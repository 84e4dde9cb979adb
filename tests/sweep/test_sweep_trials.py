"""A sweep's report with intervals over trials (issue 56, item 1): each point's 95 % interval of
the team mean (Student t over the trials' team means), "n/a (1 trial)" with one trial, the paired
comparison of the completion ratio against a reference (RAMEN on the method axis, else the first
value) with its interval and count, and the runs a report cannot count (missing, partial,
unreadable) or marks (another host) named, the rest reported, never a traceback."""
from __future__ import annotations

import csv
import io
import itertools
import json
import math
import shutil
from pathlib import Path

import pytest

from ramensim.sweep.report import make_report

REPO = Path(__file__).resolve().parents[2]
T975 = {1: 12.706204736174698, 2: 4.302652729911275, 3: 3.182446305284263}
"""Student t quantiles t_{df, 0.975} (tables), for the hand computations."""


def _hand_interval(xs: list[float]) -> tuple[float, float, float]:
    n = len(xs)
    mean = sum(xs) / n
    sd = math.sqrt(sum((x - mean) ** 2 for x in xs) / (n - 1))
    half = T975[n - 1] * sd / math.sqrt(n)
    return mean, mean - half, mean + half


def _team(method: str, rate: float, seed: int) -> float:
    """The team completion (%) of a run: RAMEN 70 + 2 r + s², DiNNO 66 + 5 r + s."""
    return 70.0 + 2.0 * rate + seed * seed if method == "ramen" else 66.0 + 5.0 * rate + seed


def _metrics(ax: dict, build: dict | None = None) -> dict:
    m, r, s = ax.get("method", "ramen"), ax.get("channel.success_rate", 1.0), ax.get("seed", 0)
    team = _team(m, r, s)
    per_agent = {f"agent_{k}": {"completion_ratio_pct": team + d, "artifacts_cm": 3.0 + s + d / 10,
                                "holes_cm": 4.0 + d / 10} for k, d in enumerate((-0.5, 0.5))}
    out = {"status": "ok", "method": m, "sim_time_s": 60.0, "per_agent": per_agent, "consensus_error": 0.01,
           "timeline": [{"t": 30.0, "agent": k, "completion_ratio_pct": team} for k in range(2)]}
    if build:
        out["build"] = build
    return out


def _sweep(root: Path, axes: dict, metrics_fn=_metrics) -> Path:
    keys = list(axes)
    points = []
    for combo in itertools.product(*(axes[k] for k in keys)):
        ax = dict(zip(keys, combo))
        name = "__".join(f"{k}={v}" for k, v in ax.items())
        points.append({"name": name, "axes": ax, "fingerprint": "x"})
        d = root / "runs" / name
        d.mkdir(parents=True)
        (d / "status.json").write_text(json.dumps({"status": "ok", "axes": ax, "fingerprint": "x"}))
        (d / "metrics.json").write_text(json.dumps(metrics_fn(ax)))
    (root / "sweep.json").write_text(json.dumps({"name": "trials", "axes": axes, "points": points}))
    return root


def _report(root: Path, capsys) -> tuple[str, str, str]:
    """``ramensim report ROOT`` through the CLI: (what it printed, summary.md, report.html)."""
    from ramensim import cli

    capsys.readouterr()
    assert cli.main(["report", str(root), "--formats", "png", "--html", "linked"]) == 0
    printed = capsys.readouterr().out
    return printed, (root / "summary.md").read_text(encoding="utf-8"), (root / "report.html").read_text(encoding="utf-8")


def test_each_point_gets_the_t_interval_of_its_team_mean_over_trials(tmp_path, capsys):
    root = _sweep(tmp_path / "sw", {"seed": [0, 1, 2], "method": ["ramen", "dinno"]})
    printed, md, page = _report(root, capsys)
    # RAMEN's team means over the three trials: 70 + 2 + s² = 72, 73, 76
    mean, lo, hi = _hand_interval([72.0, 73.0, 76.0])
    cell = f"{mean:.2f} [{lo:.2f}, {hi:.2f}]"
    assert cell == "73.67 [68.50, 78.84]"
    artifacts = _hand_interval([3.0, 4.0, 5.0])   # 3 + s, the robots' ±0.05 cancel
    row = f"| ramen | 3 | {cell} | {artifacts[0]:.2f} [{artifacts[1]:.2f}, {artifacts[2]:.2f}] | 4.00 [4.00, 4.00] |"
    assert row in md and row in printed                       # summary.md and the terminal
    assert "## 95 % interval over trials" in md and "Student t over the trials' team means" in md
    assert "a trial: run seed" in md
    assert f"<td>ramen</td><td>3</td><td>{cell}</td>" in page  # report.html
    # the existing table is kept as it was (mean ± std over agents and seeds), the intervals added after it
    assert md.index("| method | runs | failed |") < md.index("## 95 % interval over trials")
    rows = list(csv.DictReader(io.StringIO((root / "summary.csv").read_text())))
    ramen = next(r for r in rows if r["method"] == "ramen")
    assert float(ramen["completion_ratio_pct_ci95_lo"]) == pytest.approx(lo)
    assert float(ramen["completion_ratio_pct_ci95_hi"]) == pytest.approx(hi)
    assert ramen["completion_ratio_pct_trials"] == "3"
    assert list(rows[0])[:4] == ["method", "runs", "ok", "diverged"]   # the old columns first, in their order
    # the same runs give the same bytes
    before = {n: (root / n).read_bytes() for n in ("summary.md", "summary.csv", "report.html")}
    make_report(root, formats=("png",), html="linked")
    assert before == {n: (root / n).read_bytes() for n in ("summary.md", "summary.csv", "report.html")}


def test_one_trial_has_no_interval(tmp_path, capsys):
    root = _sweep(tmp_path / "one", {"seed": [0], "method": ["ramen", "dinno"]})
    printed, md, page = _report(root, capsys)
    assert "| ramen | 1 | 72.00, n/a (1 trial) |" in md and "72.00, n/a (1 trial)" in printed
    assert "<td>72.00, n/a (1 trial)</td>" in page
    assert "Paired comparisons" not in md        # one trial planned per condition: nothing to pair
    # two trials planned, one run failed: that point and its pair have one trial
    two = _sweep(tmp_path / "two", {"seed": [0, 1], "method": ["ramen", "dinno"]})
    status = two / "runs" / "seed=1__method=dinno" / "status.json"
    status.write_text(json.dumps({"status": "failed", "error": "killed", "axes": {"seed": 1, "method": "dinno"}}))
    _, md, _ = _report(two, capsys)
    assert "| dinno | 1 | 71.00, n/a (1 trial) |" in md
    assert "| dinno | 1 | -1.00, n/a (1 trial) |" in md      # 66 + 5 + 0 − (70 + 2 + 0)
    assert "- `seed=1__method=dinno`: status 'failed': killed; not counted" in md


def test_paired_comparisons_match_a_hand_computation(tmp_path, capsys):
    # planned out of order: DiNNO first, 20 % before 100 %; the references are RAMEN and 100 %
    root = _sweep(tmp_path / "sw", {"method": ["dinno", "ramen"], "channel.success_rate": [0.2, 1.0],
                                    "seed": [0, 1, 2]})
    printed, md, page = _report(root, capsys)
    assert "### Method against ramen" in md and "### Communication success rate against 1.0" in md
    for rate in (1.0, 0.2):  # DiNNO − RAMEN on each trial, at the same rate: −4 + 3 r + s − s²
        diffs = [_team("dinno", rate, s) - _team("ramen", rate, s) for s in (0, 1, 2)]
        assert diffs == pytest.approx([-4 + 3 * rate, -4 + 3 * rate, -6 + 3 * rate])
        mean, lo, hi = _hand_interval(diffs)
        row = f"| {rate} | dinno | 3 | {mean:+.2f} [{lo:+.2f}, {hi:+.2f}] |"
        assert row in md and row in printed, (row, md)
    assert "| 1.0 | dinno | 3 | -1.67 [-4.54, +1.20] |" in md
    # the rate against 100 %, per method: RAMEN loses 2 (1 − 0.2) = 1.6 points on every trial
    assert "| ramen | 0.2 | 3 | -1.60 [-1.60, -1.60] |" in md
    assert "| dinno | 0.2 | 3 | -4.00 [-4.00, -4.00] |" in md
    assert "<h3>Method against ramen</h3>" in page and "<td>100 %</td><td>dinno</td><td>3</td>" \
        "<td>-1.67 [-4.54, +1.20]</td>" in page
    assert "difference from ramen (points)" in md and "† (hosts differ)" not in md   # no host records


def test_the_first_value_is_the_reference_without_ramen(tmp_path, capsys):
    root = _sweep(tmp_path / "sw", {"method": ["local", "dinno"], "seed": [0, 1]},
                  lambda ax: _metrics({**ax, "method": "ramen" if ax["method"] == "local" else "dinno"}))
    _, md, _ = _report(root, capsys)
    assert "### Method against local" in md and "| dinno | 2 |" in md


def test_missing_partial_and_foreign_runs_are_named_and_the_rest_reported(tmp_path, capsys, caplog):
    """A copy of the archived Fig. 1 sweep with one run deleted, one failed, one without metrics.json,
    one unreadable, one lacking the completion ratio and one from another host: the report names
    each, reports the other runs and never raises."""
    root = tmp_path / "paper_fig1"
    shutil.copytree(REPO / "docs" / "results" / "paper" / "paper_fig1", root)
    runs = root / "runs"

    def edit(name: str, fname: str, change) -> None:
        path = runs / name / fname
        data = json.loads(path.read_text())
        change(data)
        path.write_text(json.dumps(data))

    host_a = {"cpu": "AMD EPYC", "simd": "avx512f", "device": "cpu", "host": "aaaa"}
    for run in runs.iterdir():
        edit(run.name, "metrics.json", lambda d: d.update(build=host_a))
    shutil.rmtree(runs / "seed=0__world.scene.seed=0__method=local")                           # missing
    edit("seed=0__world.scene.seed=1__method=ramen", "status.json", lambda d: d.update(status="failed",
                                                                                      error="killed"))
    (runs / "seed=1__world.scene.seed=0__method=dinno" / "metrics.json").unlink()               # partial
    (runs / "seed=1__world.scene.seed=1__method=centralised" / "metrics.json").write_text("{ torn")
    edit("seed=2__world.scene.seed=1__method=ramen", "metrics.json",
         lambda d: [a.pop("completion_ratio_pct") for a in d["per_agent"].values()])
    edit("seed=2__world.scene.seed=0__method=dinno", "metrics.json",
         lambda d: d.update(build={"cpu": "Some Other CPU", "simd": "avx2", "device": "cuda", "host": "bbbb"}))
    printed, md, page = _report(root, capsys)
    notes = md.split("## Runs not counted or marked", 1)[1]
    assert "not run yet: seed=0__world.scene.seed=0__method=local" in md
    for name, why in [("seed=0__world.scene.seed=1__method=ramen", "status 'failed': killed; not counted"),
                      ("seed=1__world.scene.seed=0__method=dinno", "metrics.json missing or unreadable"),
                      ("seed=1__world.scene.seed=1__method=centralised", "metrics.json missing or unreadable"),
                      ("seed=2__world.scene.seed=1__method=ramen", "no finite completion_ratio_pct in its metrics.json"),
                      ("seed=2__world.scene.seed=0__method=dinno", "Some Other CPU, avx2, cuda")]:
        line = next((ln for ln in notes.splitlines() if name in ln), "")
        assert why in line, (name, why, notes)
        assert name in page and name in printed
    assert "another host than the 19 runs on AMD EPYC, avx512f, cpu" in notes
    # the rest reported: RAMEN's completion over the 4 trials it has a number for, by hand
    def team(name: str) -> float:
        vals = [a["completion_ratio_pct"] for a in json.loads((runs / name / "metrics.json").read_text())
                ["per_agent"].values()]
        return sum(vals) / len(vals)
    ramen = {st: team(f"seed={st[0]}__world.scene.seed={st[1]}__method=ramen") for st in ((0, 0), (1, 0), (1, 1), (2, 0))}
    # the two layouts of a run seed meet one channel: one unit, averaged first (seed 1 has both)
    units = [ramen[(0, 0)], (ramen[(1, 0)] + ramen[(1, 1)]) / 2, ramen[(2, 0)]]
    mean, lo, hi = _hand_interval(units)
    assert f"| ramen | 5 (3 units) | {mean:.2f} [{lo:.2f}, {hi:.2f}] |" in md
    assert "the independent unit is the run seed" in md
    # DiNNO − RAMEN paired on the trials where both have a number: s0L0, s1L1, s2L0 (the † pair)
    pairs = [(0, 0), (1, 1), (2, 0)]
    diffs = [team(f"seed={s}__world.scene.seed={lay}__method=dinno") - team(f"seed={s}__world.scene.seed={lay}__method=ramen")
             for s, lay in pairs]
    mean, lo, hi = _hand_interval(diffs)
    assert f"| dinno | 3 | 1 | {mean:+.2f} [{lo:+.2f}, {hi:+.2f}] |" in md
    assert "Traceback" not in printed and "Traceback" not in caplog.text


def test_a_sweep_of_settings_blocks_is_reported(tmp_path, capsys):
    """An axis whose values are blocks of settings (dicts, as cause/paper_update_switches sweeps
    consensus): tables, intervals and figures, no traceback."""
    blocks = [{"preset": "paper"}, {"preset": "paper", "dual_step": 0.2}]
    root = _sweep(tmp_path / "sw", {"consensus": blocks, "seed": [0, 1]},
                  lambda ax: _metrics({"seed": ax["seed"], "method": "ramen" if ax["consensus"] == blocks[0] else "dinno"}))
    printed, md, _ = _report(root, capsys)
    assert "### Consensus against {'preset': 'paper'}" in md
    assert "| {'preset': 'paper', 'dual_step': 0.2} | 2 | -1.00 [-1.00, -1.00] |" in md
