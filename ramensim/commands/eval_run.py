"""``ramensim eval --run RUN_FOLDER``: the paper's metrics of a finished run's saved meshes,
scored again exactly as the run scored them (docs/ALGORITHM.md section 5): the world and every
robot's camera poses up to the run's end are rebuilt from the folder's ``scenario.yaml`` (they
are deterministic in its seed), each ``mesh_<map>.ply`` is culled and sampled with the run's
evaluation settings, and the result is shown beside the run's own ``metrics.json``.

The saved meshes hold float32 vertices (PLY) where the run scored float64 ones, so the two
agree closely, not bit for bit (a 6-s house run: within 0.004 points of completion). With a
voxel (``evaluation.voxel_m``) whose cell diagonals straddle ``evaluation.cull_max_edge_m`` (e.g.
both 0.1 m) the rounding can split faces differently before culling, and the metrics then differ
by the samples' noise (0.4 points of completion at 5,000 samples); the default 3-cm voxel never
splits a face.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

COMPARED = ("completion_ratio_pct", "artifacts_cm", "holes_cm", "completion_unseen_pct", "own_coverage_pct",
            "completion_far_pct")
"""The per-map metrics shown beside the run's."""


def evaluate_run(folder: Path) -> dict[str, Any]:
    """``{"run": folder, "t_s": end time, "maps": {name: {"run": {...}, "again": {...}}}}``;
    InputError naming the file when the folder is not a finished run with meshes."""
    from ramensim.config import load_scenario
    from ramensim.core.results import RunResult
    from ramensim.scoring import Evaluator
    from ramensim.evaluation.mesh import load_mesh
    from ramensim.agents.consensus import get_method
    from ramensim.sim import scenario_world

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"--run {folder}: not a folder; expected a run folder (scenario.yaml, metrics.json, "
                         f"mesh_<map>.ply), e.g. runs/<name>.")
    sc = load_scenario(folder / "scenario.yaml")
    try:
        result = RunResult.read(folder / "metrics.json")
    except (ValueError, OSError) as exc:
        raise InputError(f"--run {folder}: {' '.join(str(exc).split())}") from None
    meshes = {name: folder / f"mesh_{name}.ply" for name in result.per_agent}
    missing = [p.name for p in meshes.values() if not p.is_file()]
    if missing:
        raise InputError(f"--run {folder}: {', '.join(missing)} missing; the run was made without "
                         f"output.save_meshes (or its meshes were removed), so there is nothing to score.")
    n = sc.agents.count
    world = scenario_world(sc, folder)  # as a run composes it
    evaluator = Evaluator.for_scenario(sc, world)
    if not evaluator.can_score:
        raise InputError(f"--run {folder}: the run's world has no ground-truth mesh, so its maps cannot be scored.")
    poses = evaluator.poses_by_agent_until(result.sim_time_s)
    merged = get_method(sc.method).merges_frames
    out: dict[str, Any] = {"run": str(folder), "t_s": result.sim_time_s, "maps": {}}
    for k, (name, path) in enumerate(meshes.items()):
        fed_by = list(range(n)) if merged else [k]
        again = evaluator.score_mesh(load_mesh(path), poses, fed_by)
        stored = result.per_agent[name]
        out["maps"][name] = {"run": {key: stored.metric(key) for key in COMPARED},
                             "again": {key: again.get(key) for key in COMPARED}}
    world.close()
    return out


def scoring_note(cfg: Any, n_poses: int, n_robots: int, t_s: float) -> str:
    """In words, how a scenario scores a mesh (``eval --mesh --scenario``, ``eval --run``): the
    culling, and the denominator of Completion ratio and Holes."""
    if cfg.cull == "none":
        return ("cull: none (evaluation.cull); denominator: the whole ground-truth mesh of the scenario's world")
    what = "camera frusta and what the ground truth hides (occlusion)" if cfg.cull == "frustum_occlusion" \
        else "camera frusta"
    return (f"cull: {cfg.cull} (evaluation.cull): both meshes cut to the {what} of the {n_poses} frames the "
            f"{n_robots} robot(s) took up to t = {t_s:g} s; denominator: the ground truth the team's cameras saw "
            f"by then, as the run scores it")


