"""``ramensim sweep --only AXIS=V[,V]``: run a subset of a sweep's points into its folder
(batches of a long protocol), the plan kept whole so the report counts what is left; a later
run without --only finishes the rest; bad axes and values are one-paragraph errors."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ramensim.core.errors import InputError
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep, select_points
from sweep_testfuncs import fake_run, validate_dict


def _plan(tmp_path: Path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump({"name": "exp", "base": "base.yaml", "set": {"duration": 30},
                                    "axes": {"seed": [0, 1], "channel.success_rate": [1.0, 0.2, 0.01],
                                             "method": ["ramen", "dinno"]}}, sort_keys=False))
    return plan_sweep(path, validate_fn=validate_dict)


def test_select_points_matches_values_as_written(tmp_path):
    plan = _plan(tmp_path)
    assert len(select_points(plan, None)) == 12
    chosen = select_points(plan, ["seed=0", "channel.success_rate=1.0,0.01"])
    assert chosen == {p.name for p in plan.points
                      if p.axes["seed"] == 0 and p.axes["channel.success_rate"] in (1.0, 0.01)}
    assert len(chosen) == 4
    assert select_points(plan, {"method": "dinno", "seed": [1]}) == {
        p.name for p in plan.points if p.axes["method"] == "dinno" and p.axes["seed"] == 1}


def test_select_points_matches_a_number_however_written(tmp_path):
    """``--only beta_l=1.0e-6`` names the axis value 1e-06 (YAML reads ``1.0e-6`` as a float and
    prints it ``1e-06``): the same number in another spelling is the same point."""
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen"}))
    path = tmp_path / "knob.yaml"
    path.write_text("name: knob\nbase: base.yaml\naxes:\n  consensus.ramen.beta_l: [1.0e-6, 1.0e-4]\n")
    plan = plan_sweep(path, validate_fn=validate_dict)
    want = {p.name for p in plan.points if p.axes["consensus.ramen.beta_l"] == 1e-6}
    assert len(want) == 1
    for spelling in ("1.0e-6", "1e-6", "0.000001", "1e-06"):
        assert select_points(plan, [f"consensus.ramen.beta_l={spelling}"]) == want
    with pytest.raises(InputError, match="1e-06, 0.0001"):
        select_points(plan, ["consensus.ramen.beta_l=1.0e-5"])


@pytest.mark.parametrize("only, words", [
    (["sede=0"], ["'sede'", "seed, channel.success_rate, method"]),
    (["channel.success_rate=0.5"], ["0.5", "1.0, 0.2, 0.01"]),
    (["seed"], ["AXIS=VALUE", "seed, channel.success_rate, method"]),
    (["seed="], ["AXIS=VALUE"]),
])
def test_bad_only_is_a_clear_error(tmp_path, only, words):
    plan = _plan(tmp_path)
    with pytest.raises(InputError) as err:
        select_points(plan, only)
    for w in words:
        assert w in str(err.value)


def test_only_runs_the_subset_and_the_rest_later(tmp_path):
    plan = _plan(tmp_path)
    out = tmp_path / "out"
    first = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False,
                      only=select_points(plan, ["seed=0", "method=ramen"]))
    assert sorted(first.ok) == sorted(p.name for p in plan.points
                                      if p.axes["seed"] == 0 and p.axes["method"] == "ramen")
    assert len(first.ok) == 3 and first.skipped == 0
    assert len(json.loads((out / "sweep.json").read_text())["points"]) == 12  # the whole plan
    rest = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert rest.skipped == 3 and len(rest.ok) == 9
    assert not set(rest.ok) & set(first.ok)


def test_cli_dry_run_marks_points_not_selected(tmp_path, capsys):
    from ramensim.cli import main

    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"duration": 1, "method": "local"}))
    sweep = tmp_path / "s.yaml"
    sweep.write_text(yaml.safe_dump({"name": "s", "base": "base.yaml", "axes": {"seed": [0, 1, 2]}}))
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--dry-run", "--only", "seed=1"]) == 0
    text = capsys.readouterr().out
    assert "1 to run" in text and text.count("not selected (--only)") == 2
    assert main(["sweep", str(sweep), "--dry-run", "--only", "seed=7"]) == 2
    assert "not a value of the axis 'seed'" in capsys.readouterr().err


def test_cli_dry_run_marks_points_another_sweep_is_running(tmp_path, capsys):
    from ramensim.cli import main
    from ramensim.sweep import store

    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"duration": 1, "method": "local"}))
    sweep = tmp_path / "s.yaml"
    sweep.write_text(yaml.safe_dump({"name": "s", "base": "base.yaml", "axes": {"seed": [0, 1, 2]}}))
    runs = tmp_path / "o" / "runs"
    claim = store.PointClaim(runs, "seed=1")
    assert claim.try_acquire()
    try:
        assert main(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--dry-run"]) == 0
    finally:
        claim.release()
    text = capsys.readouterr().out
    assert "2 to run" in text and text.count("running (another sweep)") == 1
