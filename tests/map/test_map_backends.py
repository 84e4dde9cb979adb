"""Every backend the selector (agents/map/backend.py) can pick, on every thread count it
tries, gives the same loss and gradients as the pure-torch autograd reference on a tiny
batch: a faster path can never be a wrong one. Also: the AVX2 (x86-64-v3) build of the C
kernels agrees as well, forcing works, and the choice is cached and read back."""
from __future__ import annotations

import functools
import json
import shutil

import numpy as np
import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, _native, synthetic
from ramensim.agents.map import backend as B
from ramensim.agents.map.decoders import KEYS, DecoderKernel, Decoders, init_decoders

TINY = dict(n_levels=4, log2_hashmap_size=10, n_rays=64, n_stratified=6, n_surface=3,
            smooth_lattice=4, geo_hidden=16, color_hidden=16, geo_feat_dim=7, oneblob_bins=4)
NATIVE = _native.get_lib() is not None


def _map(cfg: MapConfig, train_decoders: bool = False) -> NeuralMap:
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1),
                  torch.Generator().manual_seed(2), train_decoders=train_decoders)
    for i, f in enumerate(synthetic.frames(3, 40, 30)):
        m.add_frame(f, keyframe=(i % 2 == 0))
    return m


@functools.cache
def _reference() -> tuple[dict[str, float], torch.Tensor]:
    """Pure torch: fused torch hash grid, decoders through autograd (no hand-written
    backward, no compiled code)."""
    m = _map(MapConfig(**TINY, native=False), train_decoders=True)
    assert m.decoders.backend == "autograd" and not m.grid_native
    scal, grad = m.loss_and_grad()
    return scal, grad.clone()


def _variants() -> list[tuple[str, str, str, int]]:
    out = []
    for dec in B.CANDIDATES["decoder"]:
        for grid in B.CANDIDATES["grid"]:
            for render in B.CANDIDATES["objective"]:
                for t in B.thread_options():
                    out.append((dec, grid, render, t))
    return out


@pytest.mark.parametrize("dec, grid, render, threads", _variants())
def test_every_backend_matches_reference(dec, grid, render, threads):
    assert set(B.CANDIDATES) == set(B.STAGES)  # a new stage must be added to this test
    shape = B.decoder_shape(MapConfig(**TINY))
    if "c" in (dec, grid, render) and not NATIVE:
        pytest.skip("native kernels unavailable (no C compiler)")
    if dec == "c" and _native.get_mlp_lib(*shape) is None:
        pytest.skip("fused decoder kernel unavailable")
    ref_s, ref_g = _reference()
    m = _map(MapConfig(**TINY, decoder_backend=dec, grid_backend=grid, objective_backend=render))
    assert m.decoders.backend == dec and m.grid_native == (grid == "c")
    assert m.objective_backend == render
    m.decoders.kernel.threads = threads
    m.grid_threads = threads if grid == "c" else 0
    m.torch_threads = threads
    s, g = m.loss_and_grad()
    for k in ref_s:
        assert s[k] == pytest.approx(ref_s[k], rel=1e-5, abs=1e-7), k
    assert g.abs().max() > 0
    scale = float(ref_g.abs().max())
    assert float((g - ref_g).abs().max()) <= 1e-5 * scale, (dec, grid, render, threads)


@pytest.mark.parametrize("dec", B.CANDIDATES["decoder"])
def test_map_sdf_query_equals_sdf_and_color(dec):
    if dec == "c" and (not NATIVE or _native.get_mlp_lib(*B.decoder_shape(MapConfig(**TINY))) is None):
        pytest.skip("fused decoder kernel unavailable")
    m = _map(MapConfig(**TINY, decoder_backend=dec, chunk=1024))
    lo, hi = (np.asarray(b, dtype=np.float32) for b in synthetic.bounds())
    pts = np.random.default_rng(5).uniform(lo, hi, size=(3000, 3)).astype(np.float32)
    sdf, _ = m.sdf_and_color(pts)
    assert (sdf != 0).any()
    assert (m.sdf(pts) == sdf).all()  # bit-identical, every chunk


