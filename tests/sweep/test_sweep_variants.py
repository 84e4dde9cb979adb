"""A sweep file's ``variants``: named groups of overrides that form one more axis ('variant',
the fastest), so a trial can hold RAMEN, RAMEN at DiNNO's bytes and DiNNO (keys that a
cartesian product of single-key axes cannot pair); clashes are one-paragraph errors; the
runner, --only and the report take the variant axis like any other."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ramensim.core.errors import InputError
from ramensim.sweep.report import make_report
from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep, select_points
from sweep_testfuncs import fake_run, validate_dict

WIRE = {"lam": "float16", "visits": "uint16"}
SHIPPED = Path(__file__).resolve().parents[2] / "scenarios" / "sweeps" / "bytes" / "equal_bytes_fig1.yaml"


def _write(tmp_path: Path, sweep: dict) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump({"name": "exp", "base": "base.yaml", **sweep}, sort_keys=False))
    return path


def _variants() -> dict:
    return {"ramen": {"method": "ramen"},
            "ramen_dinno_bytes": {"method": "ramen", "consensus.wire": WIRE},
            "dinno": {"method": "dinno"}}


def test_variants_are_the_fastest_axis_and_set_their_keys(tmp_path: Path) -> None:
    path = _write(tmp_path, {"set": {"duration": 30}, "axes": {"seed": [0, 1], "world.scene.seed": [0, 1]},
                             "variants": _variants()})
    plan = plan_sweep(path, validate_fn=validate_dict)
    assert len(plan.points) == 12
    assert [p.axes["variant"] for p in plan.points[:3]] == ["ramen", "ramen_dinno_bytes", "dinno"]
    assert [(p.axes["seed"], p.axes["world.scene.seed"]) for p in plan.points[::3]] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert plan.points[1].name == "seed=0__world.scene.seed=0__variant=ramen_dinno_bytes"
    ramen, equal, dinno = (p.data for p in plan.points[:3])
    assert ramen["method"] == "ramen" and "consensus" not in ramen
    assert equal["method"] == "ramen" and equal["consensus"] == {"wire": WIRE}
    assert dinno["method"] == "dinno" and "consensus" not in dinno and dinno["duration"] == 30
    assert plan.axes["variant"] == ["ramen", "ramen_dinno_bytes", "dinno"]
    assert plan.to_json()["variants"]["ramen_dinno_bytes"] == {"method": "ramen", "consensus.wire": WIRE}
    assert len({p.fingerprint for p in plan.points}) == 12


@pytest.mark.parametrize("sweep,words", [
    ({"set": {"method": "dinno"}, "variants": {"a": {"method": "ramen"}}}, ["variants.a.method", "'set'"]),
    ({"axes": {"method": ["ramen"]}, "variants": {"a": {"method": "ramen"}}}, ["variants.a.method", "'axes'"]),
    ({"axes": {"variant": [1, 2]}, "variants": {"a": {}}}, ["axes.variant", "variants"]),
    ({"variants": {"a/b": {"method": "ramen"}}}, ["variants", "a/b", "folder name"]),
    ({"variants": {"a": {"consensus wire": 1}}}, ["variants", "consensus wire", "dotted"]),
])
def test_bad_variants_name_file_and_key(tmp_path: Path, sweep: dict, words: list[str]) -> None:
    path = _write(tmp_path, sweep)
    with pytest.raises(InputError) as info:
        plan_sweep(path, validate_fn=validate_dict)
    message = str(info.value)
    assert str(path) in message and "\n" not in message
    for w in words:
        assert w in message, (w, message)


def test_set_on_the_command_line_may_not_change_a_variant_key(tmp_path: Path) -> None:
    path = _write(tmp_path, {"variants": _variants()})
    with pytest.raises(InputError, match="set by the variant.*ramen_dinno_bytes"):
        plan_sweep(path, validate_fn=validate_dict, overrides=["consensus.wire={}"])
    with pytest.raises(InputError, match="set by the variant"):  # the variant would replace it unseen
        plan_sweep(path, validate_fn=validate_dict, overrides=["consensus.wire.lam=float32"])
    plan = plan_sweep(path, validate_fn=validate_dict, overrides=["duration=10"])
    assert all(p.data["duration"] == 10 for p in plan.points)


def test_a_bad_variant_is_refused_by_the_real_schema(tmp_path: Path) -> None:
    """DiNNO with RAMEN's wire override: the point names the variant and the key."""
    (tmp_path / "base.yaml").write_text("method: ramen\n")
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump({"base": "base.yaml", "variants": {
        "dinno_bad": {"method": "dinno", "consensus.wire": WIRE}}}))
    with pytest.raises(InputError) as info:
        plan_sweep(path)
    assert "variant=dinno_bad" in str(info.value) and "consensus.wire.visits" in str(info.value)


def test_variants_run_select_and_report(tmp_path: Path) -> None:
    path = _write(tmp_path, {"set": {"write_metrics": True}, "axes": {"seed": [0, 1]}, "variants": _variants()})
    plan = plan_sweep(path, validate_fn=validate_dict)
    only = select_points(plan, ["variant=dinno"])
    assert only == {"seed=0__variant=dinno", "seed=1__variant=dinno"}
    out = tmp_path / "out"
    done = run_sweep(plan, out, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    assert len(done.ok) == 6
    ran = json.loads((out / "runs" / "seed=1__variant=ramen_dinno_bytes" / "scenario.json").read_text())
    assert ran["consensus"]["wire"] == WIRE and ran["method"] == "ramen"
    report = make_report(out, formats=("png",))
    summary = (out / "summary.csv").read_text()
    rows = [line for line in summary.splitlines()[1:] if line]
    assert [r.split(",")[0] for r in rows] == ["ramen", "ramen_dinno_bytes", "dinno"]
    assert report is not None


def test_shipped_equal_bytes_sweep() -> None:
    """scenarios/sweeps/bytes/equal_bytes_fig1.yaml: Fig. 1's setting at 300 s, run seed slowest,
    three variants per trial, the override only on the middle one."""
    plan = plan_sweep(SHIPPED)
    assert len(plan.points) == 12
    assert [p.axes["variant"] for p in plan.points] == ["ramen", "ramen_dinno_bytes", "dinno"] * 4
    assert [p.axes["seed"] for p in plan.points] == [0] * 6 + [1] * 6
    for p in plan.points:
        assert p.data["duration"] == 300 and p.data["recording"]["mode"] == "off"
        assert p.data["agents"]["count"] == 2 and p.data["channel"]["windows"]["period_s"] == 30
        wire = (p.data.get("consensus") or {}).get("wire")
        assert wire == (WIRE if p.axes["variant"] == "ramen_dinno_bytes" else None)
