"""``ramensim sensitivity`` (``ramensim.paper.sensitivity``): the four main claims per knob value,
judged with claims.md's rules and intervals on small archives whose verdicts are known (the real
sensitivity sweep files' plans, fake runs): an interval that straddles its threshold is
"inconclusive", a claim lacking a run is "not run", runs that failed, are unreadable or were made
from other settings are named and the rest judged, a trial whose runs ran on different hosts is
marked and its runs named; and docs/results/sensitivity.md kept current with the archives it is
made from; the command and the old tools/ script name bad input in one paragraph."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from ramensim.commands.sensitivity import main
from ramensim.paper import sensitivity
from ramensim.paper.sensitivity_page import cell, to_markdown

REPO = Path(__file__).resolve().parents[2]
SWEEPS = REPO / "scenarios" / "sweeps" / "sensitivity"
RATE = "channel.success_rate"
BUILD = {"cpu": "Test CPU", "simd": "avx2", "device": "cpu", "host": "h1"}


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    """The real sweep files' plans restricted to run seed 0 (the unit the fake archives below
    hold; the files plan more run seeds): each file copied with ``seed: [0]`` and its base made
    absolute."""
    folder = tmp_path_factory.mktemp("sweeps")
    for path in SWEEPS.glob("*.yaml"):
        text = path.read_text(encoding="utf-8").replace("base: ../../", f"base: {SWEEPS.parents[1].as_posix()}/")
        lines = [("  seed: [0]" if line.startswith("  seed: [") else line) for line in text.splitlines()]
        (folder / path.name).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return sensitivity.load_plans(folder)


@pytest.fixture()
def planned_once(monkeypatch, plans):
    monkeypatch.setattr(sensitivity, "load_plans", lambda folder: plans)   # planned once per module


def _archive(root: Path, plan, runs: dict[tuple, list[float]], build: dict | None = None) -> Path:
    """A sweep folder as tools/archive_sweep.py keeps it, for the points of ``plan`` given in ``runs``:
    (layout, ((axis, value), ...)) -> each robot's completion (%)."""
    folder = root / plan.name
    (folder / "runs").mkdir(parents=True, exist_ok=True)
    (folder / "sweep.json").write_text(json.dumps(plan.to_json()))
    for (layout, items), completion in runs.items():
        axes = dict(items)
        point = next(p for p in plan.points if p.axes["world.scene.seed"] == layout
                     and all(p.axes.get(k) == v for k, v in axes.items()))
        run = folder / "runs" / point.name
        run.mkdir()
        # a robot given as None diverged (in round 240 + its index), as the run marks it
        metrics = {"per_agent": {f"agent_{i}": {"completion_ratio_pct": c} if c is not None else
                                 {"completion_ratio_pct": None, "diverged": True, "diverged_round": 240 + i}
                                 for i, c in enumerate(completion)},
                   "build": dict(build or BUILD)}
        (run / "metrics.json").write_text(json.dumps(metrics))
        (run / "status.json").write_text(json.dumps({"name": point.name, "status": "ok", "axes": point.axes,
                                                     "fingerprint": point.fingerprint}))
    return folder


def _rates(layout: int, **by_rate: float) -> dict[tuple, list[float]]:
    """RAMEN's team at each success rate (``r50=73.0``: 50 %), three equal robots."""
    rate = {"r100": 1.0, "r50": 0.5, "r20": 0.2, "r1": 0.01}
    return {(layout, ((RATE, rate[k]),)): [v] * 3 for k, v in by_rate.items()}


def _methods(layout: int, **teams: float) -> dict[tuple, list[float]]:
    return {(layout, (("method", m),)): [v] * (1 if m == "centralised" else 3) for m, v in teams.items()}


def _row(rows, label: str):
    return next(r for r in rows if r.label.startswith(label))


