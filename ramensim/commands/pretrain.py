"""``ramensim pretrain-decoders``: train grid and decoders jointly on the pretraining scene
(never an evaluation scene) and write frozen decoder weights, with the settings that made them.

The same settings on the same machine give the same bytes. They do not give the shipped
``agents/data/decoders.pt`` (which every scenario loads unless ``map.decoders`` names another
file): that file was trained on 2026-11-21 with the code of that day, and the map's kernels are
chosen and compiled per machine, so a re-run differs (with the documented command, 2026-11-27:
by up to 4.7 in a weight); the command says by how much at its end. docs/MAP_PERFORMANCE.md,
"The shipped decoders"."""
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


MAX_ITERATIONS = 10_000_000
MAX_AGENTS = 64
MAX_DURATION_S = 86_400.0


def _check_args(args: argparse.Namespace) -> None:
    """One-paragraph InputErrors for arguments out of range (counts bounded, numbers finite)."""
    import math

    from ramensim.core.errors import InputError

    if not 1 <= args.iterations <= MAX_ITERATIONS:
        raise InputError(f"--iterations {args.iterations}: expected a number of iterations in 1..{MAX_ITERATIONS}.")
    if not 1 <= args.agents <= MAX_AGENTS:
        raise InputError(f"--agents {args.agents}: expected a number of trajectories in 1..{MAX_AGENTS}.")
    if not (math.isfinite(args.duration) and 0 < args.duration <= MAX_DURATION_S):
        raise InputError(f"--duration {args.duration}: expected seconds of trajectory in (0, {MAX_DURATION_S:g}].")
    if not 0 <= args.seed < 2 ** 63:
        raise InputError(f"--seed {args.seed}: expected a non-negative integer below 2^63.")
    if Path(args.out).suffix != ".pt":
        raise InputError(f"--out {args.out}: expected a file name ending in .pt (a torch file of decoder weights).")
    from ramensim.runfolder import writable_output

    writable_output(args.out, "--out")  # before minutes of training


def run(args: argparse.Namespace) -> int:
    from ramensim.agents.map import MapConfig, pretrain_decoders, save_decoders
    from ramensim.agents.map.config import PRESETS
    from ramensim.core.errors import InputError
    from ramensim.core.seeding import Seeds
    from ramensim.world import WorldConfig, build_world

    if args.preset is not None and args.preset not in PRESETS:
        raise InputError(f"--preset {args.preset!r}: unknown; expected one of {sorted(PRESETS)}.")
    cfg = PRESETS[args.preset] if args.preset else MapConfig()
    _check_args(args)
    try:
        wcfg = WorldConfig.model_validate({"scene": {"name": args.scene, "seed": args.seed}})
    except ValueError:
        from ramensim.world.scenes import _BUILDERS

        raise InputError(f"--scene {args.scene!r}: not a built-in scene; expected one of "
                         f"{', '.join(sorted(_BUILDERS))}.") from None
    world = build_world(wcfg, args.agents, args.duration, Seeds(args.seed).numpy)
    frames = [world.render(a, i) for a in range(world.n_agents) for i in range(len(world.frames_for(a)))]
    log.info("pretraining on %d frames of %s for %d iterations", len(frames), args.scene, args.iterations)
    weights = pretrain_decoders(frames, world.bounds, cfg, args.iterations, args.seed)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_decoders(weights, out, _settings(args, cfg))
    log.info("wrote %s (%d bytes; its settings recorded in it)", out, out.stat().st_size)
    world.close()
    _compare_with_shipped(weights)
    return 0


def _settings(args: argparse.Namespace, cfg) -> dict:
    """What made the weights: the command's settings, the map preset and the versions."""
    import platform

    import torch

    from ramensim import __version__

    return {"command": "ramensim pretrain-decoders", "scene": args.scene, "seed": args.seed,
            "iterations": args.iterations, "duration_s": args.duration, "agents": args.agents,
            "preset": args.preset, "map": cfg.model_dump(mode="json"), "ramensim": __version__,
            "torch": torch.__version__, "python": platform.python_version(), "machine": platform.machine()}


def _compare_with_shipped(weights) -> None:
    """Say how far the new weights are from the shipped file (they are new weights, not it)."""
    from ramensim.agents.map.pretrain import DEFAULT_DECODERS, load_decoders

    try:
        shipped = load_decoders()
    except (OSError, ValueError):
        return
    diff = max(float((weights[k].float() - shipped[k]).abs().max()) for k in shipped)
    log.info("largest difference to the shipped %s: %.4g (0 = the same weights; the shipped file was trained "
             "with the code of 2026-11-21 and stays what every scenario loads unless map.decoders names "
             "another file)", DEFAULT_DECODERS.name, diff)
