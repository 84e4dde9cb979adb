"""The SDF grid query's hash-grid kernel (``hash_fwd_grid``, issue 71): the encoding of every
point of a regular grid straight from the per-axis coordinates is the point kernel's
(``hash_fwd``) on the gathered points, bit for bit, on dense and hashed levels, for row
lengths that are not a multiple of the vector width, several thread counts and F = 2 or 3;
and ``NeuralMap.sdf_grid`` through it equals the point query (``sdf``) bit for bit."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, _native, synthetic
from ramensim.agents.map.decoders import init_decoders
from ramensim.agents.map.hashgrid import GridSpec, encode, encode_grid

NATIVE = _native.get_lib() is not None
needs_native = pytest.mark.skipif(not NATIVE, reason="compiled map kernels unavailable")


def _axes(g: torch.Generator, n: tuple[int, int, int]) -> list[torch.Tensor]:
    """Sorted normalised coordinates per axis, with the ends 0 and 1 and a value past each
    (clamped positions are the normal case at the bounds)."""
    out = []
    for k in n:
        a = torch.sort(torch.rand(k, generator=g)).values
        a[0], a[-1] = 0.0, 1.0
        out.append(a)
    return out


@needs_native
@pytest.mark.parametrize("features,shape,threads", [(2, (3, 5, 37), 1), (2, (4, 7, 16), 2),
                                                    (3, (2, 3, 21), 1), (2, (1, 1, 1), 1)])
def test_grid_kernel_equals_the_point_kernel(features, shape, threads):
    spec = GridSpec.build(n_levels=8, features=features, log2_T=12, base_resolution=8, finest_resolution=90)
    assert spec.dense.any() and not spec.dense.all()  # both kinds of level
    g = torch.Generator().manual_seed(5)
    xa, ya, za = _axes(g, shape)
    table = torch.randn(spec.n_params, generator=g) * 0.3
    pts = torch.stack(torch.meshgrid(xa, ya, za, indexing="ij"), dim=-1).reshape(-1, 3).contiguous()
    ref = encode(pts, table, spec, native=True, threads=threads)
    got = encode_grid((xa, ya, za), table, spec, threads=threads)
    assert got.shape == ref.shape
    assert torch.equal(got, ref)


@needs_native
@pytest.mark.parametrize("batch", [1_000, 1 << 20])  # rows of y within a slab (ragged), several slabs
def test_sdf_grid_equals_the_point_query_bit_for_bit(batch, monkeypatch):
    from ramensim.agents.map import neural_map

    monkeypatch.setattr(neural_map, "GRID_BATCH", batch)
    cfg = MapConfig(n_levels=6, log2_hashmap_size=12, geo_hidden=16, color_hidden=16, geo_feat_dim=7,
                    oneblob_bins=8, n_rays=64, n_stratified=6, n_surface=3, smooth_lattice=4,
                    decoder_backend="c", grid_backend="c", chunk=1 << 20)
    m = NeuralMap(synthetic.bounds(), cfg, init_decoders(cfg, torch.Generator().manual_seed(0)),
                  torch.Generator().manual_seed(1), torch.Generator().manual_seed(2))
    if not (m.grid_native and m.decoders.backend == "c"):
        pytest.skip("C grid kernel or C decoder unavailable")
    for i, f in enumerate(synthetic.frames(3, 40, 30)):
        m.add_frame(f, keyframe=(i % 2 == 0))
    for _ in range(5):
        m.optimizer_step(m.loss_and_grad()[1])
    bounds = np.asarray(synthetic.bounds(), dtype=np.float64)
    origin, voxel = bounds[0] - 0.05, 0.07  # a grid reaching past the bounds: clamped coordinates too
    shape = tuple(int(v) for v in np.ceil((bounds[1] + 0.05 - origin) / voxel).astype(int) + 1)
    nz = shape[2]
    assert (batch < shape[1] * nz and batch % nz) or batch >= 2 * shape[1] * nz  # the path each case is for
    grid = m.sdf_grid(origin, voxel, shape)
    ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
    pts = (origin + ijk * voxel).astype(np.float32)
    assert (grid > 0).any() and (grid < 0).any()
    assert torch.equal(torch.from_numpy(grid.reshape(-1)), torch.from_numpy(m.sdf(pts)))
