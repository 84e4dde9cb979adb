"""Speed and memory of one agent's mapping iteration (ramensim.agents.map).

Prints field samples per second for a full mapping iteration at the default MapConfig
(sample rays, encode + decode + render + loss, forward AND backward, smoothness, visit
counting, Adam step), for the optimised path (compiled kernels), the pure-torch fused
path (RAMENSIM_NO_NATIVE semantics) and a naive per-level pure-PyTorch hash grid with
plain autograd; plus bytes of theta, optimiser state and peak RSS.

The optimised map uses the backends the selector picks on this machine
(agents/map/backend.py; printed with their timings); the forced variants (``c`` / ``torch``
decoders and grid) are timed beside it. The machine-independent goals are RATIOS measured
in this one run, the two timed in alternating rounds: optimised / naive per-level torch
(>= 15x on x86-64 with AVX2), and >= 1,000,000 samples/s on 2 threads. Wall-clock
figures depend on what else runs on the machine (the load average is printed); the CPU-time
figure (samples per CPU-second of this process) is less sensitive to other load.

``--march x86-64-v3`` builds the C kernels for AVX2 + FMA only (what an AVX2 machine gets
from -march=native), so an AVX-512 machine can measure the AVX2 code path.

    PYTHONPATH=. python benchmarks/bench_map.py [--iters 30] [--threads N] [--march TARGET]
        [--stages] [--breakdown] [--remeasure]

``--breakdown`` prints where the optimised iteration's wall time goes, stage by stage inside
``loss_and_grad`` and the Adam step (each stage's function timed in place, 40 iterations).
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import time

from ramensim.core.native import prefer_passive_openmp

# the OpenMP wait policy a run uses (the CLI and the API set it the same way, before torch
# starts; a policy set in the environment wins): the ratios are those a run would see
PASSIVE_SET_HERE = prefer_passive_openmp()

import torch  # noqa: E402  (after the OpenMP policy)

from ramensim.agents.map import MapConfig, NeuralMap  # noqa: E402
from ramensim.agents.map import hashgrid, synthetic  # noqa: E402
from ramensim.agents.map.decoders import init_decoders  # noqa: E402
from benchmarks._machine import machine_info  # noqa: E402


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


def build(native: bool, **backends: str) -> NeuralMap:
    cfg = MapConfig(native=native, **backends)
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


def naive_step(m: NeuralMap):
    """One iteration of the naive path at the same batch size (naive per-level encoding +
    torch decoders through autograd + torch.optim.Adam), as a closure."""
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

    return one


def interleaved(steps: dict[str, tuple], rounds: int) -> dict[str, tuple[float, float]]:
    """Median (wall s, CPU s) per iteration of each ``name -> (step, iterations per round)``,
    timed in ``rounds`` alternating rounds (one block of each per round, the order
    alternating), so that load from other processes falls on all of them alike."""
    times: dict[str, list[tuple[float, float]]] = {k: [] for k in steps}
    for step, _ in steps.values():  # warm-up
        step()
    names = list(steps)
    for r in range(rounds):
        for name in (names if r % 2 == 0 else names[::-1]):
            step, k = steps[name]
            c0, w0 = time.process_time(), time.perf_counter()
            for _ in range(k):
                step()
            times[name].append(((time.perf_counter() - w0) / k, (time.process_time() - c0) / k))
    return {k: (statistics.median(t[0] for t in v), statistics.median(t[1] for t in v))
            for k, v in times.items()}


def agreement(iters: int = 1) -> list[str]:
    """Loss and gradient of every decoder x grid x objective backend against the pure-torch
    autograd reference, same batch (the size of 'beyond float rounding')."""
    def run(m: NeuralMap) -> tuple[float, torch.Tensor]:
        s, g = m.loss_and_grad()
        return s["loss"], g.clone()

    cfg = MapConfig(native=False)
    ref_m = NeuralMap(synthetic.bounds(), cfg, init_decoders(cfg, torch.Generator().manual_seed(0)),
                      torch.Generator().manual_seed(1), torch.Generator().manual_seed(2),
                      train_decoders=True)
    for i, f in enumerate(synthetic.frames(20, 160, 120)):
        ref_m.add_frame(f, keyframe=(i % 2 == 0))
    ref_l, ref_g = run(ref_m)
    scale = float(ref_g.abs().max())
    out = []
    for dec in ("c", "torch"):
        for grid in ("c", "torch"):
            for obj in ("c", "torch"):
                m = build(True, decoder_backend=dec, grid_backend=grid, objective_backend=obj)
                if (m.decoders.backend != dec or m.grid_native != (grid == "c")
                        or m.objective_backend != obj):
                    out.append(f"  decoder {dec} / grid {grid} / objective {obj}: unavailable here")
                    continue
                loss, g = run(m)
                out.append(f"  decoder {dec:5s} / grid {grid:5s} / objective {obj:5s}: "
                           f"|loss - ref| / ref = {abs(loss - ref_l) / abs(ref_l):.1e}, "
                           f"max |grad - ref| / max |ref| = "
                           f"{float((g - ref_g).abs().max()) / scale:.1e}")
    return out


BREAKDOWN = {  # owner.attribute -> label: the stages of one optimised iteration
    "NeuralMap._sample_rays": "draw rays (keyframes + current frame)",
    "neural_map.sample_points": "sample depths and positions",
    "step.oneblob": "OneBlob encoding",
    "step.encode": "hash-grid forward (batch + smoothness lattice)",
    "Decoders.fused_forward": "decoders forward",
    "step.observation_grads": "rendering + losses, forward and gradient",
    "Decoders.fused_backward": "decoders backward",
    "step.accumulate_grad": "hash-grid backward (batch + smoothness lattice)",
    "NeuralMap.count_visits": "visit counts (eq. 18)",
    "neural_map.smoothness_points": "smoothness lattice",
    "step.smoothness_grads": "smoothness term and gradient",
    "NeuralMap._adam": "Adam step",
}


def breakdown(iters: int = 40) -> list[str]:
    """Wall ms per iteration of each stage of the optimised iteration (BREAKDOWN), measured
    by timing the stage's function in place; the rest is Python and glue."""
    import collections

    from ramensim.agents.map import decoders, neural_map, step

    m = build(True)
    spent: dict[str, float] = collections.defaultdict(float)
    patched = []
    owners = {"neural_map": neural_map, "step": step, "NeuralMap": neural_map.NeuralMap,
              "Decoders": decoders.Decoders}
    for key in BREAKDOWN:
        owner_name, attr = key.split(".")
        owner = owners[owner_name]
        fn = getattr(owner, attr)

        def timed(*a, _fn=fn, _key=key, **k):
            t0 = time.perf_counter()
            try:
                return _fn(*a, **k)
            finally:
                spent[_key] += time.perf_counter() - t0
        setattr(owner, attr, timed)
        patched.append((owner, attr, fn))
    try:
        for _ in range(3):
            m.optimizer_step(m.loss_and_grad()[1])
        spent.clear()
        t0 = time.perf_counter()
        for _ in range(iters):
            m.optimizer_step(m.loss_and_grad()[1])
        total = (time.perf_counter() - t0) / iters * 1e3
    finally:
        for owner, attr, fn in patched:
            setattr(owner, attr, fn)
    out = [f"  {'whole iteration':48s} {total:6.2f} ms"]
    for key, label in sorted(BREAKDOWN.items(), key=lambda kv: -spent[kv[0]]):
        out.append(f"  {label:48s} {spent[key] / iters * 1e3:6.2f} ms")
    rest = total - sum(spent.values()) / iters * 1e3
    out.append(f"  {'the rest (Python, glue, small torch ops)':48s} {rest:6.2f} ms")
    return out