def test_verdicts_per_knob_value(tmp_path, planned_once, plans):
    """The default row: the gap to centralised straddles -5 (-3 and -6: inconclusive), the lead over
    DiNNO lies below 0 on both trials (fails), the drop clears 5 (holds); the local run of one trial
    is missing, so at 1 % one trial is judged (no interval); dual_step 0.5 has its 50 % runs only."""
    _archive(tmp_path, plans["sensitivity_references"],
             {**_rates(0, r100=74.0, r50=73.0, r20=73.0, r1=60.0), **_rates(1, r100=72.0, r50=70.0, r20=70.9, r1=61.0)})
    _archive(tmp_path, plans["sensitivity_methods"],
             {**_methods(0, centralised=76.0, dinno=76.0, local=42.0), **_methods(1, centralised=76.0, dinno=73.1)})
    _archive(tmp_path, plans["sensitivity_dual_step"],
             {(lay, (("consensus.dual_step", 0.5), (RATE, 0.5))): [c] * 3
              for lay, c in ((0, 74.0), (1, 74.2))})
    rows, sweeps, trials, base = sensitivity.judge_all(tmp_path, SWEEPS)
    assert trials == [(0, 0), (0, 1)]
    assert base["consensus.dual_step"] == 0.2 and base["consensus.ramen.beta_l"] == pytest.approx(1e-7)
    default = _row(rows, "default")
    assert default.label == "default (dual_step 0.2, beta_l 1e-07, rho 0.0001)"
    gap, lead, drop, one = default.claims
    assert gap.samples == [(pytest.approx(-3.0),), (pytest.approx(-6.0),)]
    assert gap.verdict() == "inconclusive"
    assert lead.samples == [(pytest.approx(-3.0),), (pytest.approx(-3.1),)] and lead.trial_verdict() == "fails" \
        and lead.verdict() == "inconclusive"  # both layouts ran with seed 0: one unit, no interval
    assert drop.samples == [(pytest.approx(1.0),), (pytest.approx(1.1),)] and drop.trial_verdict() == "holds"
    assert one.n() == 1 and one.verdict() == "inconclusive"
    assert cell(default, 0).startswith("-4.50 (no interval: 2 trials in 1 unit; 1 of 2 trials ✓)") and cell(default, 0).endswith("**inconclusive**")
    assert cell(default, 3) == "+18.00 (one trial: no interval) **inconclusive** (1 of 2 trials)"
    half = _row(rows, "dual_step 0.5")
    # its RAMEN at 50 % against the default DiNNO and centralised of each trial
    assert half.claims[0].samples == [(pytest.approx(-2.0),), (pytest.approx(-1.8),)]
    assert half.claims[0].trial_verdict() == "holds" and half.claims[0].verdict() == "inconclusive"
    assert half.claims[1].samples == [(pytest.approx(-2.0),), (pytest.approx(1.1),)]
    assert cell(half, 2) == "not run (RAMEN at 100 %, RAMEN at 20 %)"
    assert cell(_row(rows, "beta_l 1e-05"), 0) == "not run (RAMEN at 50 %)"
    text = to_markdown(rows, sweeps, trials, base, tmp_path)
    assert "**Runs done: 15 of 82 planned.**" in text
    import re  # the plans are copies of the sweep files (run seed 0 only): their folder is a temporary one
    assert re.search(r"\| sensitivity_dual_step \| `[^`]*dual_step\.yaml` \| 2 of 24 \|", text)
    assert ("| default (dual_step 0.2, beta_l 1e-07, rho 0.0001) | At 1 %: every RAMEN robot above every local "
            "robot | seed 0, layout 0: ✓ 60.0 / 60.0 / 60.0 vs local 42.0 / 42.0 / 42.0 (≥ +18.0); "
            "seed 0, layout 1: local not run (sensitivity_methods/seed=0__world.scene.seed=1__method=local) |") in text


