"""One batched round of a team's maps against the same maps' rounds one by one, on the torch
path (``map.native: false``: the form a GPU runs), measured on this machine.

A round here is B optimiser steps of every map: L_obj and its gradient (eq. 5-6), then Adam.
"separate" calls each map's ``loss_and_grad`` in turn (what a team costs today: the sum of its
robots); "batched" calls :func:`ramensim.agents.map.team_batch.team_loss_and_grad` once per step
for all maps (stacked tables, one decoder product, per-robot losses). Adam is per map in both.
The maps are the default map configuration (the house runs' grid) over the synthetic room, each
robot with its own frames and generator; the two sets start identical and their gradients are
checked equal (up to float rounding) on the first step.

    PYTHONPATH=. python benchmarks/bench_team_batch.py [--robots 3,6,12,24] [--steps 10] [--device cpu]
        [--n-rays 1024] [--preset paper]

``--preset paper`` measures Co-SLAM's Replica settings (2048 rays, 32 + 11 samples per ray); the
last column is the team's samples per second in the batched round (each sample through the hash
grid and decoders, forward and backward), the figure benchmarks/device_check.py reports.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks._machine import machine_info  # noqa: E402
from ramensim.agents.map import MapConfig, NeuralMap, load_decoders, synthetic  # noqa: E402
from ramensim.agents.map.team_batch import team_loss_and_grad  # noqa: E402


def team(k: int, device: str, n_rays: int | None = None, preset: str = "cpu") -> list[NeuralMap]:
    """``k`` maps of ``map.preset`` ``preset`` on ``device`` (torch path), each fed six frames of
    the synthetic room from its own phase (every fifth a keyframe)."""
    cfg = MapConfig(preset=preset, native=False, device=device, **({"n_rays": n_rays} if n_rays else {}))
    dec = load_decoders()
    maps = []
    for r in range(k):
        m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1),
                      torch.Generator().manual_seed(100 + r))
        for i, f in enumerate(synthetic.frames(6, 160, 120, phase=0.37 * r)):
            m.add_frame(f, keyframe=(i % 5 == 0))
        maps.append(m)
    return maps


def _sync(device: str) -> None:
    if device == "cuda":
        torch.cuda.synchronize()


def round_separate(maps: list[NeuralMap], steps: int, device: str) -> float:
    t0 = time.perf_counter()
    for _ in range(steps):
        for m in maps:
            _, g = m.loss_and_grad()
            m.optimizer_step(g)
    _sync(device)
    return time.perf_counter() - t0


def round_batched(maps: list[NeuralMap], steps: int, device: str) -> float:
    t0 = time.perf_counter()
    for _ in range(steps):
        for m, (_, g) in zip(maps, team_loss_and_grad(maps)):
            m.optimizer_step(g)
    _sync(device)
    return time.perf_counter() - t0


def measure(k: int, device: str, steps: int, repeats: int, preset: str = "cpu",
            n_rays: int | None = None) -> dict[str, float]:
    """One team size: the fastest of ``repeats`` rounds of ``steps`` steps, separate and batched
    (s), their ratio, the first step's largest relative gradient difference, and the team's
    samples per second in the batched round (robots x steps x rays x (stratified + surface)
    samples / s: the points pushed through the hash grid and decoders, forward and backward)."""
    cfg = MapConfig(preset=preset, native=False, **({"n_rays": n_rays} if n_rays else {}))
    sep_maps, bat_maps = team(k, device, n_rays, preset), team(k, device, n_rays, preset)
    ref = [g.clone() for m in sep_maps for _, g in [m.loss_and_grad()]]
    got = [g for _, g in team_loss_and_grad(bat_maps)]
    err = max(float((x - y).abs().max()) / max(float(x.abs().max()), 1e-30) for x, y in zip(ref, got))
    sep = min(round_separate(sep_maps, steps, device) for _ in range(repeats))
    bat = min(round_batched(bat_maps, steps, device) for _ in range(repeats))
    samples = k * steps * cfg.n_rays * (cfg.n_stratified + cfg.n_surface)
    return {"robots": k, "preset": preset, "n_rays": cfg.n_rays, "samples_per_ray": cfg.n_stratified + cfg.n_surface,
            "steps": steps, "separate_s": sep, "batched_s": bat, "ratio": bat / sep, "max_rel_grad_diff": err,
            "batched_samples_per_s": samples / bat, "separate_samples_per_s": samples / sep}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", default="3,6,12,24")
    p.add_argument("--steps", type=int, default=10, help="optimiser steps per round (B)")
    p.add_argument("--repeats", type=int, default=3, help="rounds timed per size (the minimum is printed)")
    p.add_argument("--device", default="cpu")
    p.add_argument("--preset", default="cpu", choices=("cpu", "paper"),
                   help="map.preset: cpu (the default map) or paper (2048 rays, 32 + 11 samples, T = 2^16)")
    p.add_argument("--n-rays", type=int, default=None, help="rays per step (default: the preset's)")
    a = p.parse_args(argv)
    print(machine_info())
    cfg = MapConfig(preset=a.preset, native=False, **({"n_rays": a.n_rays} if a.n_rays else {}))
    print(f"torch path ({a.device}), {a.preset} map ({cfg.n_rays} rays x {cfg.n_stratified}+{cfg.n_surface} samples, "
          f"2^{cfg.log2_hashmap_size} x {cfg.n_levels} levels), B = {a.steps} steps per round")
    print(f"{'robots':>6} {'separate s':>11} {'batched s':>10} {'ratio':>6} {'M samples/s':>12} {'max |dg|/|g|':>13}")
    for k in (int(s) for s in a.robots.split(",") if s):
        r = measure(k, a.device, a.steps, a.repeats, a.preset, a.n_rays)
        print(f"{k:>6} {r['separate_s']:>11.3f} {r['batched_s']:>10.3f} {r['ratio']:>6.2f} "
              f"{r['batched_samples_per_s'] / 1e6:>12.2f} {r['max_rel_grad_diff']:>13.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
