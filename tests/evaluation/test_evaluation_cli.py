"""``ramensim eval``: table/JSON output, culling flags, and one-paragraph input errors."""
from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
import trimesh

from ramensim.evaluation.mesh import export_ply
from ramensim.commands import eval as eval_cmd
from ramensim.core.errors import InputError


def _parse(argv):
    parser = argparse.ArgumentParser(prog="ramensim")
    eval_cmd.add_parser(parser.add_subparsers(dest="command"))
    return parser.parse_args(["eval", *argv])


@pytest.fixture
def meshes(tmp_path):
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0)).subdivide().subdivide()
    gt = export_ply(box, tmp_path / "gt.ply")
    shifted = export_ply(box.copy().apply_translation((0.0, 0.0, 0.02)), tmp_path / "recon.ply")
    return shifted, gt


def test_json_output(meshes, capsys):
    recon, gt = meshes
    args = _parse(["--mesh", str(recon), "--gt", str(gt), "--samples", "5000", "--json"])
    assert args.func is eval_cmd.run
    assert eval_cmd.run(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reason"] is None and out["cull"] == "none"
    assert 0.3 < out["artifacts_cm"] < 2.5 and out["completion_ratio_pct"] > 99.0


def test_table_output(meshes, capsys):
    recon, gt = meshes
    assert eval_cmd.run(_parse(["--mesh", str(recon), "--gt", str(gt), "--samples", "2000"])) == 0
    out = capsys.readouterr().out
    assert "Completion ratio" in out and "Artifacts" in out and "Holes" in out


def test_culling_with_poses_file(meshes, tmp_path, capsys):
    recon, gt = meshes
    c2w = np.eye(4)
    c2w[:3, 3] = (0.0, 0.0, -3.0)  # 3 m in front of the box, looking at it along +z
    poses = tmp_path / "poses.txt"
    poses.write_text(" ".join(map(str, c2w.ravel())) + "\n")
    argv = ["--mesh", str(recon), "--gt", str(gt), "--samples", "3000", "--json", "--cull-poses", str(poses),
            "--fx", "100", "--fy", "100", "--cx", "50", "--cy", "50", "--width", "100", "--height", "100",
            "--occlusion", "--write-culled", str(tmp_path / "culled")]
    assert eval_cmd.run(_parse(argv)) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cull"] == "frustum_occlusion" and out["n_poses"] == 1
    assert 0 < out["n_faces_gt"] < out["faces_before_cull"]["gt"]  # the back of the box is hidden
    assert (tmp_path / "culled" / "gt_culled.ply").is_file()


def test_empty_mesh_reports_reason_and_exit_1(meshes, tmp_path, capsys):
    _, gt = meshes
    empty = export_ply(trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int)), tmp_path / "empty.ply")
    assert eval_cmd.run(_parse(["--mesh", str(empty), "--gt", str(gt), "--json"])) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["artifacts_cm"] is None and "empty" in out["reason"]


def test_missing_and_unreadable_files_raise_input_error(meshes, tmp_path):
    recon, gt = meshes
    with pytest.raises(InputError, match=r"--mesh .*nope.ply: mesh file not found"):
        eval_cmd.run(_parse(["--mesh", str(tmp_path / "nope.ply"), "--gt", str(gt)]))
    junk = tmp_path / "junk.ply"
    junk.write_text("garbage")
    with pytest.raises(InputError, match="junk.ply"):
        eval_cmd.run(_parse(["--mesh", str(recon), "--gt", str(junk)]))


def test_culling_flag_errors(meshes, tmp_path):
    recon, gt = meshes
    with pytest.raises(InputError, match="--fy, --cx, --cy, --width, --height are missing"):
        eval_cmd.run(_parse(["--mesh", str(recon), "--gt", str(gt), "--cull-poses", "p.txt", "--fx", "1"]))
    with pytest.raises(InputError, match="without --cull-poses"):
        eval_cmd.run(_parse(["--mesh", str(recon), "--gt", str(gt), "--occlusion"]))
    intr = ["--fx", "1", "--fy", "1", "--cx", "0", "--cy", "0", "--width", "4", "--height", "4"]
    with pytest.raises(InputError, match="poses file not found"):
        eval_cmd.run(_parse(["--mesh", str(recon), "--gt", str(gt), "--cull-poses", str(tmp_path / "p.txt"), *intr]))
    with pytest.raises(InputError, match="--samples 0"):
        eval_cmd.run(_parse(["--mesh", str(recon), "--gt", str(gt), "--samples", "0"]))


