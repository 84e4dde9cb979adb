"""The compiled training-ray sampler (render.sample_points, csrc/mapkernels.c ray_samples) is
bit-identical to the torch path (render.sample_depths, o + d z, normalisation): same jitter
draws, same sample depths, same normalised positions, on rays with and without depth,
positions outside the bounds (clamped), with and without jitter and without surface samples."""
from __future__ import annotations

import pytest
import torch

from ramensim.agents.map import _native
from ramensim.agents.map.render import sample_points

pytestmark = pytest.mark.skipif(_native.get_lib() is None, reason="native kernels unavailable")


def _rows(R: int, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    o = torch.rand(R, 3, generator=g) * 4 - 1  # some outside the [0, 3]^3 bounds
    d = torch.nn.functional.normalize(torch.randn(R, 3, generator=g), dim=1)
    rgb = torch.rand(R, 3, generator=g)
    depth = torch.rand(R, generator=g) * 3
    depth[::4] = 0.0  # no depth: surface samples spread over [near, far]
    depth[1] = 0.05  # surface samples reaching below near
    return torch.cat([o, d, rgb, depth[:, None]], dim=1)


@pytest.mark.parametrize("n_strat, n_surf, jitter", [(24, 8, True), (5, 3, False), (7, 0, True)])
def test_compiled_sampler_is_bit_identical(n_strat, n_surf, jitter):
    rows = _rows(203, n_strat)
    lo, ext = torch.zeros(3), torch.full((3,), 3.0)
    out = []
    for native in (False, True):
        for threads in ((1,) if not native else (1, 3)):
            g = torch.Generator().manual_seed(7) if jitter else None
            z, xn = sample_points(rows, n_strat, n_surf, 0.1, 5.0, 0.2, g, lo, ext, native, threads)
            after = torch.rand(1, generator=g) if jitter else None  # same draws consumed
            out.append((z, xn, after))
    ref = out[0]
    assert float(ref[1].min()) == 0.0 and float(ref[1].max()) == 1.0  # clamping exercised
    for z, xn, after in out[1:]:
        assert torch.equal(z, ref[0]) and torch.equal(xn, ref[1])
        assert (after is None and ref[2] is None) or torch.equal(after, ref[2])


def test_non_finite_depth_takes_the_torch_path():
    rows = _rows(16, 3)
    rows[2, 9] = float("nan")
    lo, ext = torch.zeros(3), torch.full((3,), 3.0)
    a = sample_points(rows, 6, 3, 0.1, 5.0, 0.2, torch.Generator().manual_seed(1), lo, ext, False)
    b = sample_points(rows, 6, 3, 0.1, 5.0, 0.2, torch.Generator().manual_seed(1), lo, ext, True)
    assert bool(torch.isnan(a[0][2]).any()) and not bool(torch.isnan(a[0][3]).any())
    for x, y in zip(a, b):
        assert torch.equal(torch.nan_to_num(x), torch.nan_to_num(y))