def test_a_knob_value_under_which_ramen_diverges_fails_its_claims(tmp_path, planned_once, plans):
    """dual_step 1: RAMEN at 50 % diverged on both trials (every robot on layout 0, one of three on
    layout 1, whose other two still have a completion): the Table I claims fail, not "not judged";
    at 20 % it diverged on layout 1 only: Fig. 5's drop fails though layout 0 clears it; at 1 % it
    did not diverge and is judged as usual. The default row is untouched."""
    _archive(tmp_path, plans["sensitivity_references"], {**_rates(0, r50=73.0), **_rates(1, r50=74.0)})
    _archive(tmp_path, plans["sensitivity_methods"],
             {**_methods(0, centralised=76.0, dinno=70.0, local=42.0), **_methods(1, centralised=77.0, dinno=71.0,
                                                                                  local=43.0)})
    step = (("consensus.dual_step", 1.0),)
    _archive(tmp_path, plans["sensitivity_dual_step"], {
        (0, step + ((RATE, 0.5),)): [None, None, None], (1, step + ((RATE, 0.5),)): [None, 60.0, 61.0],
        (0, step + ((RATE, 1.0),)): [72.0] * 3, (0, step + ((RATE, 0.2),)): [71.0] * 3,
        (1, step + ((RATE, 1.0),)): [73.0] * 3, (1, step + ((RATE, 0.2),)): [72.0, None, 72.0],
        (0, step + ((RATE, 0.01),)): [60.0] * 3, (1, step + ((RATE, 0.01),)): [61.0] * 3})
    rows, sweeps, trials, base = sensitivity.judge_all(tmp_path, SWEEPS)
    one = _row(rows, "dual_step 1")
    assert one.diverged[0] == {(0, 0): "RAMEN at 50 % diverged: 3 of 3 robots diverged, in rounds 240-242",
                               (0, 1): "RAMEN at 50 % diverged: 1 of 3 robots diverged, in round 240"}
    assert cell(one, 0) == cell(one, 1) == "**fails**: RAMEN diverged on 2 of 2 trials"
    assert one.claims[0].samples == []   # a diverged trial is no sample: the survivors' mean is not judged
    assert cell(one, 2) == "**fails**: RAMEN diverged on 1 of 2 trials; the other 1: +1.00"
    assert one.diverged[3] == {} and one.claims[3].n() == 2
    assert cell(one, 3).endswith("(no interval: 2 trials in 1 unit; 2 of 2 trials ✓) **inconclusive**")
    default = _row(rows, "default")
    assert default.diverged[0] == {} and default.claims[0].trial_verdict() == "holds"
    text = to_markdown(rows, sweeps, trials, base, tmp_path)
    assert ("| dual_step 1 | Fig. 5: RAMEN's drop from 100 to 20 % | seed 0, layout 0: ✓ 72.0 → 71.0 (drop +1.0); "
            "seed 0, layout 1: ✗ RAMEN at 20 % diverged: 1 of 3 robots diverged, in round 241 |") in text
    assert "| dual_step 1 | **fails**: RAMEN diverged on 2 of 2 trials |" in text


def test_maps_drifting_apart_are_marked_and_the_verdict_stands(tmp_path, planned_once, plans):
    """dual_step 0.5: RAMEN at 100 % ends 53 % (its maps drifting apart: consensus error from a
    trough of 0.05 to 1.0, 20x) and at 20 % 70 %: the drop "holds" by its rule, and the trial and
    the cell say that the 100 % run's maps drift apart; the steady 20 % run is not marked."""
    _archive(tmp_path, plans["sensitivity_references"], _rates(0, r50=73.0))
    step = (("consensus.dual_step", 0.5),)
    folder = _archive(tmp_path, plans["sensitivity_dual_step"], {(0, step + ((RATE, 1.0),)): [53.0] * 3,
                                                                 (0, step + ((RATE, 0.2),)): [70.0] * 3})
    grows = [{"t": 2.0, "consensus_error": 0.09}, {"t": 4.0, "consensus_error": 0.05},
             *({"t": float(t), "consensus_error": 1.0} for t in range(240, 302, 2))]
    steady = [{"t": 2.0, "consensus_error": 0.09}, {"t": 4.0, "consensus_error": 0.05},
              {"t": 300.0, "consensus_error": 0.06}]
    for run in (folder / "runs").iterdir():
        m = json.loads((run / "metrics.json").read_text())
        m.update(sim_time_s=300.0, consensus_timeline=grows if "success_rate=1.0" in run.name else steady)
        (run / "metrics.json").write_text(json.dumps(m))
    rows, sweeps, trials, base = sensitivity.judge_all(tmp_path, SWEEPS)
    half = _row(rows, "dual_step 0.5")
    drop = half.claims[2]
    assert drop.samples == [(pytest.approx(-17.0),)] and drop.judged[0][1] is True
    assert half.drifting[2] == {(0, 0): "RAMEN at 100 %: maps drift apart (consensus error 1 in the last minute, "
                                        "20x its trough 0.05 at 4 s)"}
    assert drop.judged[0][2].endswith("; § RAMEN at 100 %: maps drift apart (consensus error 1 in the last minute, "
                                      "20x its trough 0.05 at 4 s)")
    assert cell(half, 2).endswith("**inconclusive** (1 of 2 trials) § (maps drift apart on 1 of 1)")
    assert half.drifting[0] == {} and half.drifting[3] == {}


