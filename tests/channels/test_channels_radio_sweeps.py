"""The Fig. 5 sweeps under realistic radios (issue 18, docs/RADIO.md) expand into valid
scenarios that differ only where the experiment says they do. They are not run here."""
from __future__ import annotations

from pathlib import Path

import pytest

from ramensim.channels.burst import stationary_bad
from ramensim.config import validate
from ramensim.sweep.spec import plan_sweep

SWEEPS = Path(__file__).resolve().parents[2] / "scenarios" / "sweeps" / "radio"


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def _scenarios(name: str) -> list[tuple[dict, dict]]:
    plan = plan_sweep(SWEEPS / name)
    return [(p.axes, _flat(validate(p.data, p.name).model_dump(mode="json"))) for p in plan.points]


def test_burst_sweep_pairs_iid_and_gilbert_elliott_at_equal_mean() -> None:
    pts = _scenarios("fig5_burst.yaml")
    assert len(pts) == 16
    by = {(a["channel.success_rate"], a["method"], a["channel.burst.kind"]): sc for a, sc in pts}
    for s in (1.0, 0.5, 0.2, 0.05):
        for method in ("ramen", "dinno"):
            iid, ge = by[(s, method, "iid")], by[(s, method, "gilbert_elliott")]
            assert {k for k in iid if iid[k] != ge[k]} == {"channel.burst.kind"}
            assert ge["channel.success_rate"] == s and ge["recording.mode"] == "off"
            # the chain's long-run success (GE-2 with pi_B of GE-3) is the i.i.d. success
            pi = stationary_bad(s, ge["channel.burst.good_loss"], ge["channel.burst.bad_loss"])
            assert (1 - pi) * (1 - ge["channel.burst.good_loss"]) + pi * (1 - ge["channel.burst.bad_loss"]) \
                == pytest.approx(s)
            assert ge["world.scene.name"] == "house" and ge["agents.count"] == 3 and ge["duration"] == 60


def test_pathloss_sweep_adds_the_walls_to_the_same_iid_runs() -> None:
    pts = _scenarios("fig5_pathloss.yaml")
    assert len(pts) == 16
    by = {(a["channel.success_rate"], a["method"], a["channel.path_loss.enabled"]): sc for a, sc in pts}
    burst = {(a["channel.success_rate"], a["method"]): sc for a, sc in _scenarios("fig5_burst.yaml")
             if a["channel.burst.kind"] == "iid"}
    for s in (1.0, 0.5, 0.2, 0.05):
        for method in ("ramen", "dinno"):
            off, on = by[(s, method, False)], by[(s, method, True)]
            assert {k for k in off if off[k] != on[k]} == {"channel.path_loss.enabled"}
            assert on["channel.path_loss.wall_loss_db"] == 8.0 and on["world.scene.name"] == "house"
            # without path loss a point is the burst sweep's i.i.d. point (same runs, same seed)
            differ = {k for k in off if off[k] != burst[(s, method)].get(k)}
            assert differ <= {"name", "channel.burst.mean_bad_s", "channel.burst.good_loss",
                              "channel.burst.bad_loss"}, differ
