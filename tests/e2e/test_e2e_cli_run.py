"""End to end through the CLI on a tiny scenario: the run folder, its metrics and message
log, and determinism (same seed -> identical results and recording)."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from ramensim.cli import main

TINY = [
    "duration=4", "agents.count=2", "world.camera.width=40", "world.camera.height=30",
    "world.camera.fx=30", "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5",
    "evaluation.voxel_m=0.1", "evaluation.n_samples=5000", "evaluation.cull=frustum",
    "map.n_rays=128", "consensus.primal_steps=3", "recording.mesh_period_s=2",
    "recording.uncertainty_period_s=2",
]
SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "office_3agents.yaml"


def _run(out: Path, *extra: str) -> dict:
    args = ["run", str(SCENARIO), "--out", str(out)]
    for s in (*TINY, *extra):
        args += ["--set", s]
    assert main(args) == 0
    return json.loads((out / "metrics.json").read_text())


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory) -> tuple[Path, Path, dict, dict]:
    base = tmp_path_factory.mktemp("e2e")
    a, b = base / "a", base / "b"
    return a, b, _run(a), _run(b)


def test_run_folder_contents(two_runs) -> None:
    a, _, m, _ = two_runs
    for name in ("scenario.yaml", "run.log", "messages.csv", "metrics.json", "run.rrd",
                 "mesh_agent_0.ply", "mesh_agent_1.ply"):
        assert (a / name).is_file(), name
    assert m["status"] == "ok" and m["method"] == "ramen"
    assert set(m["per_agent"]) == {"agent_0", "agent_1"}
    for entry in m["per_agent"].values():
        assert entry["rounds"] > 0 and entry["frames"] > 0 and not entry["diverged"]
        assert entry["completion_ratio_pct"] is not None and 0 <= entry["completion_ratio_pct"] <= 100
        assert entry["artifacts_cm"] is not None and entry["artifacts_cm"] > 0
        assert 0 < entry["own_coverage_pct"] <= 100 and entry["unseen_share_pct"] >= 0
    assert 0 < m["team_coverage_pct"] <= 100
    assert m["summary"]["completion_ratio_pct"]["n"] == 2
    # what computed it: a run is bit-identical to another only on the same build
    build = m["build"]
    assert build["simd"] in ("avx512f", "avx2", "baseline", "unknown") and build["torch"]
    assert set(build["backends"]) == {"decoder", "grid", "objective"}
    assert all(v.split("@")[0] in ("c", "torch") and int(v.split("@")[1]) >= 0 for v in build["backends"].values())
    # where and from what (ramensim/provenance.py): host, fingerprint, commit of this checkout, versions
    assert build["cpu"] and build["cores"] >= 1 and build["gpu"] is None and len(build["host"]) == 12
    assert build["ramensim"] and build["python"] and build["device"] == "cpu"
    if shutil.which("git") and (SCENARIO.parents[1] / ".git").exists():  # run from this checkout
        assert len(build["commit"]) == 40 and isinstance(build["dirty"], bool)
    # a two-robot complete graph has no robot beyond the neighbours: the far part is left out, with why
    assert all(e["far_reason"] and e["completion_far_pct"] is None for e in m["per_agent"].values())
    rows = (a / "messages.csv").read_text().strip().splitlines()
    comm = m["communication"]
    assert len(rows) - 1 == comm["sent"] > 0
    assert comm["delivered"] + comm["dropped"] == comm["sent"]
    from ramensim.costs import load  # the run's cost is in this machine's ledger (here the session's)

    assert any(e["scenario"] == m["scenario"] and e["method"] == "ramen" and e["sim_s"] == m["sim_time_s"]
               and e["wall_s"] == round(m["wall_time_s"], 3) for e in load())


def test_same_seed_identical(two_runs) -> None:
    a, b, ma, mb = two_runs
    assert (a / "messages.csv").read_bytes() == (b / "messages.csv").read_bytes()
    for m in (ma, mb):
        m.pop("wall_time_s")
    assert ma == mb
    assert (a / "mesh_agent_0.ply").read_bytes() == (b / "mesh_agent_0.ply").read_bytes()


def test_same_seed_recordings_compare_equal(two_runs) -> None:
    a, b, _, _ = two_runs
    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent)) or shutil.which("rerun")
    if rerun is None:
        pytest.skip("the rerun CLI (from rerun-sdk) is not on PATH")
    proc = subprocess.run([rerun, "rrd", "compare", "--unordered", str(a / "run.rrd"), str(b / "run.rrd")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_different_seed_differs(two_runs, tmp_path: Path) -> None:
    a, _, ma, _ = two_runs
    mc = _run(tmp_path / "c", "seed=1")
    assert (a / "messages.csv").read_bytes() != (tmp_path / "c" / "messages.csv").read_bytes()
    assert mc["per_agent"] != ma["per_agent"]


def test_periodic_evaluation_gives_curves_over_time(tmp_path: Path) -> None:
    m = _run(tmp_path / "p", "evaluation.every_s=1.5", "recording.mode=off")
    times = sorted({row["t"] for row in m["timeline"]})
    assert times == [1.5, 3.0]
    assert {row["agent"] for row in m["timeline"]} == {0, 1}
    assert all(0 <= row["completion_ratio_pct"] <= 100 for row in m["timeline"])
    assert not (tmp_path / "p" / "run.rrd").exists()