@pytest.mark.parametrize("dec", B.CANDIDATES["decoder"])
def test_map_sdf_grid_equals_sdf_on_the_grid_points(dec):
    """The grid query (per-axis normalisation and OneBlob, gathered) gives what the point query
    gives on the points extract_mesh builds; meshes extracted both ways are the same."""
    from ramensim.evaluation.mesh import extract_mesh, grid_shape

    if dec == "c" and (not NATIVE or _native.get_mlp_lib(*B.decoder_shape(MapConfig(**TINY))) is None):
        pytest.skip("fused decoder kernel unavailable")
    m = _map(MapConfig(**TINY, decoder_backend=dec, chunk=1024))
    for _ in range(5):
        m.optimizer_step(m.loss_and_grad()[1])
    bounds = np.asarray(synthetic.bounds(), dtype=np.float64)
    origin, voxel = bounds[0] + 0.013, 0.11
    shape = grid_shape(bounds, voxel)
    ijk = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
    pts = (origin + ijk * voxel).astype(np.float32)
    grid = m.sdf_grid(origin, voxel, shape)
    assert grid.shape == shape and (grid > 0).any() and (grid < 0).any()
    if dec == "c":  # per sample: bit for bit
        assert np.array_equal(grid.reshape(-1), m.sdf(pts))
    else:           # torch's products depend on the batch: rounding only
        np.testing.assert_allclose(grid.reshape(-1), m.sdf(pts), rtol=0, atol=1e-6)
    a = extract_mesh(m.sdf, bounds, voxel, grid_fn=m.sdf_grid)
    b = extract_mesh(m.sdf, bounds, voxel)
    assert len(a.faces) > 0
    if dec == "c":
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


def _kernel_check(backend: str, cfg: MapConfig) -> None:
    w = init_decoders(cfg, torch.Generator().manual_seed(3))
    ref = Decoders(w, cfg, torch.device("cpu"), trainable=True)
    k = DecoderKernel(backend, w, ref.grid_dim, ref.pe_dim, torch.device("cpu"))
    g = torch.Generator().manual_seed(4)
    n = 203  # not a multiple of 8 or 16 lanes
    feats = torch.randn(n, ref.grid_dim, generator=g) * 0.3
    pe = torch.rand(n, ref.pe_dim, generator=g)
    ds, dr = torch.randn(n, generator=g), torch.randn(n, 3, generator=g)
    fq = feats.clone().requires_grad_(True)
    s_ref, r_ref = ref.forward(fq, pe)
    (g_ref,) = torch.autograd.grad((s_ref * ds).sum() + (r_ref * dr).sum(), fq)
    s, r = k.forward(feats, pe)
    assert torch.allclose(s, s_ref.detach(), atol=1e-5)
    assert torch.allclose(r, r_ref.detach(), atol=1e-5)
    g_recomputed = k.backward(feats, pe, ds, dr)
    assert torch.allclose(g_recomputed, g_ref, atol=1e-5)
    with pytest.raises(RuntimeError):  # forward without keep: no masks to read
        k.backward(feats, pe, ds, dr, kept=True)
    # a training step keeps the forward's ReLU masks: same outputs, bit-identical backward
    s2, r2 = k.forward(feats, pe, keep=True)
    assert torch.equal(s2, s) and torch.equal(r2, r)
    assert torch.equal(k.backward(feats, pe, ds, dr, kept=True), g_recomputed)
    # the SDF alone (mesh extraction) is bit-identical to the forward's on the same batch (the
    # C kernel per sample; torch's matrix products may round differently for other batch sizes)
    assert torch.equal(k.sdf(feats, pe), s)
    if backend == "c":
        assert torch.equal(k.sdf(feats[:5], pe[:5]), s[:5])


@pytest.mark.parametrize("backend", ["c", "torch"])
def test_decoder_kernels_match_autograd(backend):
    if backend == "c" and not NATIVE:
        pytest.skip("native kernels unavailable")
    _kernel_check(backend, MapConfig())


@pytest.mark.skipif(shutil.which(_native._compiler()[0]) is None, reason="no C compiler")
def test_avx2_build_of_the_decoder_matches(tmp_path, monkeypatch):
    """The 8-lane (AVX2, x86-64-v3) build is a different object with different code; it
    must agree too. Skipped where the CPU lacks AVX2."""
    if "avx2" not in _native.cpu_flags() or "fma" not in _native.cpu_flags():
        pytest.skip("CPU without AVX2 + FMA")
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("RAMENSIM_MARCH", "x86-64-v3")
    monkeypatch.setattr(_native, "_mlp_libs", {})
    _kernel_check("c", MapConfig())
    assert list((tmp_path / "native").glob("mapmlp_*.so"))


def test_choice_is_cached_and_read_back(tmp_path, monkeypatch):
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(B, "_memo", {})
    shape = B.decoder_shape(MapConfig(**TINY))
    cpu = torch.device("cpu")
    first = B.select("decoder", shape, cpu)
    if first.how == "only candidate":
        pytest.skip("one decoder candidate here: nothing to measure")
    assert first.how == "measured" and first.backend in B.CANDIDATES["decoder"]
    assert set(first.timings_ms) == {f"{n}@{t}" for n in B.CANDIDATES["decoder"]
                                     for t in B.thread_options()}
    files = list((tmp_path / "native").glob("backend_decoder_*.json"))
    assert len(files) == 1
    data = json.loads(files[0].read_text())
    assert data["backend"] == first.backend and data["threads"] == first.threads
    monkeypatch.setattr(B, "_memo", {})
    again = B.select("decoder", shape, cpu)
    assert again.how == "cache" and (again.backend, again.threads) == (first.backend, first.threads)


