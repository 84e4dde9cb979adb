"""``ramensim world``: look at a scenario's world, or export a built-in scene's mesh.

    ramensim world show SCENARIO.yaml [--out PNG] [--set key=value ...]
    ramensim world export NAME --seed S --out scene.ply
"""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

from ramensim.errors import InputError

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
    e = sub.add_parser("export", help="write a built-in scene's ground-truth mesh (PLY)")
    e.add_argument("name", help="built-in scene: office, living_room, apartment or pretrain_room")
    e.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    e.add_argument("--out", required=True, help="output mesh file, e.g. scene.ply")
    p.set_defaults(func=run)
    return p


def show(world_cfg, n_agents: int, duration: float, seed: int, out: str | Path,
         base_dir: str | Path | None = None, title: str | None = None) -> Path:
    """Build the world of (world_cfg, n_agents, duration s, seed) and save its top-down PNG."""
    from ramensim.seeding import Seeds
    from ramensim.world import build_world
    from ramensim.world.topdown import save_world_png

    world = build_world(world_cfg, n_agents, duration, Seeds(seed).numpy, base_dir=base_dir)
    try:
        caster = world.camera.caster if world.camera is not None else None
        save_world_png(out, world.scene, world.trajectories, title, caster,
                       duration if world.camera is not None else None)
    finally:
        world.close()
    return Path(out)


def export(name: str, seed: int, out: str | Path) -> Path:
    """Write built-in scene ``name`` (seed) as a coloured mesh file."""
    from ramensim.world import builtin_scene

    return builtin_scene(name, seed).export(out)


def run(args) -> int:
    """Entry point for the parsed ``world`` command; returns the exit code."""
    if args.world_command == "export":
        path = export(args.name, args.seed, args.out)
        log.info("wrote %s", path)
        return 0
    from ramensim.config import load_scenario

    sc_path = Path(args.scenario)
    scenario = load_scenario(sc_path, args.overrides)
    out = args.out or f"{scenario.name}_world.png"
    path = show(scenario.world, scenario.agents.count, scenario.duration, scenario.seed, out,
                base_dir=sc_path.parent, title=f"{scenario.name}: {scenario.agents.count} agents, "
                                                f"{scenario.duration:g} s")
    log.info("wrote %s", path)
    return 0