def test_a_folder_given_as_the_mesh_is_named_as_a_folder(meshes, tmp_path, capsys):
    from ramensim.cli import main

    recon, gt = meshes
    assert main(["eval", "--mesh", str(tmp_path), "--gt", str(gt)]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path}: is a folder; expected a triangle mesh file" in err and "gt.ply" in err


def test_eval_run_scores_a_runs_saved_meshes_as_the_run_did(tmp_path, capsys):
    """``ramensim eval --run FOLDER`` rebuilds the world and poses from scenario.yaml and scores
    the saved meshes as the run did: the same numbers up to the float32 vertices of the PLY."""
    from ramensim.cli import main

    out = tmp_path / "run"
    tiny = ["agents.count=2", "world.camera.width=40", "world.camera.height=30", "world.camera.fx=30",
            "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5", "evaluation.voxel_m=0.06",
            "evaluation.n_samples=5000", "map.n_rays=128", "consensus.primal_steps=3", "recording.mode=off",
            "duration=2"]
    from pathlib import Path

    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "house_3agents.yaml"
    argv = ["-q", "run", str(scenario), "--out", str(out)]
    for s in tiny:
        argv += ["--set", s]
    assert main(argv) == 0
    capsys.readouterr()
    assert main(["eval", "--run", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert set(res["maps"]) == {"agent_0", "agent_1"}
    for m in res["maps"].values():
        for key in ("completion_ratio_pct", "artifacts_cm", "holes_cm"):
            assert m["run"][key] == pytest.approx(m["again"][key], rel=1e-3), key
    assert main(["eval", "--run", str(out), "--mesh", "x.ply"]) == 2
    capsys.readouterr()
    _eval_mesh_with_the_runs_scenario(out, res, main, capsys)
    (out / "mesh_agent_1.ply").unlink()
    assert main(["eval", "--run", str(out)]) == 2
    assert "mesh_agent_1.ply missing" in capsys.readouterr().err


def _eval_mesh_with_the_runs_scenario(out, res, main, capsys):
    """``eval --mesh MESH --scenario RUN/scenario.yaml`` scores any mesh as the run scored its
    maps (its culling and denominator, the part the team saw) and says so; ``--gt`` with the
    whole ground truth gives another number, and the output says why (issue 57: 38.5 % against
    the run's 63.9 % with only "cull: none" said)."""
    from ramensim.config import load_scenario

    mesh, scen = out / "mesh_agent_1.ply", out / "scenario.yaml"
    assert main(["eval", "--mesh", str(mesh), "--scenario", str(scen), "--map", "1", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    for key in ("completion_ratio_pct", "artifacts_cm", "holes_cm", "completion_unseen_pct"):
        assert got[key] == pytest.approx(res["maps"]["agent_1"]["run"][key], rel=1e-3), key
    sc = load_scenario(scen)
    assert got["cull"] == sc.evaluation.cull != "none" and got["t_s"] == sc.duration
    assert "denominator: the ground truth the team's cameras saw" in got["scoring"]
    assert main(["eval", "--mesh", str(mesh), "--scenario", str(scen), "--map", "1"]) == 0
    table = " ".join(capsys.readouterr().out.split())
    assert f"cull: {sc.evaluation.cull} (evaluation.cull)" in table and "up to t = 2 s" in table
    # the whole ground truth, uncut: another denominator, and the output says so
    gt = out / "gt.ply"
    assert main(["-q", "world", "export", sc.world.scene.name, "--seed", str(sc.world.scene.seed),
                 "--out", str(gt)]) == 0
    capsys.readouterr()
    assert main(["eval", "--mesh", str(mesh), "--gt", str(gt), "--samples", "5000", "--json"]) == 0
    whole = json.loads(capsys.readouterr().out)
    assert whole["completion_ratio_pct"] < got["completion_ratio_pct"] - 5
    assert "denominator: the whole ground-truth mesh" in whole["scoring"] and "--scenario" in whole["scoring"]
    for argv, words in ((["--gt", str(gt)], "cannot be given with it"), (["--at", "99"], "expected a simulated time"),
                        (["--map", "5"], "expected a robot index in 0..1")):
        assert main(["eval", "--mesh", str(mesh), "--scenario", str(scen), *argv]) == 2
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err, err
    assert main(["eval", "--mesh", str(mesh), "--gt", str(gt), "--at", "1"]) == 2
    assert "--at is for --scenario" in capsys.readouterr().err
