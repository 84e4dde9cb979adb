"""``ramensim pretrain-decoders``: train grid and decoders jointly on the pretraining scene
(never an evaluation scene) and write the frozen decoder weights every agent loads."""
from __future__ import annotations

import argparse
import logging
from pathlib import Path

log = logging.getLogger(__name__)


def add_parser(sub) -> None:
    p = sub.add_parser("pretrain-decoders", help="pretrain the frozen decoders", description=__doc__)
    p.add_argument("--scene", default="pretrain_room", help="built-in scene to pretrain on")
    p.add_argument("--seed", type=int, default=0, help="root seed (scene, trajectory, init, sampling)")
    p.add_argument("--iterations", type=int, default=3000, help="optimiser iterations")
    p.add_argument("--duration", type=float, default=60.0, help="seconds of trajectory to render")
    p.add_argument("--agents", type=int, default=1, help="trajectories to render (all frames to one learner)")
    p.add_argument("--preset", default=None, help="map preset (default: the scenario default)")
    p.add_argument("--out", required=True, help="output file (.pt)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ramensim.agents.map import MapConfig, pretrain_decoders, save_decoders
    from ramensim.agents.map.config import PRESETS
    from ramensim.errors import InputError
    from ramensim.seeding import Seeds
    from ramensim.world import WorldConfig, build_world

    if args.preset is not None and args.preset not in PRESETS:
        raise InputError(f"--preset {args.preset!r}: unknown; expected one of {sorted(PRESETS)}.")
    cfg = PRESETS[args.preset] if args.preset else MapConfig()
    if args.iterations < 1:
        raise InputError(f"--iterations {args.iterations}: expected a positive number of iterations.")
    wcfg = WorldConfig.model_validate({"scene": {"name": args.scene, "seed": args.seed}})
    world = build_world(wcfg, args.agents, args.duration, Seeds(args.seed).numpy)
    frames = [world.render(a, i) for a in range(world.n_agents) for i in range(len(world.frames_for(a)))]
    log.info("pretraining on %d frames of %s for %d iterations", len(frames), args.scene, args.iterations)
    weights = pretrain_decoders(frames, world.bounds, cfg, args.iterations, args.seed)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_decoders(weights, out)
    log.info("wrote %s (%d bytes)", out, out.stat().st_size)
    world.close()
    return 0