def evaluate_with_scenario(mesh_path: Path, scenario_path: Path, t_s: float | None = None,
                           map_index: int | None = None) -> dict[str, Any]:
    """The paper's metrics of any mesh (``eval --mesh FILE --scenario FILE``) as a run of that
    scenario scores its maps (docs/ALGORITHM.md section 5): the ground truth of the scenario's
    world, both meshes culled to the frames its robots took up to ``t_s`` (default: the
    scenario's duration; a run's end is its metrics.json ``sim_time_s``) with its
    ``evaluation`` settings, the same denominator (the part the team saw) and sampling seed;
    ``map_index`` names the robot whose own and unseen parts are reported (default 0; a method
    that merges every camera, centralised, is fed by all). InputError for a bad file or time."""
    import math

    from ramensim.agents.consensus import get_method
    from ramensim.config import load_scenario
    from ramensim.evaluation.mesh import load_mesh
    from ramensim.scoring import Evaluator
    from ramensim.sim import scenario_world

    sc = load_scenario(scenario_path)
    t = float(sc.duration if t_s is None else t_s)
    if not (math.isfinite(t) and 0 < t <= sc.duration):
        raise InputError(f"--at {t_s}: expected a simulated time in (0, {sc.duration:g}] s, the scenario's "
                         f"duration ({scenario_path}).")
    n = sc.agents.count
    k = 0 if map_index is None else map_index
    if not 0 <= k < n:
        raise InputError(f"--map {map_index}: expected a robot index in 0..{n - 1} ({scenario_path} has {n} robots).")
    try:
        mesh = load_mesh(mesh_path)
    except (OSError, ValueError, IndexError) as exc:
        raise InputError(f"--mesh {mesh_path}: {' '.join(str(exc).split()) or type(exc).__name__}") from None
    world = scenario_world(sc, Path(scenario_path).parent)
    try:
        evaluator = Evaluator.for_scenario(sc, world)
        if not evaluator.can_score:
            raise InputError(f"--scenario {scenario_path}: its world has no ground-truth mesh to score against.")
        poses = evaluator.poses_by_agent_until(t)
        fed_by = list(range(n)) if get_method(sc.method).merges_frames else [k]
        result = evaluator.score_mesh(mesh, poses, fed_by)
    finally:
        world.close()
    n_poses = sum(len(p) for p in poses)
    result.update(mesh=str(mesh_path), gt=f"the world of {scenario_path}", cull=sc.evaluation.cull,
                  scenario=str(scenario_path), t_s=t, map=k, n_poses=n_poses,
                  scoring=scoring_note(sc.evaluation, n_poses, n, t))
    result.setdefault("reason", None)
    return result


LABELS = ("completion %", "artifacts cm", "holes cm", "unseen compl. %", "own cov. %")
"""Short column titles of :data:`COMPARED` (the table fits 80 columns)."""


def print_table(res: dict[str, Any]) -> None:
    """The run's numbers and the re-scored ones, two rows per map."""
    from ramensim.terminal import stdout_console
    from rich.table import Table

    table = Table(title=f"{res['run']}: saved meshes scored again at t = {res['t_s']:g} s")
    table.add_column("map")
    table.add_column("")
    for label in LABELS:
        table.add_column(label, justify="right")
    for name, m in res["maps"].items():
        for i, which in enumerate(("run", "again")):
            cells = []
            for key in COMPARED:
                v = m[which].get(key)
                cells.append("-" if v is None or v != v else f"{v:.3f}")
            table.add_row(name if i == 0 else "", "run" if which == "run" else "again", *cells)
    stdout_console().print(table)
