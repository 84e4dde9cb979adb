"""Fast hash-grid / OneBlob / decoder kernels against slow, obviously-correct references."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from ramensim.agents.map import _native
from ramensim.agents.map.config import MapConfig
from ramensim.agents.map.decoders import Decoders, init_decoders
from ramensim.agents.map.hashgrid import GridSpec, accumulate_grad, encode, encode_torch, hash_encode
from ramensim.agents.map.oneblob import oneblob, oneblob_torch

NATIVE = _native.get_lib() is not None


def reference_encode(xn: torch.Tensor, table: torch.Tensor, spec: GridSpec) -> torch.Tensor:
    """Loops over levels and corners, formulas exactly as docs/ALGORITHM.md section 1."""
    T = spec.T
    tab = table.reshape(spec.n_levels, T, spec.features)
    outs = []
    for lv in range(spec.n_levels):
        scale = spec.scales[lv]
        res = int(spec.res[lv])
        pos = xn * scale + 0.5
        cell = torch.floor(pos)
        frac = pos - cell
        cell = cell.long()
        acc = torch.zeros(xn.shape[0], spec.features)
        for bx in (0, 1):
            for by in (0, 1):
                for bz in (0, 1):
                    cx, cy, cz = cell[:, 0] + bx, cell[:, 1] + by, cell[:, 2] + bz
                    if res ** 3 <= T:
                        idx = cx + cy * res + cz * res * res
                    else:
                        idx = (cx * 1) ^ (cy * 2654435761) ^ (cz * 805459861)
                        idx = idx & 0xFFFFFFFF  # uint32
                    idx = idx % T
                    wx = frac[:, 0] if bx else 1 - frac[:, 0]
                    wy = frac[:, 1] if by else 1 - frac[:, 1]
                    wz = frac[:, 2] if bz else 1 - frac[:, 2]
                    acc = acc + (wx * wy * wz)[:, None] * tab[lv][idx]
        outs.append(acc)
    return torch.cat(outs, dim=1)


def reference_oneblob(xn: torch.Tensor, n: int) -> torch.Tensor:
    def fq(s):
        u = s * n
        return min(max(15 / 16 * u * (1 - 2 / 3 * u ** 2 + 1 / 5 * u ** 4) + 0.5, 0.0), 1.0)

    def C(s):
        return sum(fq(s + m) for m in (-1, 0, 1))

    out = np.zeros((xn.shape[0], 3 * n))
    for i, row in enumerate(xn.double().numpy()):
        for a in range(3):
            for k in range(n):
                out[i, a * n + k] = C((k + 1) / n - row[a]) - C(k / n - row[a])
    return torch.as_tensor(out, dtype=torch.float32)


@pytest.fixture(scope="module")
def spec() -> GridSpec:
    # log2_T = 12: levels 0..2 dense, the rest hashed (both index kinds exercised)
    return GridSpec.build(n_levels=8, features=2, log2_T=12, base_resolution=8, finest_resolution=90)


def _points(n: int, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    x = torch.rand(n, 3, generator=g)
    x[:4] = torch.tensor([[0, 0, 0], [1, 1, 1], [1, 0, 0.5], [0.999999, 0.5, 0]])  # edges
    return x


def test_grid_spec_follows_formulas():
    s = GridSpec.build(16, 2, 15, 16, 155.0)
    b = math.exp((math.log(155) - math.log(16)) / 15)
    assert s.scales[0].item() == pytest.approx(15.0)
    assert s.scales[15].item() == pytest.approx(16 * b ** 15 - 1, rel=1e-6)
    assert s.res[3].item() == math.ceil(16 * b ** 3 - 1) + 1
    assert s.dense.tolist() == [int(int(r) ** 3 <= 2 ** 15) for r in s.res]
    assert s.n_params == 16 * 2 ** 15 * 2


@pytest.mark.parametrize("native", [False, True])
def test_encoding_matches_reference(spec, native):
    if native and not NATIVE:
        pytest.skip("native kernels unavailable")
    x = _points(300, 0)
    table = torch.rand(spec.n_params, generator=torch.Generator().manual_seed(1)) * 2 - 1
    ref = reference_encode(x, table, spec)
    got = encode(x, table, spec, native=native)
    assert got.shape == (300, spec.out_dim)
    assert torch.allclose(got, ref, atol=1e-6, rtol=0)


@pytest.mark.parametrize("native", [False, True])
def test_encoding_gradient_matches_reference(spec, native):
    if native and not NATIVE:
        pytest.skip("native kernels unavailable")
    x = _points(200, 2)
    base = torch.rand(spec.n_params, generator=torch.Generator().manual_seed(3))
    w = torch.randn(200, spec.out_dim, generator=torch.Generator().manual_seed(4))
    t_ref = base.clone().requires_grad_(True)
    (reference_encode(x, t_ref, spec) * w).sum().backward()
    t_fast = base.clone().requires_grad_(True)
    (hash_encode(x, t_fast, spec, native=native) * w).sum().backward()
    assert torch.allclose(t_fast.grad, t_ref.grad, atol=1e-6, rtol=0)
    assert int((t_ref.grad != 0).sum()) > 100


@pytest.mark.skipif(not NATIVE, reason="native kernels unavailable")
def test_native_and_torch_paths_agree_at_default_size():
    spec = GridSpec.build(16, 2, 15, 16, 160.0)
    x = torch.rand(4000, 3, generator=torch.Generator().manual_seed(5))
    table = torch.rand(spec.n_params, generator=torch.Generator().manual_seed(6)) - 0.5
    assert torch.allclose(encode(x, table, spec, True), encode_torch(x, table, spec), atol=1e-6)
    g = torch.randn(4000, spec.out_dim, generator=torch.Generator().manual_seed(7))
    a = torch.zeros(spec.n_params)
    b = torch.zeros(spec.n_params)
    accumulate_grad(x, g, spec, a, native=True)
    accumulate_grad(x, g, spec, b, native=False)
    assert torch.allclose(a, b, atol=1e-5)
    assert torch.equal(a != 0, b != 0)


@pytest.mark.skipif(not NATIVE, reason="native kernels unavailable")
def test_native_grid_other_feature_counts_several_blocks_and_threads():
    """The C kernels' general-F path, more points than one block (4096) and than a whole
    number of vector lanes, and the same bits on 1 and 2 threads (levels own their rows)."""
    spec3 = GridSpec.build(n_levels=5, features=3, log2_T=10, base_resolution=4,
                           finest_resolution=60)
    x = _points(9001, 8)
    table = torch.rand(spec3.n_params, generator=torch.Generator().manual_seed(9)) * 2 - 1
    assert torch.allclose(encode(x, table, spec3, native=True), reference_encode(x, table, spec3),
                          atol=1e-6, rtol=0)
    w = torch.randn(9001, spec3.out_dim, generator=torch.Generator().manual_seed(10))
    t_ref = table.clone().requires_grad_(True)
    (reference_encode(x, t_ref, spec3) * w).sum().backward()
    a = torch.zeros(spec3.n_params)
    accumulate_grad(x, w, spec3, a, native=True)
    assert torch.allclose(a, t_ref.grad, atol=1e-4, rtol=1e-5)
    spec2 = GridSpec.build(16, 2, 15, 16, 160.0)
    t2 = torch.rand(spec2.n_params, generator=torch.Generator().manual_seed(11)) - 0.5
    g2 = torch.randn(9001, spec2.out_dim, generator=torch.Generator().manual_seed(12))
    outs, grads = [], []
    for threads in (1, 2):
        outs.append(encode(x, t2, spec2, True, threads=threads))
        grads.append(torch.zeros(spec2.n_params))
        accumulate_grad(x, g2, spec2, grads[-1], native=True, threads=threads)
    assert torch.equal(outs[0], outs[1]) and torch.equal(grads[0], grads[1])


@pytest.mark.parametrize("native", [False, True])
def test_oneblob_matches_reference(native):
    if native and not NATIVE:
        pytest.skip("native kernels unavailable")
    x = _points(40, 8)
    ref = reference_oneblob(x, 16)
    got = oneblob(x, 16, native=native) if native else oneblob_torch(x, 16)
    assert torch.allclose(got, ref, atol=1e-6)
    # a blob: each axis sums to one (periodic kernel of unit mass)
    assert torch.allclose(got.reshape(40, 3, 16).sum(-1), torch.ones(40, 3), atol=1e-5)


@pytest.mark.skipif(not NATIVE, reason="native kernels unavailable")
@pytest.mark.parametrize("bins", [2, 4, 16, 32])
def test_native_oneblob_is_bit_identical_to_torch(bins):
    """The kernel's fast path (one polynomial per bin edge away from the periodic wrap) gives
    exactly the full three-term sum, which the torch path computes: random points, and every
    float within 200 ulps of the fast path's bounds 1.3/bins and 1 - 1.3/bins."""
    g = torch.Generator().manual_seed(3)
    near = []
    for v in (1.3 / bins, 1.0 - 1.3 / bins, 1.25 / bins, 1.0 - 1.25 / bins, 0.0, 1.0):
        t = torch.tensor(v, dtype=torch.float32)
        up, down = t.clone(), t.clone()
        for _ in range(200):
            up, down = torch.nextafter(up, torch.tensor(2.0)), torch.nextafter(down, torch.tensor(-1.0))
            near += [up, down]
    x = torch.cat([torch.rand(5000, 3, generator=g), torch.stack(near)[:, None].expand(-1, 3)]).contiguous()
    assert torch.equal(oneblob(x, bins, native=True), oneblob_torch(x, bins))
    # outside [0, 1] and non-finite (the full sum, lane by lane in the vectorised kernel),
    # mixed with ordinary values in one vector block
    odd = torch.tensor([-0.3, 1.7, float("nan"), float("inf"), -1e-7, 0.5, 1.0 + 1e-7, 0.2,
                        0.9, 0.01, -2.0, 0.99, float("-inf"), 0.4, 0.6, 3.0, 0.0, 0.7, 1.0])
    x = torch.stack([odd, odd.flip(0), odd.roll(3)], dim=1).contiguous()
    a, b = oneblob(x, bins, native=True), oneblob_torch(x, bins)
    assert torch.equal(torch.isnan(a), torch.isnan(b))
    assert torch.equal(torch.nan_to_num(a), torch.nan_to_num(b))