def stage_times(n: int = 32768, reps: int = 30) -> list[str]:
    """Best-of-``reps`` ms of each decoder backend's forward and backward, and of the C hash
    grid's forward and backward, on ``n`` samples of the default configuration."""
    from ramensim.agents.map.decoders import DecoderKernel

    def best(fn) -> float:
        fn()
        t = float("inf")
        for _ in range(reps):
            t0 = time.perf_counter()
            fn()
            t = min(t, time.perf_counter() - t0)
        return t * 1e3

    cfg = MapConfig()
    g = torch.Generator().manual_seed(0)
    w = init_decoders(cfg, g)
    feats = (torch.rand(n, 32, generator=g) * 2 - 1) * 0.1
    pe = torch.rand(n, 48, generator=g)
    ds, dr = torch.randn(n, generator=g), torch.randn(n, 3, generator=g)
    out = []
    for b in ("c", "torch"):
        try:
            k = DecoderKernel(b, w, 32, 48, torch.device("cpu"))
        except RuntimeError as exc:
            out.append(f"  decoder {b}: unavailable ({exc})")
            continue
        out.append(f"  decoder {b:5s}: forward {best(lambda: k.forward(feats, pe)):6.2f} ms, "
                   f"backward {best(lambda: k.backward(feats, pe, ds, dr)):6.2f} ms")
    spec = hashgrid.GridSpec.build(cfg.n_levels, cfg.features_per_level, cfg.log2_hashmap_size,
                                   cfg.base_resolution, 300.0)
    xn = torch.rand(n, 3, generator=g)
    table = (torch.rand(spec.n_params, generator=g) * 2 - 1) * 1e-4
    gout = torch.randn(n, spec.out_dim, generator=g)
    grad = torch.zeros(spec.n_params)
    out.append(f"  grid c      : forward {best(lambda: hashgrid.encode(xn, table, spec)):6.2f} ms, "
               f"backward {best(lambda: hashgrid.accumulate_grad(xn, gout, spec, grad)):6.2f} ms")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iters", type=int, default=30, help="timed iterations per variant")
    ap.add_argument("--threads", type=int, default=0, help="torch/OpenMP threads (0 = default)")
    ap.add_argument("--march", default="", help="build target of the C kernels, e.g. "
                    "x86-64-v3 (AVX2) (default: $RAMENSIM_MARCH or native)")
    ap.add_argument("--remeasure", action="store_true",
                    help="measure the backend choice again instead of reading the cache")
    ap.add_argument("--breakdown", action="store_true",
                    help="also time each stage of the optimised iteration in place")
    ap.add_argument("--stages", action="store_true",
                    help="also time each stage's backends alone on 32,768 samples")
    args = ap.parse_args()
    if args.march:
        os.environ["RAMENSIM_MARCH"] = args.march
    if args.threads:
        torch.set_num_threads(args.threads)
    from ramensim.agents.map import _native, backend
    from ramensim.core.alloc import keep_freed_memory

    malloc_tuned = keep_freed_memory()  # as a run does (build_simulation)

    print(machine_info())
    print(f"load average at start: {os.getloadavg()[0]:.2f}; C kernels built with "
          f"-march={_native.march()}; OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY', '(unset)')}"
          f"{' (set as a run sets it)' if PASSIVE_SET_HERE else ''}; malloc keeps freed memory: "
          f"{malloc_tuned}")
    cfg = MapConfig()
    spi = cfg.n_rays * cfg.samples_per_ray
    print(f"default MapConfig: {cfg.n_rays} rays x ({cfg.n_stratified}+{cfg.n_surface}) samples "
          f"= {spi} field samples/iteration, T=2^{cfg.log2_hashmap_size}, "
          f"smoothness lattice {cfg.smooth_lattice}^3")
    cpu = torch.device("cpu")
    for stage, shape in (("decoder", backend.decoder_shape(cfg)), ("grid", backend.grid_shape(cfg)),
                         ("objective", backend.objective_shape(cfg))):
        print("backend " + backend.select(stage, shape, cpu, remeasure=args.remeasure).describe())

    def line(name: str, wall: float, cpu_s: float | None = None) -> None:
        extra = f"  {spi / cpu_s:12,.0f} samples/CPU-s" if cpu_s else ""
        print(f"{name:34s} {wall * 1e3:7.1f} ms/iteration  {spi / wall:12,.0f} samples/s wall"
              f"{extra}")

    if args.stages:
        print(f"stages alone, 32,768 samples, best of 30, {torch.get_num_threads()} thread(s):")
        for ln in stage_times():
            print(ln)
    m = build(native=True)
    mt = build(native=False)

    def opt_step() -> None:
        m.optimizer_step(m.loss_and_grad()[1])

    # optimised and naive interleaved (the goal is their ratio): 5 rounds
    rounds = 5
    res = interleaved({"opt": (opt_step, max(1, args.iters // rounds)),
                       "naive": (naive_step(mt), max(1, args.iters // (3 * rounds)))}, rounds)
    wall, cpu_s = res["opt"]
    wall_n, cpu_n = res["naive"]
    print(f"interleaved, {rounds} rounds, median per iteration; load average now "
          f"{os.getloadavg()[0]:.2f}:")
    line(f"optimised (auto: decoder {m.decoders.backend}, grid "
         f"{'c' if m.grid_native else 'torch'})", wall, cpu_s)
    line("naive per-level torch grid", wall_n, cpu_n)
    print(f"RATIO optimised / naive per-level torch: {wall_n / wall:.1f}x wall, "
          f"{cpu_n / cpu_s:.1f}x CPU time (goal >= 15x)")
    print(f"SAMPLES/S optimised: {spi / wall:,.0f} wall on {torch.get_num_threads()} thread(s) "
          f"(goal >= 1,000,000 on 2 threads)")
    forced = {}
    for dec in ("c", "torch"):
        mf = build(True, decoder_backend=dec, grid_backend="c")
        if mf.decoders.backend == dec and mf.grid_native:
            forced[dec] = time_iters(mf, max(3, args.iters // 3))
            line(f"forced decoder {dec}, grid c", *forced[dec])
    wall_t, cpu_t = time_iters(mt, max(3, args.iters // 3))
    line("pure-torch path (native=False)", wall_t, cpu_t)
    print(f"RATIO optimised / pure-torch path:       {wall_t / wall:.1f}x (not interleaved)")
    for dec, (w_f, _) in forced.items():
        print(f"RATIO forced decoder {dec} / optimised:     {w_f / wall:.2f} (not interleaved)")
    if args.breakdown:
        print(f"where an optimised iteration's wall time goes (40 iterations, in place, "
              f"load average {os.getloadavg()[0]:.2f}):")
        for ln in breakdown():
            print(ln)
    print("agreement with the pure-torch autograd reference (one batch, default config):")
    for ln in agreement():
        print(ln)
    mem = m.memory_bytes()
    print(f"theta {mem['theta']:,} B; optimiser state (Adam m, v) {mem['optimizer']:,} B; "
          f"visits {mem['visits']:,} B; grad buffer {mem['grad']:,} B; "
          f"keyframe rays {mem['keyframes']:,} B")
    rss_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(f"peak RSS of this process (all maps + torch): {rss_kb / 1024:.0f} MiB")
    print(f"load average at end: {os.getloadavg()[0]:.2f}")
    print(machine_info())


if __name__ == "__main__":
    main()
