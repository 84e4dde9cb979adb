"""``ramensim world``: look at a scenario's world, or export a built-in scene's mesh.

    ramensim world show SCENARIO.yaml [--out PNG] [--set key=value ...] [--no-coverage]
    ramensim world export NAME --seed S --out scene.ply

``show`` draws the scene from above with every agent's trajectory, then logs how much of the
ground truth each agent's camera sees on its own (% of what the team sees) and how much the
team sees (% of the scene): the room communication has to bring something.
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path


log = logging.getLogger(__name__)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register the ``world`` command and its ``show`` / ``export`` subcommands."""
    p = subparsers.add_parser("world", help="show a scenario's scene and trajectories, or export a scene mesh",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="world_command", required=True)
    s = sub.add_parser("show", help="draw the scene from above with every agent's trajectory")
    s.add_argument("scenario", help="scenario YAML file")
    s.add_argument("--out", default=None, help="PNG to write (default: <scenario name>_world.png)")
    s.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key (repeatable)")
    s.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="FILE_OR_MODULE",
                   help="load a plugin first (a .py file or a module that registers a scene; repeatable; "
                        "docs/EXTENDING.md)")
    s.add_argument("--no-coverage", dest="coverage", action="store_false",
                   help="skip the table of what each agent's camera sees")
    s.add_argument("--coverage-points", type=int, default=50_000, metavar="N",
                   help=f"ground-truth surface points sampled for the coverage table (default 50000, at most "
                        f"{MAX_COVERAGE_POINTS})")
    e = sub.add_parser("export", help="write a built-in scene's ground-truth mesh (PLY)")
    e.add_argument("name", help="scene: office, living_room, apartment, house, pretrain_room or one a plugin registers")
    e.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    e.add_argument("--out", required=True, help="output mesh file, e.g. scene.ply")
    e.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="FILE_OR_MODULE",
                   help="load a plugin first (a .py file or a module that registers a scene; repeatable; "
                        "docs/EXTENDING.md)")
    p.set_defaults(func=run)
    return p


def show(world_cfg, n_agents: int, duration: float, seed: int, out: str | Path,
         base_dir: str | Path | None = None, title: str | None = None, evaluation=None,
         coverage: bool = True, coverage_points: int = 50_000) -> Path:
    """Build the world of (world_cfg, n_agents, duration s, seed) and save its top-down PNG
    (:func:`show_world`): for a world configuration without a scenario; the command composes a
    scenario's world as a run does (``ramensim.sim.scenario_world``)."""
    from ramensim.core.seeding import Seeds
    from ramensim.world import build_world

    world = build_world(world_cfg, n_agents, duration, Seeds(seed).numpy, base_dir=base_dir)
    return show_world(world, duration, out, title, evaluation, coverage, coverage_points)


def show_world(world, duration: float, out: str | Path, title: str | None = None, evaluation=None,
               coverage: bool = True, coverage_points: int = 50_000) -> Path:
    """Save the top-down PNG of ``world`` (trajectories drawn over ``duration`` s) and close it;
    with ``coverage`` (and a ground-truth mesh) also log each agent's own coverage
    (:func:`ramensim.coverage_report.coverage_report`, ``coverage_points`` samples,
    frusta and occlusion tolerance from ``evaluation``, an EvalConfig; default its defaults)."""
    from ramensim.world.topdown import save_world_png

    try:
        caster = world.camera.caster if world.camera is not None else None
        save_world_png(out, world.scene, world.trajectories, title, caster,
                       duration if world.camera is not None else None)
        log.info("wrote %s", out)
        if coverage and world.scene is not None:
            log.info("%s", world_coverage(world, evaluation, coverage_points).table())
    finally:
        world.close()
    return Path(out)


def world_coverage(world, evaluation=None, n_points: int = 50_000):
    """Each agent's own coverage and the team's (a :class:`CoverageReport`) of ``world``, seen
    with ``evaluation``'s near/far planes and occlusion settings (an EvalConfig; None = its
    defaults); the surface samples are seeded by evaluation.seed."""
    from ramensim.evaluation.config import EvalConfig
    from ramensim.coverage_report import coverage_report

    ev = evaluation if evaluation is not None else EvalConfig()
    return coverage_report(world, ev.near_m, ev.far_m, n_points, seed=ev.seed, eps_m=ev.occlusion_eps_m,
                           stride=ev.occlusion_stride_px)


MAX_COVERAGE_POINTS = 10_000_000
"""Most surface points ``world show --coverage-points`` samples."""
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".svg", ".pdf")
"""Image formats ``world show --out`` writes (by the file's suffix)."""
MESH_SUFFIXES = (".ply", ".obj", ".stl", ".glb", ".off")
"""Mesh formats ``world export`` writes (by the file's suffix)."""


def export(name: str, seed: int, out: str | Path) -> Path:
    """Write built-in scene ``name`` (seed) as a coloured mesh file."""
    from ramensim.core.errors import InputError
    from ramensim.world import builtin_scene

    if not 0 <= seed < 2 ** 63:
        raise InputError(f"--seed {seed}: expected a non-negative integer below 2^63.")
    if Path(out).suffix.lower() not in MESH_SUFFIXES:
        raise InputError(f"--out {out}: unknown mesh format {Path(out).suffix or '(no suffix)'!r}; expected a "
                         f"file name ending in {', '.join(MESH_SUFFIXES)}.")
    scene = builtin_scene(name, seed)
    try:
        return scene.export(out)
    except OSError as exc:
        raise InputError(f"--out {out}: cannot be written ({exc.strerror or exc}); expected a path in a "
                         f"writable folder.") from None


def run(args) -> int:
    """Entry point for the parsed ``world`` command; returns the exit code."""
    if args.world_command == "export":
        if args.plugins:
            from ramensim.plugins import load_plugins

            load_plugins(args.plugins)
        path = export(args.name, args.seed, args.out)
        log.info("wrote %s", path)
        return 0
    from ramensim.config import load_scenario
    from ramensim.core.errors import InputError
    from ramensim.runfolder import safe_name, writable_output

    if not 1 <= args.coverage_points <= MAX_COVERAGE_POINTS:
        raise InputError(f"--coverage-points {args.coverage_points}: expected a number of points in "
                         f"1..{MAX_COVERAGE_POINTS}.")
    if args.out is not None and Path(args.out).suffix.lower() not in IMAGE_SUFFIXES:
        raise InputError(f"--out {args.out}: unknown image format {Path(args.out).suffix or '(no suffix)'!r}; "
                         f"expected a file name ending in {', '.join(IMAGE_SUFFIXES)}.")
    sc_path = Path(args.scenario)
    scenario = load_scenario(sc_path, args.overrides, plugins=args.plugins)
    out = args.out or f"{safe_name(scenario.name)}_world.png"
    writable_output(out, "--out")
    title = f"{scenario.name}: {scenario.agents.count} agents, {scenario.duration:g} s"
    from ramensim.sim import scenario_world

    world = scenario_world(scenario, sc_path.parent)  # as a run composes it
    show_world(world, scenario.duration, out, title=title, evaluation=scenario.evaluation,
               coverage=args.coverage, coverage_points=args.coverage_points)
    return 0
