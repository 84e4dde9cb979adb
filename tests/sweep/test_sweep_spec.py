"""Sweep files: expansion, names, and one-paragraph errors naming the file and key."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from ramensim.core.errors import InputError
from ramensim.sweep.spec import expand, load_spec, plan_sweep, point_name
from sweep_testfuncs import validate_dict


def _write(tmp_path: Path, sweep: dict | str, base: dict | None = None) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(base if base is not None else {"seed": 0}))
    path = tmp_path / "sweep.yaml"
    path.write_text(sweep if isinstance(sweep, str) else yaml.safe_dump(sweep, sort_keys=False))
    return path


def test_expand_is_cartesian_product_first_axis_slowest():
    pts = expand({"method": ["ramen", "dinno"], "channel.success_rate": [1.0, 0.5, 0.2], "seed": [0, 1]})
    assert len(pts) == 12
    assert pts[0] == {"method": "ramen", "channel.success_rate": 1.0, "seed": 0}
    assert pts[1] == {"method": "ramen", "channel.success_rate": 1.0, "seed": 1}
    assert pts[-1] == {"method": "dinno", "channel.success_rate": 0.2, "seed": 1}
    assert expand({}) == [{}]


def test_point_names_are_readable_and_stable():
    assert point_name({"method": "ramen", "channel.success_rate": 0.5, "seed": 0}) == \
        "method=ramen__channel.success_rate=0.5__seed=0"
    assert point_name({"x": 1.0, "flag": True, "none": None}) == "x=1.0__flag=true__none=null"
    assert point_name({"topology.edges": [[0, 1], [1, 2]]}) == "topology.edges=0-1-1-2"
    assert point_name({}) == "base"
    long = point_name({"k": "a" * 400})
    assert len(long) <= 180 and long == point_name({"k": "a" * 400})
    assert long != point_name({"k": "a" * 399 + "b"})


def test_plan_resolves_base_relative_to_sweep_file_and_applies_set_then_axes(tmp_path):
    sub = tmp_path / "sweeps"
    sub.mkdir()
    (tmp_path / "base.yaml").write_text("seed: 7\nchannel: {success_rate: 1.0, latency_s: 0.1}\n")
    (sub / "s.yaml").write_text("base: ../base.yaml\nset: {duration: 5}\n"
                                "axes: {channel.success_rate: [0.8, 0.4], seed: [1, 2]}\n")
    plan = plan_sweep(sub / "s.yaml", validate_fn=validate_dict)
    assert plan.name == "s" and plan.base == (tmp_path / "base.yaml").resolve()
    assert [p.name for p in plan.points] == [
        "channel.success_rate=0.8__seed=1", "channel.success_rate=0.8__seed=2",
        "channel.success_rate=0.4__seed=1", "channel.success_rate=0.4__seed=2"]
    d = plan.points[2].data
    assert d == {"seed": 1, "duration": 5, "channel": {"success_rate": 0.4, "latency_s": 0.1}}
    assert len({p.fingerprint for p in plan.points}) == 4


def test_names_that_sanitise_alike_are_disambiguated(tmp_path):
    path = _write(tmp_path, {"base": "base.yaml", "axes": {"tag": ["a/b", "a-b"]}})
    names = [p.name for p in plan_sweep(path, validate_fn=validate_dict).points]
    assert len(set(names)) == 2 and all(n.startswith("tag=a-b__") for n in names)


@pytest.mark.parametrize("sweep, needles", [
    ({"base": "base.yaml", "axes": {"seed": []}}, ["axis 'seed'", "at least one value"]),
    ({"base": "base.yaml", "axes": {"seed": [1, 1]}}, ["axes", "distinct", "1"]),
    ({"base": "base.yaml", "axis": {"seed": [1]}}, ["unknown key 'axis'"]),
    ({"axes": {"seed": [1]}}, ["'base'", "required"]),
    ({"base": "base.yaml", "set": {"seed": 1}, "axes": {"seed": [1, 2]}}, ["'seed'", "both"]),
    ({"base": "base.yaml", "axes": {"bad key": [1]}}, ["dotted", "'bad key'"]),
    ({"base": "nope.yaml", "axes": {"seed": [1]}}, ["'base'", "nope.yaml", "no such file"]),
    ({"base": "base.yaml", "axes": {"seed": 3}}, ["axes.seed", "list"]),
    ("base: base.yaml\naxes: {seed: [1, 2]\n", ["YAML syntax error", "line"]),
    ("- just\n- a list\n", ["top level", "list"]),
])
def test_bad_sweep_files_name_file_and_key(tmp_path, sweep, needles):
    path = _write(tmp_path, sweep)
    with pytest.raises(InputError) as err:
        plan_sweep(path, validate_fn=validate_dict)
    msg = str(err.value)
    assert str(path) in msg and "\n" not in msg
    for needle in needles:
        assert needle in msg, msg


def test_every_point_is_validated_against_the_real_schema_before_running(tmp_path):
    path = _write(tmp_path, {"base": "base.yaml",
                             "axes": {"method": ["ramen", "dinno"], "channel.success_rate": [1.0, 1.5]}})
    with pytest.raises(InputError) as err:
        plan_sweep(path)
    msg = str(err.value)
    assert "method=ramen__channel.success_rate=1.5" in msg
    assert "channel.success_rate" in msg and "1.5" in msg and "1 more of 4 points" in msg
    ok = _write(tmp_path, {"base": "base.yaml", "axes": {"method": ["ramen", "dinno"], "seed": [0, 1]}})
    assert len(plan_sweep(ok).points) == 4


def test_load_spec_keeps_name_and_set(tmp_path):
    path = _write(tmp_path, {"name": "comm", "base": "base.yaml", "set": {"duration": 3}, "axes": {"seed": [0]}})
    spec = load_spec(path)
    assert spec.name == "comm" and spec.fixed == {"duration": 3} and spec.axes == {"seed": [0]}


def test_trials_are_zipped_slowest_and_crossed_with_the_axes(tmp_path):
    path = _write(tmp_path, {"base": "base.yaml", "axes": {"method": ["ramen", "dinno"]},
                             "trials": [{"seed": 10, "world.scene.seed": 10}, {"seed": 11, "world.scene.seed": 11}]})
    plan = plan_sweep(path, validate_fn=validate_dict)
    got = [p.axes for p in plan.points]
    assert got == [{"seed": 10, "world.scene.seed": 10, "method": "ramen"},
                   {"seed": 10, "world.scene.seed": 10, "method": "dinno"},
                   {"seed": 11, "world.scene.seed": 11, "method": "ramen"},
                   {"seed": 11, "world.scene.seed": 11, "method": "dinno"}]
    assert plan.axes == {"seed": [10, 11], "world.scene.seed": [10, 11], "method": ["ramen", "dinno"]}
    assert plan.points[2].data["seed"] == 11 and plan.points[2].data["world"]["scene"]["seed"] == 11
    assert plan.to_json()["trials"] == [{"seed": 10, "world.scene.seed": 10}, {"seed": 11, "world.scene.seed": 11}]


@pytest.mark.parametrize("trials, words", [
    ([{"method": "ramen"}], "replicate keys only"),
    ([{"seed": 1}, {"seed": 2, "world.scene.seed": 2}], "same keys"),
    ([{"seed": 1}, {"seed": 1}], "appears twice"),
])
def test_bad_trials_name_the_key(tmp_path, trials, words):
    path = _write(tmp_path, {"base": "base.yaml", "trials": trials})
    with pytest.raises(InputError) as err:
        plan_sweep(path, validate_fn=validate_dict)
    assert "trials" in str(err.value) and words in str(err.value)


def test_a_trial_key_cannot_also_be_an_axis_or_set(tmp_path):
    path = _write(tmp_path, {"base": "base.yaml", "axes": {"seed": [0, 1]}, "trials": [{"seed": 3}]})
    with pytest.raises(InputError, match="also under 'axes'"):
        plan_sweep(path, validate_fn=validate_dict)
    ok = _write(tmp_path, {"base": "base.yaml", "trials": [{"seed": 3}, {"seed": 4}]})
    with pytest.raises(InputError, match="advanced by this sweep's 'trials'"):
        plan_sweep(ok, validate_fn=validate_dict, overrides=["seed=5"])
