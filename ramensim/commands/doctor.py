"""``ramensim doctor [SCENARIO]``: the machine, the map's compiled kernels, and the backend the
map uses for each hot stage on this machine, with the timings that chose it."""
from __future__ import annotations

import argparse
import os
import platform

from ramensim.core.errors import InputError


def add_parser(sub) -> None:
    p = sub.add_parser("doctor", help="show the map's backend choice on this machine",
                       description=__doc__)
    p.add_argument("scenario", nargs="?", default=None,
                   help="scenario YAML whose map settings to use (default: the default MapConfig)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario field by dotted key (repeatable)")
    p.add_argument("--threads", type=int, default=0,
                   help="torch/OpenMP threads to measure with (default: torch's count)")
    p.add_argument("--remeasure", action="store_true",
                   help="time the candidates again and overwrite the cached choice")
    p.add_argument("--speed-s", type=float, default=2.0, metavar="SECONDS",
                   help="seconds spent timing whole mapping iterations for the samples/s figure "
                        "(default 2; 0 skips it)")
    p.set_defaults(func=run)


def _map_config(args: argparse.Namespace):
    from ramensim.agents.map import MapConfig

    if args.scenario is None:
        if args.overrides:
            raise InputError("ramensim doctor: --set needs a scenario file; name one "
                             "(e.g. scenarios/office_3agents.yaml).")
        return MapConfig()
    from ramensim.config import load_scenario

    return load_scenario(args.scenario, args.overrides).map


def run(args: argparse.Namespace) -> int:
    if not 0 <= args.speed_s <= 600:
        raise InputError(f"ramensim doctor: --speed-s = {args.speed_s}; expected 0 (skip the speed "
                         f"measurement) to 600 seconds.")
    if args.threads < 0:
        raise InputError(f"ramensim doctor: --threads = {args.threads}; expected 0 (torch's "
                         f"default) or a positive thread count.")
    cfg = _map_config(args)
    import torch

    from ramensim.agents.map import _native, backend

    if args.threads:
        torch.set_num_threads(args.threads)
    flags = _native.cpu_flags()
    model = next((ln.split(":", 1)[1].strip() for ln in _native._cpu_model().splitlines()
                  if ln.startswith("model name")), platform.processor() or platform.machine())
    simd = [f for f in ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512bw", "avx512vl",
                        "avx512_bf16", "amx_tile") if f in flags]
    print(f"machine: {model}; {os.cpu_count()} logical cores; load average "
          f"{os.getloadavg()[0]:.2f}")
    print(f"SIMD: {' '.join(simd) or 'unknown'}")
    print(f"python {platform.python_version()}; torch {torch.__version__}, "
          f"{torch.get_num_threads()} threads")
    print(f"C kernels: compiler {' '.join(_native._compiler())}, -march={_native.march()} "
          f"(RAMENSIM_MARCH), cache {_native.cache_dir()}")
    lib = _native.get_lib()
    print(f"  mapkernels: {'built' if lib is not None else 'UNAVAILABLE (pure-torch path)'}")
    shape = backend.decoder_shape(cfg)
    mlp = _native.get_mlp_lib(*shape) if lib is not None else None
    print(f"  mapmlp {shape}: {'built' if mlp is not None else 'UNAVAILABLE'}")
    from ramensim.agents.consensus import _native as consensus_native
    from ramensim.evaluation import _native as evaluation_native

    for name, mod, fallback in (("ramenedge", consensus_native, "torch ops"),
                                ("visibility", evaluation_native, "numpy path")):
        built = mod.get_lib() is not None
        print(f"  {name}: {'built' if built else f'UNAVAILABLE ({fallback})'}")
    from ramensim.commands.doctor_backends import backend_lines, cache_health, measure_map_speed

    for line in cache_health(_native.cache_dir()):
        print(line)
    print("backends in use:")
    for line in backend_lines(cfg):
        print(f"  {line}")
    from ramensim.agents.map.config import resolve_device

    if resolve_device(cfg.device, check=False).type != "cpu":
        print(f"map.device = {cfg.device}: the CPU backends below apply only when the map "
              f"runs on the CPU")
    cpu = torch.device("cpu")
    print(f"map backends (map.native = {cfg.native}, map.decoder_backend = "
          f"{cfg.decoder_backend}, map.grid_backend = {cfg.grid_backend}, "
          f"map.objective_backend = {cfg.objective_backend}):")
    for stage, shp, key in (("decoder", shape, cfg.decoder_backend),
                            ("grid", backend.grid_shape(cfg), cfg.grid_backend),
                            ("objective", backend.objective_shape(cfg), cfg.objective_backend)):
        forced = key if cfg.native else "torch"
        ch = backend.select(stage, shp, cpu, forced, remeasure=args.remeasure,
                            threads=cfg.threads)
        if forced != "auto" and args.remeasure:
            ms = backend.measure(stage, shp, cpu, [n for n in backend.CANDIDATES[stage]
                                                   if n not in ch.unavailable])
            ch.timings_ms = {k: v * 1e3 for k, v in ms.items()}
        print(f"  {ch.describe()}")
    print("(timings: median of 7 interleaved runs on this machine; they are cached per CPU model "
          "and flags, torch version, -march target, thread count and shape: --remeasure times "
          "them again, e.g. on an idle machine)")
    if args.speed_s > 0:
        sp = measure_map_speed(cfg, args.speed_s)
        print(f"map speed: {sp.samples_per_s:,.0f} field samples/s (wall clock; {sp.ms_per_iter:.1f} ms per "
              f"mapping iteration of {sp.samples_per_iter:,} samples = map.n_rays x samples per ray, "
              f"median of {sp.iters}; forward, backward and Adam step with the backends above; "
              f"load average {os.getloadavg()[0]:.2f})")
    return 0