def test_forcing_and_native_off():
    cfg = MapConfig(**TINY, decoder_backend="torch", grid_backend="torch", objective_backend="torch")
    m = _map(cfg)
    assert m.decoders.backend == "torch" and not m.grid_native and m.objective_backend == "torch"
    assert m.decoders.choice.how.startswith("forced")
    assert m.objective_choice.how.startswith("forced")
    m2 = _map(MapConfig(**TINY, native=False))
    assert m2.decoders.backend == "torch" and not m2.grid_native and not m2.native
    assert m2.objective_backend == "torch"
    with pytest.raises(ValueError):
        MapConfig(decoder_backend="fortran")


def test_weights_unchanged_by_kernel():
    cfg = MapConfig(**TINY)
    w = init_decoders(cfg, torch.Generator().manual_seed(5))
    d = Decoders(w, cfg, torch.device("cpu"))
    for k in KEYS:
        assert torch.equal(d.weights()[k], w[k])


def test_doctor_prints_the_choice(tmp_path, monkeypatch, capsys):
    from ramensim.cli import main

    monkeypatch.setattr(B, "_memo", {})
    monkeypatch.setattr(B, "_cache_path", lambda stage, key: tmp_path / f"{stage}_{key}.json")
    monkeypatch.setattr(B, "measure", lambda stage, shape, device, names, **kw:
                        {f"{n}@1": 0.001 * (i + 1) for i, n in enumerate(names)})
    threads = torch.get_num_threads()
    try:
        assert main(["doctor", "--threads", "1"]) == 0
    finally:
        torch.set_num_threads(threads)
    out = capsys.readouterr().out
    assert "decoder:" in out and "grid:" in out and "objective:" in out and "-march=" in out
    if NATIVE:
        assert "decoder: c on 1 thread(s) (measured) [c@1 1.00 ms" in out
    assert main(["doctor", "--threads", "-1"]) == 2
    assert "--threads" in capsys.readouterr().err


def test_map_threads_fixes_the_thread_count():
    m = _map(MapConfig(**TINY, threads=1, decoder_backend="torch", grid_backend="c"
                       if NATIVE else "torch"))
    assert m.decoders.choice.threads == 1 and m.decoders.kernel.threads == 1
    assert m.torch_threads == 1
    assert m.grid_choice.threads == 1
    assert "map.threads" in m.decoders.choice.how


def test_more_threads_must_be_clearly_faster():
    """1 thread wins a near tie (on a loaded machine extra OpenMP threads spin at barriers);
    N threads win when at least MULTI_THREAD_GAIN faster; on a tie, candidate order."""
    assert B.pick({"c@1": 1.00, "c@2": 0.95, "torch@1": 2.0, "torch@2": 1.9}) == ("c", 1)
    assert B.pick({"c@1": 1.00, "c@2": 0.55, "torch@1": 2.0, "torch@2": 1.1}) == ("c", 2)
    assert B.pick({"c@1": 3.00, "c@2": 2.90, "torch@1": 2.0, "torch@2": 0.5}) == ("torch", 2)
    assert B.pick({"c@1": 1.00, "torch@1": 1.00}) == ("c", 1)
    assert B.pick({"torch@2": 1.0}) == ("torch", 2)


def test_a_choice_cached_without_the_c_kernels_is_not_reused(tmp_path, monkeypatch):
    """A process that could not build the kernels measured torch alone and cached 'torch';
    a process that has them measures again instead of keeping the slower path."""
    if not NATIVE:
        pytest.skip("native kernels unavailable")
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(B, "_memo", {})
    shape = B.grid_shape(MapConfig(**TINY))
    cpu = torch.device("cpu")
    key = B.cache_key("grid", shape, cpu)
    B._write_cache("grid", key, {"schema": B.SCHEMA, "stage": "grid", "backend": "torch",
                                 "threads": 1, "timings_ms": {"torch@1": 80.0}})
    monkeypatch.setattr(B, "measure", lambda stage, shape, device, names, **kw:
                        {f"{n}@1": 0.001 * (i + 1) for i, n in enumerate(names)})
    ch = B.select("grid", shape, cpu)
    assert ch.how == "measured" and ch.backend == "c"
    monkeypatch.setattr(B, "_memo", {})
    again = B.select("grid", shape, cpu)  # the new measurement is what the cache holds now
    assert again.how == "cache" and again.backend == "c"
