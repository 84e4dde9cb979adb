"""Speed and memory of one agent's mapping iteration (ramensim.agents.map).

Prints field samples per second for a full mapping iteration at the default MapConfig
(sample rays, encode + decode + render + loss, forward AND backward, smoothness, visit
counting, Adam step), for the optimised path (compiled kernels), the pure-torch fused
path (RAMENSIM_NO_NATIVE semantics) and a naive per-level pure-PyTorch hash grid with
plain autograd; plus bytes of theta, optimiser state and peak RSS.

Wall-clock figures depend on what else runs on the machine; the CPU-time figure
(samples per CPU-second of this process) is less sensitive to other load.

    PYTHONPATH=. python benchmarks/bench_map.py [--iters 30] [--threads N]
"""
from __future__ import annotations

import argparse
import resource
import time

import torch

from ramensim.agents.map import MapConfig, NeuralMap
from ramensim.agents.map import hashgrid, synthetic
from ramensim.agents.map.decoders import init_decoders
from benchmarks._machine import machine_info


def naive_encode(xn: torch.Tensor, table: torch.Tensor, spec: hashgrid.GridSpec) -> torch.Tensor:
    """Textbook pure-PyTorch hash grid: a Python loop over levels and corners, autograd
    through indexing (what the optimised kernels replace)."""
    tab = table.view(spec.n_levels, spec.T, spec.features)
    outs = []
    for lv in range(spec.n_levels):
        pos = xn * float(spec.scales[lv]) + 0.5
        cell = torch.floor(pos)
        frac = pos - cell
        cell = cell.long()
        res = int(spec.res[lv])
        acc = 0
        for c in range(8):
            b = [(c >> k) & 1 for k in range(3)]
            cx, cy, cz = cell[:, 0] + b[0], cell[:, 1] + b[1], cell[:, 2] + b[2]
            if int(spec.dense[lv]):
                idx = cx + cy * res + cz * res * res
            else:
                idx = cx ^ (cy * 2654435761) ^ (cz * 805459861)
            idx = idx & (spec.T - 1)
            w = 1.0
            for k in range(3):
                w = w * (frac[:, k] if b[k] else 1 - frac[:, k])
            acc = acc + w[:, None] * tab[lv][idx]
        outs.append(acc)
    return torch.cat(outs, dim=1)


def build(native: bool) -> NeuralMap:
    cfg = MapConfig(native=native)
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1),
                  torch.Generator().manual_seed(2))
    for i, f in enumerate(synthetic.frames(20, 160, 120)):
        m.add_frame(f, keyframe=(i % 2 == 0))
    return m


def time_iters(m: NeuralMap, iters: int) -> tuple[float, float]:
    for _ in range(3):
        m.optimizer_step(m.loss_and_grad()[1])
    c0, w0 = time.process_time(), time.perf_counter()
    for _ in range(iters):
        m.optimizer_step(m.loss_and_grad()[1])
    return (time.perf_counter() - w0) / iters, (time.process_time() - c0) / iters


def naive_iteration_time(m: NeuralMap, iters: int) -> float:
    """Same batch size, naive encoding + torch decoders + autograd + torch.optim.Adam."""
    cfg = m.cfg
    theta = m.theta.clone().requires_grad_(True)
    opt = torch.optim.Adam([theta], lr=cfg.lr, betas=(cfg.adam_beta1, cfg.adam_beta2),
                           eps=cfg.adam_eps)
    from ramensim.agents.map.losses import render_losses, sdf_losses
    from ramensim.agents.map.oneblob import oneblob_torch
    from ramensim.agents.map.render import composite, sample_depths, sdf_weights

    def one() -> None:
        rows = m._sample_rays()
        z = sample_depths(rows[:, 9], cfg.n_stratified, cfg.n_surface, cfg.near, m.far,
                          cfg.surface_range, m.gen)
        R, S = z.shape
        pts = (rows[:, None, 0:3] + rows[:, None, 3:6] * z[..., None]).reshape(-1, 3)
        xn = m._normalise(pts)
        feats = naive_encode(xn, theta, m.spec)
        sdf, raw = m.decoders.forward(feats, oneblob_torch(xn, cfg.oneblob_bins))
        sdf = sdf.reshape(R, S)
        w = sdf_weights(sdf, z, cfg.truncation)
        rgb, depth = composite(w, raw.reshape(R, S, 3), z)
        lr, ld = render_losses(rgb, depth, rows[:, 6:9], rows[:, 9])
        lf, ls = sdf_losses(z, rows[:, 9], sdf, cfg.truncation)
        loss = cfg.rgb_weight * lr + cfg.depth_weight * ld + cfg.sdf_weight * ls + cfg.fs_weight * lf
        opt.zero_grad()
        loss.backward()
        opt.step()

    one()
    t0 = time.perf_counter()
    for _ in range(iters):
        one()
    return (time.perf_counter() - t0) / iters


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iters", type=int, default=30, help="timed iterations per variant")
    ap.add_argument("--threads", type=int, default=0, help="torch/OpenMP threads (0 = default)")
    args = ap.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    cfg = MapConfig()
    spi = cfg.n_rays * cfg.samples_per_ray
    print(f"default MapConfig: {cfg.n_rays} rays x ({cfg.n_stratified}+{cfg.n_surface}) samples "
          f"= {spi} field samples/iteration, T=2^{cfg.log2_hashmap_size}, "
          f"smoothness lattice {cfg.smooth_lattice}^3")
    m = build(native=True)
    wall, cpu = time_iters(m, args.iters)
    print(f"optimised (native={m.native}, fused decoders={m.decoders.fused}): "
          f"{wall * 1e3:7.1f} ms/iteration  {spi / wall:12,.0f} samples/s wall  "
          f"{spi / cpu:12,.0f} samples/CPU-s")
    mt = build(native=False)
    wall_t, cpu_t = time_iters(mt, max(3, args.iters // 3))
    print(f"pure-torch fused path:        {wall_t * 1e3:7.1f} ms/iteration  "
          f"{spi / wall_t:12,.0f} samples/s wall  {spi / cpu_t:12,.0f} samples/CPU-s")
    wall_n = naive_iteration_time(mt, max(2, args.iters // 10))
    print(f"naive per-level torch grid:   {wall_n * 1e3:7.1f} ms/iteration  "
          f"{spi / wall_n:12,.0f} samples/s wall")
    mem = m.memory_bytes()
    print(f"theta {mem['theta']:,} B; optimiser state (Adam m, v) {mem['optimizer']:,} B; "
          f"visits {mem['visits']:,} B; grad buffer {mem['grad']:,} B; "
          f"keyframe rays {mem['keyframes']:,} B")
    rss_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(f"peak RSS of this process (three maps + torch): {rss_kb / 1024:.0f} MiB")
    print(machine_info())


if __name__ == "__main__":
    main()
