"""The cause studies of docs/results/causes.md ("Why local gets worse with time") on a tiny run:
``ramensim paper rescore`` (``ramensim.paper.rescore``) scores the final meshes with the views up
to each time and agrees with the run's own final scores at the end; ``ramensim paper artifacts``
(``ramensim.paper.artifacts``) splits a kept mesh into distance bins that add up to the whole."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
TINY = ["agents.count=2", "world.camera.width=40", "world.camera.height=30", "world.camera.fx=30",
        "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5", "evaluation.voxel_m=0.06",
        "evaluation.n_samples=5000", "evaluation.every_s=1", "map.n_rays=128", "consensus.primal_steps=3",
        "recording.mode=off", "duration=2", "method=local"]


@pytest.fixture(scope="module")
def local_run(tmp_path_factory) -> Path:
    from ramensim.cli import main

    out = tmp_path_factory.mktemp("cause") / "run"
    argv = ["-q", "run", str(REPO / "scenarios" / "house_3agents.yaml"), "--out", str(out)]
    for s in TINY:
        argv += ["--set", s]
    assert main(argv) == 0
    return out


@pytest.fixture
def tools():
    from ramensim.paper import artifacts, rescore
    return rescore, artifacts


def test_rescore_at_the_end_is_the_runs_own_score(local_run, tools):
    from ramensim.core.results import RunResult

    rescore_over_time, _ = tools
    res = rescore_over_time.rescore(local_run, [1.0, 2.0], own=True)
    stored = RunResult.read(local_run / "metrics.json").per_agent
    assert set(res["maps"]) == set(stored) == {"agent_0", "agent_1"}
    for name, rows in res["maps"].items():
        assert [r["t"] for r in rows] == [1.0, 2.0]
        assert rows[0]["timeline"]["artifacts_cm"] is not None  # the run evaluated at t = 1 s
        end = rows[-1]["team"]
        for key in ("completion_ratio_pct", "artifacts_cm", "holes_cm"):
            assert end[key] == pytest.approx(stored[name].metric(key), rel=1e-3), (name, key)
        assert set(rows[-1]["own"]) == {"artifacts_cm", "completion_ratio_pct", "holes_cm"}
    text = rescore_over_time.markdown(res)
    assert "## agent_0" in text and "| 2 |" in text


def test_distance_bins_add_up_to_the_kept_mesh(local_run, tools):
    _, artifacts_by_distance = tools
    res = artifacts_by_distance.analyse(local_run, 4000, 0.05)
    for m in res["maps"].values():
        shares = [r["share_pct"] for r in m["bins"]]
        assert sum(shares) == pytest.approx(100.0)
        mean = sum(r["share_pct"] * r["mean_error_cm"] for r in m["bins"] if r["mean_error_cm"] is not None) / 100.0
        assert mean == pytest.approx(m["mean_error_cm"], rel=1e-9)
        assert 0 < m["own_seen_gt_area_m2"] <= m["team_seen_gt_area_m2"] + 1e-9
        assert np.isfinite(m["kept_area_m2"])
    assert "all (kept" in artifacts_by_distance.markdown(res)


def test_parts_split_the_kept_mesh_too(local_run, tools):
    _, artifacts_by_distance = tools
    res = artifacts_by_distance.analyse(local_run, 4000, 0.05)
    for m in res["maps"].values():
        parts = {r["part"]: r for r in m["parts"]}
        assert list(parts) == list(artifacts_by_distance.PARTS)
        assert sum(r["share_pct"] for r in parts.values()) == pytest.approx(100.0)
        assert parts["far"]["share_pct"] == 0.0  # two robots: each is the other's neighbour
        mean = sum(r["share_pct"] * r["mean_error_cm"] for r in parts.values() if r["mean_error_cm"] is not None) / 100.0
        assert mean == pytest.approx(m["mean_error_cm"], rel=1e-9)
    assert "| agent_0 | own |" in artifacts_by_distance.markdown(res)
    team = {r["part"]: r for r in res["team"]["parts"]}
    assert team["far"]["share_pct"] == 0.0 and team["far"]["mean_error_cm"] is None
    assert res["team"]["mean_error_cm"] == pytest.approx(np.mean([m["mean_error_cm"] for m in res["maps"].values()]))
    assert "| far | 0.0 | - |" in artifacts_by_distance.markdown(res)


def test_team_parts_pool_the_maps_samples(tools, tmp_path):
    """A part's team error is that of all the team's samples in it (maps weighted by their
    share), its share the maps' mean; ``--compare`` prints it from saved outputs."""
    import json

    from ramensim.core.errors import InputError

    _, artifacts_by_distance = tools

    def parts(shares, errs):
        return [{"part": p, "share_pct": sh, "bad_pct": None, "mean_error_cm": e}
                for p, sh, e in zip(artifacts_by_distance.PARTS, shares, errs)]

    res = {"run": "r", "method": "ramen", "maps": {
        "agent_0": {"mean_error_cm": 3.0, "kept_area_m2": 400.0, "parts": parts([50, 10, 40, 0], [2.0, 4.0, 4.0, None])},
        "agent_1": {"mean_error_cm": 4.0, "kept_area_m2": 410.0, "parts": parts([20, 20, 60, 0], [3.0, 3.0, 5.0, None])}}}
    team = {r["part"]: r for r in artifacts_by_distance.team(res)["parts"]}
    assert team["own"]["share_pct"] == 35.0
    assert team["own"]["mean_error_cm"] == pytest.approx((50 * 2.0 + 20 * 3.0) / 70)
    assert team["far"]["mean_error_cm"] == pytest.approx((40 * 4.0 + 60 * 5.0) / 100)
    assert team["unseen by all"]["mean_error_cm"] is None
    path = tmp_path / "artifacts_by_distance.json"
    path.write_text(json.dumps(res))
    line = artifacts_by_distance.compare([path]).splitlines()[-1]
    assert line.startswith("| r | ramen | 2.29 (35) |") and line.endswith("| 3.50 |")
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(InputError, match="bad.json: not an artifacts_by_distance.json"):
        artifacts_by_distance.compare([tmp_path / "bad.json"])


def test_gt_parts_on_a_path(tools):
    _, artifacts_by_distance = tools
    # four robots on a path 0-1-2-3; samples seen by: 0 only, 1 only, 2 and 3, 3 only, nobody, 0 and 3
    seen = np.array([[1, 0, 0, 0, 0, 1],
                     [0, 1, 0, 0, 0, 0],
                     [0, 0, 1, 0, 0, 0],
                     [0, 0, 1, 1, 0, 1]], dtype=bool)
    path = [[1], [0, 2], [1, 3], [2]]
    own, nb, far, none = range(4)
    assert artifacts_by_distance.gt_parts(seen, [0], path).tolist() == [own, nb, far, far, none, own]
    assert artifacts_by_distance.gt_parts(seen, [2], path).tolist() == [far, nb, own, nb, none, nb]
    assert artifacts_by_distance.gt_parts(seen, [0, 1, 2, 3], path).tolist() == [own] * 4 + [none, own]
