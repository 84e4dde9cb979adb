"""The hash grid's corner reads with hardware gathers against lane by lane (issue 71: the SDF
grid of an evaluation, and the training's forward): the map kernels built twice, with
``GATHER_ROWS`` 1 (the default: AVX-512 gathers where the build targets AVX-512) and 0 (scalar
loads), each timed alternately in one process on

- ``hash_fwd``: a training batch's worth of random points (2,048 rays x 43 samples);
- ``hash_fwd_grid``: the house's evaluation grid (417 x 275 x 107 = 12.27 M points at 3 cm),

16 levels of 2^15 rows, 2 features, a seeded random table; CPU seconds of one thread, and a
check that both builds write the same bytes. On a machine without AVX-512 both builds are the
lane-by-lane code. Prints the machine.

    PYTHONPATH=. python benchmarks/bench_hash_rows.py [--repeats 5]
"""
from __future__ import annotations

import argparse
import statistics
import time

import torch

from benchmarks._machine import machine_info


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()

    from agents.map import _native
    from agents.map.hashgrid import GridSpec
    from ramensim.core.native import BASE_FLAGS, compile_shared, declare, with_march

    libs = {}
    for g in (1, 0):
        lib = compile_shared(_native.KERNEL_SOURCES, f"mapkernels_rows{g}", with_march(BASE_FLAGS),
                             defines={"GATHER_ROWS": g})
        declare(lib, _native.SIGNATURES)
        libs[g] = lib
    gen = torch.Generator().manual_seed(0)
    spec = GridSpec.build(16, 2, 15, 16, 600.0)
    table = torch.randn(16 * spec.T * 2, generator=gen) * 0.3
    pts = torch.rand(2048 * 43, 3, generator=gen)
    axes = [torch.linspace(0.02, 0.98, n) for n in (417, 275, 107)]
    n_grid = 417 * 275 * 107
    outs = {g: (torch.empty(len(pts), 32), torch.empty(n_grid, 32)) for g in libs}
    common = (16, 2, spec.T, spec.scales.data_ptr(), spec.res.data_ptr(), spec.dense.data_ptr())

    def fwd(g: int) -> None:
        libs[g].hash_fwd(pts.data_ptr(), len(pts), table.data_ptr(), *common, outs[g][0].data_ptr(), 1)

    def grid(g: int) -> None:
        libs[g].hash_fwd_grid(axes[0].data_ptr(), 417, axes[1].data_ptr(), 275, axes[2].data_ptr(), 107,
                              table.data_ptr(), *common, outs[g][1].data_ptr(), 1)

    cpu: dict[tuple[str, int], list[float]] = {}
    for r in range(args.repeats + 1):  # the first round warms up (page faults of the outputs)
        for g in ((1, 0) if r % 2 == 0 else (0, 1)):
            for name, fn, times in (("hash_fwd", fwd, 20), ("hash_fwd_grid", grid, 1)):
                t0 = time.process_time()
                for _ in range(times):
                    fn(g)
                if r:
                    cpu.setdefault((name, g), []).append((time.process_time() - t0) / times)
    print(machine_info(), "- kernels on 1 thread")
    for name in ("hash_fwd", "hash_fwd_grid"):
        a, b = statistics.median(cpu[(name, 1)]), statistics.median(cpu[(name, 0)])
        k = 0 if name == "hash_fwd" else 1
        same = torch.equal(outs[1][k], outs[0][k])
        print(f"{name}: gathers {a * 1e3:.2f} ms, lane by lane {b * 1e3:.2f} ms (CPU, median of {args.repeats}); "
              f"ratio {a / b:.3f}; outputs equal: {same}")


if __name__ == "__main__":
    main()