@pytest.mark.skipif(not NATIVE, reason="native kernels unavailable")
def test_fused_decoders_match_torch():
    cfg = MapConfig()
    w = init_decoders(cfg, torch.Generator().manual_seed(0))
    d = Decoders(w, cfg, torch.device("cpu"))
    assert d.fused
    g = torch.Generator().manual_seed(1)
    feats = torch.randn(1001, 32, generator=g)  # not a multiple of the 16-sample block
    pe = oneblob(torch.rand(1001, 3, generator=g), 16)
    sdf_f, raw_f = d.fused_forward(feats, pe)
    sdf_t, raw_t = d.forward(feats, pe)
    assert torch.allclose(sdf_f, sdf_t, atol=1e-5) and torch.allclose(raw_f, raw_t, atol=1e-5)
    ds, dr = torch.randn(1001, generator=g), torch.randn(1001, 3, generator=g)
    fq = feats.clone().requires_grad_(True)
    s, r = d.forward(fq, pe)
    (gt,) = torch.autograd.grad((s * ds).sum() + (r * dr).sum(), fq)
    assert torch.allclose(d.fused_backward(feats, pe, ds, dr), gt, atol=1e-5)


@pytest.mark.skipif(not NATIVE, reason="native kernels unavailable")
def test_avx2_build_of_oneblob_is_bit_identical(tmp_path, monkeypatch):
    """The AVX2 (x86-64-v3) build vectorises OneBlob differently (8 lanes, the clamp as
    masks); it must give the same bits as the torch path too. Skipped without AVX2."""
    if "avx2" not in _native.cpu_flags() or "fma" not in _native.cpu_flags():
        pytest.skip("CPU without AVX2 + FMA")
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("RAMENSIM_MARCH", "x86-64-v3")
    monkeypatch.setattr(_native, "_lib", None)
    monkeypatch.setattr(_native, "_tried", False)
    g = torch.Generator().manual_seed(4)
    x = torch.cat([torch.rand(3001, 3, generator=g), torch.tensor([[-0.5, 1.5, 0.999]])])
    for bins in (4, 16, 32):
        assert torch.equal(oneblob(x, bins, native=True), oneblob_torch(x, bins))
    assert list((tmp_path / "native").glob("mapkernels_*.so"))
