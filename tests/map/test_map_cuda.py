"""The map on CUDA (``map.device: cuda``) computes what the map on the CPU computes: the same
samples (the jitter is drawn by the map's CPU generator on both, docs/ALGORITHM.md section 1),
the same loss terms (eq. 5-6) and gradient up to float rounding, the same visit counts, and
after a few Adam steps the same SDF. Skipped where torch sees no CUDA device (CI); run on a
GPU machine with ``pytest tests/map/test_map_cuda.py``."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, synthetic
from ramensim.agents.map.decoders import init_decoders
from test_map_backends import TINY

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="torch sees no CUDA device")


def _map(device: str) -> NeuralMap:
    # native=False on the CPU: the pure-torch path, the one CUDA runs (no compiled kernels)
    cfg = MapConfig(**TINY, device=device, native=False)
    dec = init_decoders(cfg, torch.Generator().manual_seed(0))
    m = NeuralMap(synthetic.bounds(), cfg, dec, torch.Generator().manual_seed(1),
                  torch.Generator().manual_seed(2))
    for i, f in enumerate(synthetic.frames(3, 40, 30)):
        m.add_frame(f, keyframe=(i % 2 == 0))
    return m


def test_cuda_map_matches_cpu_map_step_by_step():
    torch.backends.cuda.matmul.allow_tf32 = False  # fp32 products, as on the CPU
    cpu, gpu = _map("cpu"), _map("cuda")
    assert gpu.device.type == "cuda" and cpu.device.type == "cpu"
    for _ in range(5):
        s_c, g_c = cpu.loss_and_grad()
        s_g, g_g = gpu.loss_and_grad()
        for k in s_c:
            assert s_g[k] == pytest.approx(s_c[k], rel=1e-4, abs=1e-6), k
        scale = float(g_c.abs().max())
        assert scale > 0
        assert float((g_g.cpu() - g_c).abs().max()) <= 1e-4 * scale
        cpu.optimizer_step(g_c)
        gpu.optimizer_step(g_g)
    assert torch.equal(cpu.visits.cpu(), gpu.visits.cpu())
    lo, hi = (np.asarray(b, dtype=np.float32) for b in synthetic.bounds())
    pts = np.random.default_rng(5).uniform(lo, hi, size=(2000, 3)).astype(np.float32)
    np.testing.assert_allclose(gpu.sdf(pts), cpu.sdf(pts), rtol=0, atol=1e-4)
