"""``ramensim report --style paper``: figures at a journal width as PDF and SVG, one colour per
method across figures, a success-rate axis that separates 5 % and 1 %, no "± 0" for one run, and
a mark wherever a robot diverged. Synthetic sweep folders of a few runs each (bounded by size)."""
from __future__ import annotations

import itertools
import json
import math
import re
from pathlib import Path

import pytest

from ramensim.evaluation.plots import (METHOD_COLOURS, PaperSeries, method_colour, paper_lines,
                                       percent_ticks)
from ramensim.sweep.report import make_report, sweep_description

RATES = [1.0, 0.2, 0.05, 0.01]


def _metrics(method: str, rate: float, seed: int, diverged: int | None = None) -> dict:
    """A run's metrics.json: two robots (robot ``diverged`` with NaN metrics), a timeline, the
    consensus error (one value per run) and its probes."""
    base = (74.0 if method == "ramen" else 70.0) - 10 * (1 - rate) + seed
    per_agent = {}
    for k in range(2):
        if k == diverged:
            per_agent[f"agent_{k}"] = {"completion_ratio_pct": None, "artifacts_cm": None, "holes_cm": None,
                                       "diverged": True, "diverged_round": 7, "diverged_reason": "non-finite loss",
                                       "failed_reason": None}
        else:
            per_agent[f"agent_{k}"] = {"completion_ratio_pct": base + k, "artifacts_cm": 3.5 + k / 10,
                                       "holes_cm": 4.2 + k / 10, "diverged": False, "failed_reason": None}
    timeline = [{"t": t, "agent": k, "completion_ratio_pct": base * t / 60 + k, "completion_unseen_pct": base - 5}
                for t in (30.0, 60.0) for k in range(2)]
    probes = [{"t": t, "consensus_error": 0.001 * (2 - rate) * (1 + seed)} for t in (1.0, 2.0, 3.0)]
    return {"status": "diverged" if diverged is not None else "ok", "method": method, "sim_time_s": 60.0,
            "wall_time_s": 10.0, "per_agent": per_agent, "consensus_error": 0.0152 * (2 - rate),
            "timeline": timeline, "consensus_timeline": probes,
            "diverged_agents": [f"agent_{diverged}"] if diverged is not None else []}


def _sweep(root: Path, axes: dict, metrics_fn, **plan) -> Path:
    keys = list(axes)
    points = []
    for combo in itertools.product(*(axes[k] for k in keys)):
        ax = dict(zip(keys, combo))
        name = "__".join(f"{k}={v}" for k, v in ax.items())
        points.append({"name": name, "axes": ax, "fingerprint": "x"})
        d = root / "runs" / name
        d.mkdir(parents=True)
        m = metrics_fn(ax)
        (d / "status.json").write_text(json.dumps({"status": m["status"], "axes": ax, "fingerprint": "x"}))
        (d / "metrics.json").write_text(json.dumps(m))
    (root / "sweep.json").write_text(json.dumps({"name": "fig5like", "axes": axes, "points": points,
                                                 "set": {"duration": 60}, **plan}))
    return root


def _fig5(root: Path, methods=("ramen", "dinno"), seeds=(0, 1), **plan) -> Path:
    """Fig. 5 in small: success rates 100 % to 1 %; agent_1 of dinno's run at 5 %, seed 1,
    diverged."""
    def fn(a):
        bad = 1 if (a["method"], a["channel.success_rate"], a["seed"]) == ("dinno", 0.05, 1) else None
        return _metrics(a["method"], a["channel.success_rate"], a["seed"], bad)
    return _sweep(root, {"seed": list(seeds), "channel.success_rate": RATES, "method": list(methods)}, fn, **plan)


def _svg_width_pt(path: Path) -> float:
    head = path.read_text(encoding="utf-8")[:2000]
    found = re.search(r'<svg[^>]*\swidth="([\d.]+)pt"', head)
    assert found, head[:400]
    return float(found[1])