def test_the_rho_rows_pair_ramen_with_dinno_at_the_same_rho(tmp_path, planned_once, plans):
    _archive(tmp_path, plans["sensitivity_rho"],
             {(lay, (("consensus.ramen.rho", 2e-4), (RATE, 0.5))): [73.0] * 3 for lay in (0, 1)})
    _archive(tmp_path, plans["sensitivity_rho_dinno"],
             {(0, (("consensus.dinno.rho", 2e-4),)): [70.0] * 3, (1, (("consensus.dinno.rho", 5e-5),)): [60.0] * 3})
    _archive(tmp_path, plans["sensitivity_methods"], _methods(1, dinno=50.0))   # the default DiNNO: not used here
    rows, *_ = sensitivity.judge_all(tmp_path, SWEEPS)
    twice = _row(rows, "rho 0.0002")
    assert twice.label == "rho 0.0002 (2x)"
    assert twice.claims[1].samples == [(pytest.approx(3.0),)]
    assert twice.missing[1] == {(0, 1): "DiNNO not run (sensitivity_rho_dinno/seed=0__world.scene.seed=1__"
                                        "consensus.dinno.rho=0.0002)"}


def test_bad_runs_are_named_and_the_rest_judged(tmp_path, planned_once, plans, caplog):
    """A failed run, an unreadable metrics.json, a run made from other settings and one without a
    completion: each named under "Runs not judged", its cells "not judged"; the rest judged, exit 0."""
    refs = _archive(tmp_path, plans["sensitivity_references"],
                    {**_rates(0, r100=74.0, r50=73.0, r20=73.0, r1=60.0), **_rates(1, r100=72.0, r50=70.0, r20=71.0)})
    _archive(tmp_path, plans["sensitivity_methods"], {**_methods(0, centralised=76.0, local=42.0, dinno=70.0),
                                                     **_methods(1, centralised=76.0, local=42.0)})
    runs = refs / "runs"
    status = runs / "seed=0__world.scene.seed=0__channel.success_rate=1.0" / "status.json"
    status.write_text(json.dumps({**json.loads(status.read_text()), "status": "failed", "error": "killed"}))
    (runs / "seed=0__world.scene.seed=1__channel.success_rate=0.2" / "metrics.json").write_text("{ torn")
    status = runs / "seed=0__world.scene.seed=0__channel.success_rate=0.5" / "status.json"
    status.write_text(json.dumps({**json.loads(status.read_text()), "fingerprint": "other"}))
    metrics = tmp_path / "sensitivity_methods" / "runs" / "seed=0__world.scene.seed=0__method=local" / "metrics.json"
    metrics.write_text(json.dumps({"per_agent": {"agent_0": {"completion_ratio_pct": float("nan")}}, "build": BUILD}))
    out = tmp_path / "page.md"
    assert main(["--results", str(tmp_path), "--out", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    notes = text.split("## Runs not judged: ", 1)[1]
    assert notes.startswith("4\n")
    for name, why in [("sensitivity_references/seed=0__world.scene.seed=0__channel.success_rate=1.0",
                       "status 'failed' (killed)"),
                      ("sensitivity_references/seed=0__world.scene.seed=1__channel.success_rate=0.2",
                       "metrics.json missing or unreadable"),
                      ("sensitivity_references/seed=0__world.scene.seed=0__channel.success_rate=0.5",
                       "made from other settings"),
                      ("default (dual_step 0.2, beta_l 1e-07, rho 0.0001): At 1 %: every RAMEN robot above every "
                       "local robot, seed 0, layout 0", "no finite completion_ratio_pct")]:
        line = next((ln for ln in notes.splitlines() if name in ln), "")
        assert why in line, (name, why, notes)
    assert "sensitivity_references/seed=0__world.scene.seed=0__channel.success_rate=1.0" in caplog.text
    rows, *_ = sensitivity.judge_all(tmp_path, SWEEPS)
    default = _row(rows, "default")
    assert cell(default, 2) == "not judged (RAMEN at 100 %, RAMEN at 20 %)"   # one trial each side broken
    assert cell(default, 3) == "not judged (a number a rule needs, RAMEN at 1 %)"
    assert default.claims[0].samples == [(pytest.approx(-6.0),)]                  # layout 1 only: 70 vs 76
    assert "Traceback" not in caplog.text


def test_a_trial_of_runs_from_two_hosts_is_marked_and_its_runs_named(tmp_path, planned_once, plans):
    _archive(tmp_path, plans["sensitivity_references"], {**_rates(0, r100=74.0, r20=73.0), **_rates(1, r100=72.0)})
    _archive(tmp_path / "other", plans["sensitivity_references"], _rates(1, r20=71.0),
             build={"cpu": "Other CPU", "simd": "avx512f", "device": "cpu", "host": "h2"})
    for run in (tmp_path / "other" / "sensitivity_references" / "runs").iterdir():  # beside the others
        run.rename(tmp_path / "sensitivity_references" / "runs" / run.name)
    rows, sweeps, trials, base = sensitivity.judge_all(tmp_path, SWEEPS)
    drop = _row(rows, "default").claims[2]
    assert [label for label, _, _ in drop.judged] == ["seed 0, layout 0", "seed 0, layout 1†"]
    assert cell(_row(rows, "default"), 2).endswith("**inconclusive**†")
    text = to_markdown(rows, sweeps, trials, base, tmp_path)
    hosts = text.split("## Trials whose compared runs ran on different hosts (†): 1", 1)[1]
    assert "seed=0__world.scene.seed=1__channel.success_rate=0.2 (Other CPU, avx512f, cpu, host h2)" in hosts
    assert "seed=0__world.scene.seed=1__channel.success_rate=1.0 (Test CPU, avx2, cpu, host h1)" in hosts


def test_runs_not_archived_yet_are_read_with_runs(tmp_path, planned_once, plans):
    """--runs DIR reads DIR/<sweep name> beside the archives; a run in both is taken from the archive."""
    results, runs = tmp_path / "results", tmp_path / "runs"
    results.mkdir()
    _archive(results, plans["sensitivity_references"], _rates(0, r100=74.0, r20=73.0))
    _archive(runs, plans["sensitivity_references"], {**_rates(0, r100=10.0), **_rates(1, r100=72.0, r20=71.5)})
    out = tmp_path / "page.md"
    assert main(["--results", str(results), "--runs", str(runs), "--out", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    assert "**Runs done: 4 of 82 planned.**" in text
    assert "seed 0, layout 0: ✓ 74.0 → 73.0 (drop +1.0); seed 0, layout 1: ✓ 72.0 → 71.5 (drop +0.5)" in text
    assert f"--runs {runs.as_posix()}" in text


def test_nothing_judged_and_bad_folders(tmp_path, planned_once, caplog):
    out = tmp_path / "page.md"
    assert main(["--results", str(tmp_path), "--out", str(out)]) == 1     # no run: the page, exit 1
    assert "**Runs done: 0 of 82 planned.**" in out.read_text(encoding="utf-8")
    assert "nothing judged" in caplog.text
    assert main(["--results", str(tmp_path / "nope")]) == 2
    assert "is not a folder" in caplog.text and "nope" in caplog.text


def test_a_missing_sweep_file_is_one_clear_error(tmp_path, caplog):
    (tmp_path / "sweeps").mkdir()
    (tmp_path / "sweeps" / "references.yaml").write_text((SWEEPS / "references.yaml").read_text())
    assert main(["--results", str(tmp_path), "--sweeps", str(tmp_path / "sweeps")]) == 2
    assert "no sweep file named sensitivity_methods" in caplog.text


def test_sensitivity_page_is_current_with_the_archives(tmp_path):
    """docs/results/sensitivity.md is what the command makes of the archives committed under
    docs/results/sensitivity/: whoever archives a sensitivity sweep regenerates it (its command is
    on the page)."""
    out = tmp_path / "sensitivity.md"
    assert main(["--out", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == (REPO / "docs" / "results" / "sensitivity.md").read_text(
        encoding="utf-8"), "docs/results/sensitivity.md is stale: run ramensim sensitivity --out " \
                           "docs/results/sensitivity.md"


def test_the_command_and_the_tools_script_name_bad_input_in_one_paragraph(tmp_path, capsys):
    """``ramensim sensitivity`` (through the CLI: "error: ...", exit 2, no traceback) and the old
    command the pages printed, ``python tools/sensitivity_table.py``, which calls the same code."""
    import subprocess
    import sys

    from ramensim.cli import main as cli

    (tmp_path / "sweeps").mkdir()
    (tmp_path / "sweeps" / "references.yaml").write_text((SWEEPS / "references.yaml").read_text())
    assert cli(["sensitivity", "--results", str(tmp_path), "--sweeps", str(tmp_path / "sweeps")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --sweeps ") and "no sweep file named sensitivity_methods" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "sensitivity_table.py"), "--runs",
                           str(tmp_path / "nope")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "--runs" in proc.stderr and "nope is not a folder" in proc.stderr
    assert "Traceback" not in proc.stderr
