"""``ramensim eval --mesh A.ply --gt B.ply``: the paper's metrics (Artifacts, Holes, Completion
ratio; docs/ALGORITHM.md section 5) of any reconstructed mesh against a ground-truth mesh, optionally
after culling both to what a set of camera poses saw (NICE-SLAM protocol); without culling the
denominator is the whole ground truth, which a run never uses. ``ramensim eval --mesh A.ply
--scenario RUN/scenario.yaml``: the mesh scored as a run of that scenario scores its maps (its
world's ground truth, its culling to the frames its robots took up to ``--at``, the part the team
saw as the denominator); the output says which culling and denominator it used. ``ramensim eval
--run RUN_FOLDER``: a finished run's saved meshes scored again as the run scored them.

Exit status: 0 when the metrics were computed, 1 when they could not be (empty mesh,
non-finite vertices, different units: the output says why), 2 for bad input.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from pathlib import Path
from typing import Any

from ramensim.evaluation.config import EvalConfig
from ramensim.evaluation.cull import PinholeCamera, cull_to_views, load_poses
from ramensim.evaluation.mesh import export_ply, load_mesh
from ramensim.evaluation.metrics import mesh_metrics
from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

_INTRINSICS = ("fx", "fy", "cx", "cy", "width", "height")


def add_parser(sub) -> argparse.ArgumentParser:
    """Register ``eval`` on the ``ramensim`` subparsers."""
    d = EvalConfig()
    p = sub.add_parser("eval", help="paper metrics of a mesh against ground truth",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mesh", type=Path, help="reconstructed mesh (PLY, OBJ, ...), metres")
    p.add_argument("--gt", type=Path, help="ground-truth mesh, metres")
    p.add_argument("--scenario", type=Path, metavar="FILE",
                   help="with --mesh, instead of --gt: score the mesh as a run of this scenario does (e.g. a run "
                        "folder's scenario.yaml): its ground truth, culling and denominator (the part the team saw)")
    p.add_argument("--at", type=float, default=None, metavar="T",
                   help="with --scenario: the frames taken up to T simulated seconds (default: its duration, "
                        "a run's end)")
    p.add_argument("--map", type=int, default=None, metavar="K",
                   help="with --scenario: the robot whose own and unseen parts are reported (default 0)")
    p.add_argument("--run", type=Path, metavar="RUN_FOLDER",
                   help="instead of --mesh/--gt: score a finished run's saved meshes again, as the run did "
                        "(its world, poses and evaluation settings from its scenario.yaml), beside its metrics.json")
    c = p.add_argument_group("culling (NICE-SLAM): keep only what the cameras saw")
    c.add_argument("--cull-poses", type=Path, metavar="FILE",
                   help="camera-to-world poses (OpenCV axes): .npy (N,4,4) or text, one row-major "
                        "4x4 (16 numbers) per line; needs --fx --fy --cx --cy --width --height")
    c.add_argument("--fx", type=float, help="focal length x (px)")
    c.add_argument("--fy", type=float, help="focal length y (px)")
    c.add_argument("--cx", type=float, help="principal point x (px)")
    c.add_argument("--cy", type=float, help="principal point y (px)")
    c.add_argument("--width", type=int, help="image width (px)")
    c.add_argument("--height", type=int, help="image height (px)")
    c.add_argument("--near", type=float, default=d.near_m, help="near plane (m, default %(default)s)")
    c.add_argument("--far", type=float, default=d.far_m, help="far plane (m, default %(default)g)")
    c.add_argument("--pose-stride", type=int, default=1, metavar="K", help="use every K-th pose (default 1)")
    c.add_argument("--occlusion", action="store_true",
                   help="also drop what the ground-truth surface hides from every camera (ray casting)")
    c.add_argument("--occlusion-eps", type=float, default=d.occlusion_eps_m, metavar="M",
                   help="depth tolerance of the occlusion test (m, default %(default)s)")
    c.add_argument("--occlusion-stride", type=int, default=d.occlusion_stride_px, metavar="PX",
                   help="pixel stride of the rendered depth (default %(default)s)")
    c.add_argument("--cull-max-edge", type=float, default=None, metavar="M",
                   help="split faces longer than M metres before culling, for coarse meshes whose big "
                        "faces would otherwise be kept or dropped whole (default: cull faces as given)")
    c.add_argument("--write-culled", type=Path, metavar="DIR", help="write the culled meshes as PLY here")
    p.add_argument("--samples", type=int, default=d.n_samples, metavar="N",
                   help="points sampled on each mesh (default %(default)s)")
    p.add_argument("--threshold", type=float, default=d.threshold_m, metavar="M",
                   help="completion-ratio threshold (m, default %(default)s)")
    p.add_argument("--seed", type=int, default=d.seed, help="sampling seed (default %(default)s)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)
    return p


def _load(path: Path, what: str) -> Any:
    try:
        mesh = load_mesh(path)
    except (OSError, ValueError, IndexError) as exc:
        raise InputError(f"--{what} {path}: {' '.join(str(exc).split()) or type(exc).__name__}") from None
    faces = getattr(mesh, "faces", None)
    if faces is not None and len(faces):
        lo, hi = int(faces.min()), int(faces.max())
        if lo < 0 or hi >= len(mesh.vertices):
            raise InputError(f"--{what} {path}: a face refers to vertex {lo if lo < 0 else hi}, but the mesh has "
                             f"{len(mesh.vertices)} vertices (indices 0..{len(mesh.vertices) - 1}); expected a "
                             f"valid triangle mesh.")
    return mesh


def _camera(args: argparse.Namespace) -> PinholeCamera | None:
    given = {k: getattr(args, k) for k in _INTRINSICS if getattr(args, k) is not None}
    if args.cull_poses is None:
        if given or args.occlusion:
            flags = ", ".join(f"--{k}" for k in given) or "--occlusion"
            raise InputError(f"{flags} given without --cull-poses FILE; culling needs the camera poses "
                             f"(a .npy (N,4,4) or a text file with one row-major 4x4 per line).")
        return None
    missing = [f"--{k}" for k in _INTRINSICS if k not in given]
    if missing:
        raise InputError(f"--cull-poses {args.cull_poses} needs the camera intrinsics, but "
                         f"{', '.join(missing)} {'is' if len(missing) == 1 else 'are'} missing; expected "
                         f"--fx --fy --cx --cy in pixels and --width --height in pixels.")
    try:
        return PinholeCamera(near_m=args.near, far_m=args.far, **given)
    except ValueError as exc:
        raise InputError(f"culling camera: {exc}") from None


MAX_SAMPLES = 100_000_000
"""Most points sampled on each mesh (--samples)."""
MAX_PIXELS = 100_000
"""Largest --width or --height of the culling camera (px)."""


def _check_args(args: argparse.Namespace) -> None:
    if not 1 <= args.samples <= MAX_SAMPLES:
        raise InputError(f"--samples {args.samples}: expected a number of points per mesh in 1..{MAX_SAMPLES} "
                         f"(the paper uses 200000).")
    for flag in ("width", "height"):
        v = getattr(args, flag)
        if v is not None and not 1 <= v <= MAX_PIXELS:
            raise InputError(f"--{flag} {v}: expected an image size in 1..{MAX_PIXELS} pixels.")
    if args.cull_max_edge is not None and not (math.isfinite(args.cull_max_edge) and args.cull_max_edge > 0):
        raise InputError(f"--cull-max-edge {args.cull_max_edge}: expected a positive edge length in metres.")
    if not (math.isfinite(args.threshold) and args.threshold > 0):
        raise InputError(f"--threshold {args.threshold}: expected a positive distance in metres "
                         f"(the paper uses 0.05).")
    if args.seed < 0:
        raise InputError(f"--seed {args.seed}: expected a non-negative integer.")
    if args.pose_stride < 1:
        raise InputError(f"--pose-stride {args.pose_stride}: expected a positive integer.")
    if args.occlusion_stride < 1:
        raise InputError(f"--occlusion-stride {args.occlusion_stride}: expected a positive integer (pixels).")
    if not (math.isfinite(args.occlusion_eps) and args.occlusion_eps >= 0):
        raise InputError(f"--occlusion-eps {args.occlusion_eps}: expected a non-negative distance in metres.")


def evaluate(args: argparse.Namespace) -> dict[str, Any]:
    """Load, optionally cull, and score; returns the JSON-able result."""
    _check_args(args)
    cam = _camera(args)
    recon = _load(args.mesh, "mesh")
    gt = _load(args.gt, "gt")
    result: dict[str, Any] = {"mesh": str(args.mesh), "gt": str(args.gt), "cull": "none"}
    if cam is not None:
        try:
            poses = load_poses(args.cull_poses)[::args.pose_stride]
        except (FileNotFoundError, ValueError) as exc:
            raise InputError(f"--cull-poses {exc}") from None
        t0 = time.perf_counter()
        occluder = gt if args.occlusion else None
        kw = dict(occluder=occluder, eps_m=args.occlusion_eps, stride=args.occlusion_stride,
                  max_edge_m=args.cull_max_edge)
        faces_before = (len(recon.faces), len(gt.faces))
        recon = cull_to_views(recon, poses, cam, **kw)
        gt = cull_to_views(gt, poses, cam, **kw)
        result.update(cull="frustum_occlusion" if args.occlusion else "frustum", n_poses=len(poses),
                      faces_before_cull={"recon": faces_before[0], "gt": faces_before[1]})
        log.info("culled to %d poses in %.1f s: recon %d -> %d faces, gt %d -> %d faces", len(poses),
                 time.perf_counter() - t0, faces_before[0], len(recon.faces), faces_before[1], len(gt.faces))
        if args.write_culled is not None:
            export_ply(recon, args.write_culled / f"{args.mesh.stem}_culled.ply")
            export_ply(gt, args.write_culled / f"{args.gt.stem}_culled.ply")
    result.update(mesh_metrics(recon, gt, n_samples=args.samples, threshold_m=args.threshold,
                               seed=args.seed))
    return result


def _table(result: dict[str, Any]) -> None:
    from ramensim.terminal import stdout_console
    from rich.table import Table

    table = Table(title=f"{result['mesh']}  vs  {result['gt']}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_row("Artifacts (cm, lower is better)", f"{result['artifacts_cm']:.3f}")
    table.add_row("Holes (cm, lower is better)", f"{result['holes_cm']:.3f}")
    table.add_row(f"Completion ratio (% < {result['threshold_m'] * 100:g} cm)",
                  f"{result['completion_ratio_pct']:.2f}")
    table.add_row("faces (recon / gt)", f"{result['n_faces_recon']} / {result['n_faces_gt']}")
    table.add_row("samples (recon / gt)", f"{result['n_samples_recon']} / {result['n_samples_gt']}")
    console = stdout_console()
    console.print(table)
    from ramensim.terminal import print_prose

    print_prose(console, result.get("scoring") or _scoring_without_scenario(result))
    if result["reason"]:
        console.print(f"[bold red]not computed:[/] {result['reason']}", highlight=False)


def _scoring_without_scenario(result: dict[str, Any]) -> str:
    """In words, the culling and denominator of ``--mesh --gt`` (what the table title used to say only as
    ``cull: none``)."""
    if result.get("cull", "none") == "none":
        return ("cull: none; denominator: the whole ground-truth mesh (a run scores only the part its team saw, "
                "culled to its cameras: --scenario RUN/scenario.yaml scores this mesh as the run did)")
    return (f"cull: {result['cull']} to the {result.get('n_poses')} poses of --cull-poses, both meshes; "
            f"denominator: the ground truth those poses saw")


def _evaluate_scenario(args: argparse.Namespace) -> dict[str, Any]:
    """``--mesh FILE --scenario FILE``: :func:`ramensim.commands.eval_run.evaluate_with_scenario`."""
    from ramensim.commands.eval_run import evaluate_with_scenario

    if args.mesh is None:
        raise InputError(f"--scenario {args.scenario} scores a mesh as a run of that scenario does; give the "
                         f"mesh with --mesh FILE (for a run folder's own meshes: --run RUN_FOLDER).")
    clash = [flag for flag, v in (("--gt", args.gt), ("--cull-poses", args.cull_poses), ("--run", args.run))
             if v is not None]
    if clash:
        raise InputError(f"--scenario {args.scenario} gives the ground truth, the culling and the denominator "
                         f"(its world, its robots' frames, its evaluation settings), so {', '.join(clash)} "
                         f"cannot be given with it.")
    if not args.scenario.is_file():
        raise InputError(f"--scenario {args.scenario}: not a file; expected a scenario YAML, e.g. a run folder's "
                         f"scenario.yaml.")
    return evaluate_with_scenario(args.mesh, args.scenario, args.at, args.map)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``ramensim eval``: 0 ok, 1 metrics not computable (reason printed)."""
    if args.run is not None:
        if args.mesh is not None or args.gt is not None:
            raise InputError(f"--run {args.run} scores a run folder's own meshes; --mesh and --gt are for any "
                             f"other pair of meshes (give one or the other).")
        from ramensim.commands.eval_run import evaluate_run, print_table

        res = evaluate_run(args.run)
        if args.json:
            sys.stdout.write(json.dumps(res, indent=2) + "\n")
        else:
            print_table(res)
        return 0
    if args.scenario is not None:
        result = _evaluate_scenario(args)
    elif args.at is not None or args.map is not None:
        raise InputError(f"{'--at' if args.at is not None else '--map'} is for --scenario FILE (the frames a run of "
                         f"that scenario took by then); with --gt give --cull-poses instead.")
    elif args.mesh is None or args.gt is None:
        raise InputError("ramensim eval needs --mesh FILE and --gt FILE (a reconstruction and its ground truth), "
                         "--mesh FILE and --scenario FILE (scored as a run of that scenario scores its maps), "
                         "or --run RUN_FOLDER (a finished run's meshes scored again).")
    else:
        result = evaluate(args)
        result["scoring"] = _scoring_without_scenario(result)
    if args.json:
        clean = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in result.items()}
        sys.stdout.write(json.dumps(clean, indent=2) + "\n")
    else:
        _table(result)
    return 1 if result["reason"] else 0