def _pdf_mediabox(path: Path) -> tuple[float, float]:
    found = re.search(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", path.read_bytes())
    assert found
    return float(found[1]), float(found[2])


@pytest.mark.parametrize("width, inches", [("column", 3.5), ("page", 7.0)])
def test_paper_style_writes_pdf_and_svg_at_the_asked_width(tmp_path, width, inches):
    """Every figure as PDF, SVG and PNG; the SVG's width attribute and the PDF's MediaBox are the
    asked width (72 pt per inch), whatever the figure."""
    root = _fig5(tmp_path / "sw")
    rep = make_report(root, style="paper", width=width)
    stems = {p.stem for p in rep.figures}
    assert {"vs_channel.success_rate", "bars_method", "completion_over_time", "consensus_timeline"} <= stems
    for stem in stems:
        for ext in ("pdf", "svg", "png"):
            assert (root / "plots" / f"{stem}.{ext}").is_file(), (stem, ext)
        assert _svg_width_pt(root / "plots" / f"{stem}.svg") == pytest.approx(72 * inches)
        w, h = _pdf_mediabox(root / "plots" / f"{stem}.pdf")
        assert w == pytest.approx(72 * inches) and 0 < h < 72 * 10
    captions = (root / "plots" / "captions.md").read_text()
    assert all(f"## {stem}" in captions for stem in stems)
    first = {p.name: p.read_bytes() for p in (root / "plots").iterdir()}
    make_report(root, style="paper", width=width)  # redrawn: the same bytes (no dates in PDF, SVG, PNG)
    assert first == {p.name: p.read_bytes() for p in (root / "plots").iterdir()}


def test_captions_open_with_the_sweeps_description_not_its_name(tmp_path):
    """The plan's ``description`` opens every caption; without one, the sweep file's leading
    comment block (through sweep.json's ``source``); the figures carry no title."""
    root = _fig5(tmp_path / "sw", description="Fig. 5 in small: two methods,\n  four rates.")
    rep = make_report(root, style="paper")
    assert rep.captions and all(c.startswith("Fig. 5 in small: two methods, four rates. — ")
                                for c in rep.captions.values())
    page = (root / "report.html").read_text()
    assert "Fig. 5 in small: two methods, four rates." in page
    src = tmp_path / "file.yaml"
    src.write_text("# A comment block\n# of two lines.\nname: x\n# not this\n")
    assert sweep_description({"source": str(src), "name": "x"}) == "A comment block of two lines."
    assert sweep_description({"source": str(tmp_path / "gone.yaml"), "name": "x"}) == "x"


def _colours(svg: Path) -> set[str]:
    return {c.lower() for c in re.findall(r"(?:stroke|fill):\s*(#[0-9a-fA-F]{6})", svg.read_text())}


def test_one_colour_per_method_in_every_figure(tmp_path):
    """RAMEN is the same blue and DiNNO the same vermillion in the metrics figure, the bars and
    the completion over time, where the default style coloured by success rate; a method the
    fixed map does not know (a plugin's) gets one hash-based colour, the same in each figure and
    in each report."""
    root = _fig5(tmp_path / "sw", methods=("ramen", "dinno", "agemedian"))
    make_report(root, style="paper")
    plugin = method_colour("agemedian")
    assert plugin == method_colour("agemedian") and plugin not in METHOD_COLOURS.values()
    for stem in ("vs_channel.success_rate", "bars_method", "completion_over_time"):
        found = _colours(root / "plots" / f"{stem}.svg")
        for colour in (METHOD_COLOURS["ramen"], METHOD_COLOURS["dinno"], plugin):
            assert colour.lower() in found, (stem, colour)


def test_success_rates_from_1_to_100_percent_are_on_a_log_axis(tmp_path):
    """Values spanning more than a decade (1 % to 100 %) get a log x axis whose 1 % and 5 %
    ticks are labelled and lie apart; values within a decade stay on a linear axis."""
    xs = [100.0 * r for r in RATES]
    s = PaperSeries("ramen", METHOD_COLOURS["ramen"],
                    points={"completion_ratio_pct": [(x, 70.0, 65.0, 75.0) for x in xs]})
    fig = paper_lines([s], "channel.success_rate", ["completion_ratio_pct"], "column", x_values=xs)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    labels = {t.get_text(): t.get_position()[0] for t in ax.get_xticklabels() if t.get_text()}
    assert {"1 %", "5 %", "100 %"} <= set(labels)
    px = ax.transData.transform([(1.0, 70.0), (5.0, 70.0)])[:, 0]
    assert abs(px[1] - px[0]) > 0.15 * ax.bbox.width  # 5 % and 1 % far apart, not both at 0
    from matplotlib.figure import Figure

    lin = Figure().subplots()
    assert percent_ticks(lin, [20.0, 60.0, 100.0]) == "linear"
    assert percent_ticks(Figure().subplots(), [0.0, 1.0, 100.0]) == "symlog"
    root = _fig5(tmp_path / "sw")
    rep = make_report(root, style="paper")
    assert "log scale" in rep.captions["vs_channel.success_rate"]


def test_bands_are_95_percent_t_intervals_and_absent_with_one_trial(tmp_path):
    """The band at a point is the Student t interval of summary.md's interval table; with one
    trial no band is drawn."""
    from ramensim.evaluation.intervals import t_interval
    from ramensim.sweep.report import _PaperData
    from ramensim.sweep.aggregate import load_runs

    root = _fig5(tmp_path / "sw")
    plan, records = load_runs(root)
    data = _PaperData(root, records, plan["axes"], {})
    point = data.points[data.point_id({"channel.success_rate": 0.2, "method": "ramen"})]
    est, lo, hi, n = data.estimate(point, "completion_ratio_pct")
    want = t_interval([74.0 - 8 + 0.5, 74.0 - 8 + 1 + 0.5])
    assert n == 2 and (est, lo, hi) == pytest.approx((want.estimate, want.lo, want.hi))
    assert "95 % Student t" in make_report(root, style="paper").captions["vs_channel.success_rate"]
    one = _fig5(tmp_path / "one", seeds=(0,))
    rep = make_report(one, style="paper")
    assert "no band" in rep.captions["vs_channel.success_rate"]
    s = PaperSeries("ramen", "#000000", points={"completion_ratio_pct": [(x, 70.0, math.nan, math.nan)
                                                                         for x in (1.0, 100.0)]})
    fig = paper_lines([s], "channel.success_rate", ["completion_ratio_pct"], "column")
    assert not fig.axes[0].collections  # no fill_between without an interval


def test_no_plus_minus_zero_for_one_run_in_the_paper_tables(tmp_path):
    """With one trial a run-level number (the consensus error) rests on one value: the default
    tables print "± 0.0000", the paper style's summary.md and report.html the value alone."""
    root = _fig5(tmp_path / "sw", seeds=(0,))
    make_report(root)
    assert "± 0.0000" in (root / "summary.md").read_text()
    make_report(root, style="paper")
    for name in ("summary.md", "report.html"):
        text = (root / name).read_text()
        assert not re.search(r"± 0(\.0+)?(?![.\d])", text), name
        assert "n = 1" in text
    assert "0.0152" in (root / "summary.md").read_text()


def test_a_point_with_a_diverged_robot_is_marked(tmp_path):
    """DiNNO at 5 % lost agent_1 in one trial: the caption's footnote says how many of the point's
    robots and which (with its trial), the figure draws that point hollow with its letter, and
    the completion-over-time legend carries the letter."""
    root = _fig5(tmp_path / "sw")
    rep = make_report(root, style="paper")
    cap = rep.captions["vs_channel.success_rate"]
    assert "(a) dinno, communication success rate 5 %: 1 of 4 robots diverged (run seed 1: agent_1)" in cap
    assert "Hollow marker" in cap
    assert "1 of 4 robots diverged" in rep.captions["completion_over_time"]
    assert "Hatched bar" in rep.captions["bars_method"]
    assert "<td>1 of 4</td>" in (root / "report.html").read_text()  # the results table counts them too
    clean = PaperSeries("ramen", "#0072B2", points={"holes_cm": [(1.0, 4.0, 3.9, 4.1), (5.0, 4.2, 4.0, 4.4)]})
    marked = PaperSeries("dinno", "#D55E00", points={"holes_cm": [(1.0, 4.5, 4.4, 4.6), (5.0, 5.0, 4.8, 5.2)]},
                         marks={5.0: "a"})
    ax = paper_lines([clean, marked], "channel.success_rate", ["holes_cm"], "column").axes[0]
    hollow = [ln for ln in ax.lines if ln.get_markerfacecolor() in ("white", (1.0, 1.0, 1.0, 1.0))]
    assert len(hollow) == 1 and list(hollow[0].get_xdata()) == [5.0]
    assert [t.get_text() for t in ax.texts] == ["a"]


def test_a_point_where_every_robot_diverged_is_still_marked(tmp_path):
    """A point without any value left is not silently absent: an x at the panel's bottom."""
    s = PaperSeries("ramen", "#0072B2", points={"holes_cm": [(1.0, 4.0, 3.9, 4.1), (5.0, math.nan, math.nan,
                                                                                    math.nan)]},
                    marks={5.0: "a"})
    ax = paper_lines([s], "channel.success_rate", ["holes_cm"], "column").axes[0]
    assert any(ln.get_marker() == "x" and list(ln.get_xdata()) == [5.0] for ln in ax.lines)
    assert [t.get_text() for t in ax.texts] == ["a"]


def test_bad_style_or_width_is_one_paragraph_and_exit_2(tmp_path, capsys):
    from ramensim.cli import main

    root = _fig5(tmp_path / "sw", seeds=(0,))
    assert main(["report", str(root), "--style", "papr"]) == 2
    assert main(["report", str(root), "--style", "paper", "--width", "huge"]) == 2
    assert main(["report", str(root), "--width", "page"]) == 2
    err = capsys.readouterr().err
    assert "--style papr" in err and "--width huge" in err and "Traceback" not in err
    assert not (root / "plots").exists()
    with pytest.raises(ValueError):
        make_report(root, style="paper", width="huge")
