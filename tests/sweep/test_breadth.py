"""``ramensim breadth``: Table I's comparisons and Fig. 5's drop judged per scene family and
pooled over breadth sweeps, each layout its own unit, on synthetic archives whose numbers are
computed by hand; incomplete runs named, not raised on."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ramensim.cli import main
from ramensim.sweep.breadth import family_of, judge, load_trials, report

T_3 = 3.182446305284263   # t_{3, 0.975}
T_1 = 12.706204736174705  # t_{1, 0.975}


def _archive(root: Path, name: str, scene: dict, trials: dict[tuple[int, int], dict[str, float]],
             status: dict[str, str] | None = None, preset: str = "ramensim") -> Path:
    """A sweep folder: sweep.json and runs/<point>/{status,metrics}.json, scenario.yaml; ``trials``:
    (seed, layout) -> variant -> team completion (every robot the same); a variant ``NAME@paper``
    is ``NAME`` run with ``consensus.preset: paper`` in the same folder (an axis ``consensus.preset``)."""
    folder = root / name
    points = []
    both = any(v.endswith("@paper") for vs in trials.values() for v in vs)
    for (seed, layout), variants in trials.items():
        for variant, c in variants.items():
            run_preset = "paper" if variant.endswith("@paper") else preset
            variant = variant.removesuffix("@paper")
            axes = {"seed": seed, "world.scene.seed": layout, **({"consensus.preset": run_preset} if both else {}),
                    "variant": variant}
            pname = "__".join(f"{k}={v}" for k, v in axes.items())
            points.append({"name": pname, "axes": axes, "fingerprint": "x"})
            run = folder / "runs" / pname
            run.mkdir(parents=True)
            metrics = {"per_agent": {f"agent_{i}": {"completion_ratio_pct": c} for i in range(3)}}
            (run / "metrics.json").write_text(json.dumps(metrics))
            state = (status or {}).get(pname, "ok")
            (run / "status.json").write_text(json.dumps({"name": pname, "status": state, "axes": axes}))
            (run / "scenario.yaml").write_text(yaml.safe_dump({"seed": seed, "world": {"scene": {**scene, "seed": layout}},
                                                                       "consensus": {"preset": run_preset}}))
    (folder / "sweep.json").write_text(json.dumps({"name": name, "axes": {}, "points": points}))
    return folder


def _trial(ramen: float, dinno: float, local: float, central: float, r100: float, r20: float,
           d100: float, d20: float) -> dict[str, float]:
    return {"ramen": ramen, "dinno": dinno, "local": local, "centralised": central,
            "ramen_100": r100, "ramen_20": r20, "dinno_100": d100, "dinno_20": d20}


def test_each_family_and_the_pool_by_hand(tmp_path):
    house = _archive(tmp_path, "house", {"kind": "builtin", "name": "house"}, {
        (10, 10): _trial(72, 68, 44, 76, 73, 72, 70, 66),
        (11, 11): _trial(74, 69, 45, 77, 75, 74, 71, 67),
        (12, 12): _trial(73, 67, 46, 79, 74, 72, 70, 65),
        (13, 13): _trial(71, 68, 43, 75, 72, 71, 69, 66)})
    ware = _archive(tmp_path, "ware", {"kind": "builtin", "name": "warehouse"}, {
        (30, 0): _trial(60, 61, 50, 64, 61, 60, 62, 58),
        (31, 1): _trial(62, 60, 50, 66, 63, 61, 61, 59)})
    text, judged = report([house, ware])
    by = {(j.claim.name, j.scope): j for j in judged}
    lead = by[("Table I: DiNNO below RAMEN", "house")]
    d = [4.0, 5.0, 6.0, 3.0]                            # RAMEN − DiNNO per layout
    mean, s = 4.5, (sum((x - 4.5) ** 2 for x in d) / 3) ** 0.5
    (iv,) = lead.intervals()
    assert lead.n_units() == 4 and iv.estimate == pytest.approx(mean)
    assert (iv.lo, iv.hi) == pytest.approx((mean - T_3 * s / 2, mean + T_3 * s / 2))
    assert lead.verdict() == "holds"
    # the warehouse: +(-1) and +2 over 2 units: t with one degree of freedom straddles 0
    w = by[("Table I: DiNNO below RAMEN", "warehouse")]
    (iv,) = w.intervals()
    assert iv.estimate == pytest.approx(0.5) and iv.hi - iv.lo == pytest.approx(2 * T_1 * (4.5 ** 0.5) / 2 ** 0.5)
    assert w.verdict() == "inconclusive"
    pooled = by[("Table I: DiNNO below RAMEN", "all families pooled")]
    assert pooled.n_units() == 6 and pooled.intervals()[0].estimate == pytest.approx((18 + 1) / 6)
    # Fig. 5: drops 1, 1, 2, 1 for RAMEN, DiNNO's 4, 4, 5, 3: both rules hold
    drop = by[("Fig. 5: RAMEN loses ≤ 5 points from 100 to 20 %, less than DiNNO", "house")]
    assert [v for _, v in drop.trials] == [(1, 3), (1, 3), (2, 3), (1, 2)]
    assert drop.verdict() == "holds"
    central = by[("Table I: RAMEN within 5 points of centralised", "house")]
    assert [v[0] for _, v in central.trials] == [-4, -3, -6, -4] and central.verdict() == "inconclusive"
    assert "| Table I: DiNNO below RAMEN | house | 4 |" in text and "**holds**" in text
    assert "seed 12, layout 12: ✗ -6.00" in text


def test_incomplete_runs_are_named_and_their_trials_judged_on_what_they_have(tmp_path):
    folder = _archive(tmp_path, "house", {"kind": "builtin", "name": "house"}, {
        (10, 10): _trial(72, 68, 44, 76, 73, 72, 70, 66),
        (11, 11): {"ramen": 74.0, "dinno": 69.0, "local": 45.0}},
        status={"seed=10__world.scene.seed=10__variant=local": "failed"})
    notes: list[tuple[str, str]] = []
    trials = load_trials(folder, notes)
    assert notes == [("house/seed=10__world.scene.seed=10__variant=local", "status 'failed'")]
    by = {(j.claim.name, j.scope): j for j in judge(trials)}
    assert by[("Table I: RAMEN ≥ local + 15", "house")].n_units() == 1            # seed 10's local failed
    assert by[("Table I: DiNNO below RAMEN", "house")].n_units() == 2
    assert by[("Fig. 5: RAMEN loses ≤ 5 points from 100 to 20 %, less than DiNNO", "house")].n_units() == 1


def test_family_names_the_scene_and_a_noisy_sensor():
    assert family_of({"world": {"scene": {"name": "house"}}}) == "house"
    noisy = {"world": {"scene": {"name": "house"}, "camera": {"sensor": {"depth_noise_b": 0.0014}}}}
    assert family_of(noisy) == "house, noisy sensor"


def test_the_command_writes_the_page_and_refuses_a_missing_folder(tmp_path, capsys):
    folder = _archive(tmp_path, "house", {"kind": "builtin", "name": "house"},
                      {(10, 10): _trial(72, 68, 44, 76, 73, 72, 70, 66)})
    out = tmp_path / "page.md"
    assert main(["breadth", str(folder), "--out", str(out)]) == 0
    assert out.read_text(encoding="utf-8").startswith("# Beyond one house")
    assert main(["breadth", str(tmp_path / "nope")]) == 2
    assert "no such folder" in capsys.readouterr().err


def test_gain_over_local_against_own_coverage_by_hand(tmp_path):
    from ramensim.sweep.breadth import Trial, gain_vs_own_coverage

    t = Trial("house", 10, 10, robots={"ramen": [(70.0, 30.0), (60.0, 50.0), (65.0, 40.0)],
                                       "local": [(45.0, 30.0), (50.0, 50.0), (47.0, 40.0)]})
    lines = gain_vs_own_coverage([t])
    row = next(line for line in lines if line.startswith("| house |"))
    # own 30, 50, 40; gain 25, 10, 18: Sxy = -150, Sxx = 200, Syy = 112.67 -> r = -0.9993, b = -0.75, a = 47.67
    assert row == "| house | 3 | 30.0-50.0 | +10.00 to +25.00 | -1.00 | +47.67 -0.750 x own |"
    # archives without own coverage (older metrics.json): no section, nothing raised
    house = _archive(tmp_path, "house", {"kind": "builtin", "name": "house"}, {(10, 10): _trial(72, 68, 44, 76, 73, 72, 70, 66)})
    text, _ = report([house])
    assert "gain over a robot alone" not in text


def test_the_papers_update_beside_the_projects_by_hand(tmp_path):
    house = {"kind": "builtin", "name": "house"}
    project = _archive(tmp_path, "project", house, {
        (10, 10): _trial(72, 68, 44, 76, 73, 72, 70, 66),
        (11, 11): _trial(74, 69, 45, 77, 75, 74, 71, 67),
        (12, 12): _trial(73, 67, 46, 79, 74, 72, 70, 65)})
    # the paper's update on the same trials (RAMEN and DiNNO only): a different archive, same keys
    paper = _archive(tmp_path, "paper", house, {
        (10, 10): {"ramen": 60.0, "dinno": 58.0, "ramen_100": 70.0, "ramen_20": 55.0, "dinno_100": 66.0, "dinno_20": 50.0},
        (11, 11): {"ramen": 62.0, "dinno": 57.0, "ramen_100": 71.0, "ramen_20": 56.0, "dinno_100": 67.0, "dinno_20": 52.0},
        (12, 12): {"ramen": 61.0, "dinno": 59.0}}, preset="paper")
    text, judged = report([project, paper])
    by = {(j.claim.name, j.scope): j for j in judged}
    # the project's rows are unchanged by the paper's runs: RAMEN − DiNNO 4, 5, 6
    assert [v[0] for _, v in by[("Table I: DiNNO below RAMEN", "house")].trials] == [4, 5, 6]
    # judged again with the paper's update: RAMEN − DiNNO 2, 5, 2; RAMEN − local with the trial's own local
    lead = by[("Table I: DiNNO below RAMEN — the paper's update", "house")]
    assert [v[0] for _, v in lead.trials] == [2, 5, 2] and lead.n_units() == 3
    local = by[("Table I: RAMEN ≥ local + 15 — the paper's update", "house")]
    assert [v[0] for _, v in local.trials] == [16, 17, 15]
    drop = by[("Fig. 5: RAMEN loses ≤ 5 points from 100 to 20 %, less than DiNNO — the paper's update", "house")]
    # RAMEN drops 15 on both units (a zero-width interval above 5): fails, whatever DiNNO's +1 and 0 say
    assert [v for _, v in drop.trials] == [(15, 1), (15, 0)] and drop.verdict() == "fails"
    # beside the project's: RAMEN at 50 %: 60 - 72, 62 - 74, 61 - 73 = -12 each (no spread: a zero-width interval)
    row = next(line for line in text.splitlines() if line.startswith("| house | RAMEN, 50 % |"))
    assert row.startswith("| house | RAMEN, 50 % | 3 | 73.00 | 61.00 | -12.00 [-12.00, -12.00] |")
    assert "layout 10: -12.00; layout 11: -12.00; layout 12: -12.00" in row
    # DiNNO at 20 %: 50 - 66, 52 - 67 = -16, -15 over two units
    row = next(line for line in text.splitlines() if line.startswith("| house | DiNNO, 20 % |"))
    lo, hi = -15.5 - T_1 * 0.5, -15.5 + T_1 * 0.5
    assert f"-15.50 [{lo:+.2f}, {hi:+.2f}]" in row
    # rows in order: per method, 100 % first
    order = [line.split(" | ")[1] for line in text.splitlines() if line.startswith("| house | RAMEN,") or
             line.startswith("| house | DiNNO,")]
    assert order == ["DiNNO, 100 %", "DiNNO, 50 %", "DiNNO, 20 %", "RAMEN, 100 %", "RAMEN, 50 %", "RAMEN, 20 %"]
    # without runs of the paper's update: neither the section nor its claims
    text, judged = report([project])
    assert "paper's update as written beside" not in text
    assert not any("the paper's update" in j.claim.name for j in judged)


def test_both_updates_against_the_rate_drawn_over_the_same_trials(tmp_path):
    """One folder holding both updates (the rates sweep's axis consensus.preset) beside the 50 / 20 /
    100 % folders: the figure's rates are those some trial ran with both updates of both methods,
    its points the means over the trials that ran them all, and a trial missing one is left out."""
    house = {"kind": "builtin", "name": "house"}
    base = _archive(tmp_path, "project", house, {
        (10, 10): _trial(72, 68, 44, 76, 73, 72, 70, 66),
        (11, 11): _trial(74, 69, 45, 77, 75, 74, 71, 67),
        (12, 12): _trial(73, 67, 46, 79, 74, 72, 70, 65)})
    paper = _archive(tmp_path, "paper", house, {k: {"ramen_100": 60.0 + i, "ramen_20": 50.0 + i, "dinno_100": 40.0,
                                                      "dinno_20": 38.0 - i}
                                                  for i, k in enumerate([(10, 10), (11, 11), (12, 12)])}, preset="paper")
    rates = _archive(tmp_path, "rates", house, {
        (10, 10): {"ramen_80": 73.0, "ramen_80@paper": 58.0, "dinno_80": 69.0, "dinno_80@paper": 39.0},
        (11, 11): {"ramen_80": 75.0, "ramen_80@paper": 62.0, "dinno_80": 70.0, "dinno_80@paper": 41.0},
        (12, 12): {"ramen_80": 74.0, "dinno_80": 69.0, "dinno_80@paper": 40.0}})  # no RAMEN@paper at 80 %
    text, _ = report([base, paper, rates], figures=tmp_path / "fig", page_dir=tmp_path)
    # the paper-vs-project rows gain 80 % (two units: layouts 10 and 11)
    row = next(line for line in text.splitlines() if line.startswith("| house | RAMEN, 80 % |"))
    assert row.startswith("| house | RAMEN, 80 % | 2 | 74.00 | 60.00 | -14.00 [")
    from ramensim.sweep.breadth import load_trials, merge_trials
    from ramensim.sweep.breadth_figure import rate_figures

    trials = merge_trials([t for f in (base, paper, rates) for t in load_trials(f, [])])
    [fig] = rate_figures(trials, tmp_path / "fig2", formats=("png",))
    assert fig.rates == [100.0, 80.0, 20.0]  # 50 % has no paper's run of either method
    assert fig.drawn == [(10, 10), (11, 11)] and fig.left_out == [(12, 12)]
    assert [p.name for p in fig.files] == ["update_vs_rate_house.png"] and fig.files[0].stat().st_size > 0
    pts = fig.lines["RAMEN, paper's update"]
    assert [(r, m) for r, m, _, _ in pts] == [(100.0, 60.5), (80.0, 60.0), (20.0, 50.5)]
    r, m, lo, hi = pts[1]  # 58 and 62 over two units
    assert (lo, hi) == pytest.approx((60.0 - T_1 * 2.0, 60.0 + T_1 * 2.0))
    assert [m for _, m, _, _ in fig.lines["DiNNO, project's update"]] == [70.5, 69.5, 66.5]
    # local and centralised are drawn flat, over the same two trials
    assert {m for _, m, _, _ in fig.lines["local"]} == {44.5} and {m for _, m, _, _ in fig.lines["centralised"]} == {76.5}
    # the page shows the figure by a link relative to the page and names the trial left out
    assert "![Team completion against the success rate, house](fig/update_vs_rate_house.png)" in text
    assert "left out (not every point ran): (seed 12, layout 12)" in text
    # no figure without runs of the paper's update at two rates
    assert rate_figures(merge_trials(load_trials(base, [])), tmp_path / "none") == []
