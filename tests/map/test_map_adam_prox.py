"""The compiled Adam + proximal step (csrc/adam.c adam_prox, NeuralMap._optimizer_step)
against (a) the same arithmetic emulated in numpy float32 (IEEE operations, the update a fused
multiply-add): bit-identical, with a per-parameter A (RAMEN) and a scalar A (DiNNO-style), on
1 and 2 threads; (b) what it replaces (the C Adam step, then the torch ops of
agents/learner.apply_prox_inv): the same Adam moments, theta equal to float rounding (torch's
vectorised sqrt is not correctly rounded on every CPU: 1 ulp off in ~17 % of the entries on a
Zen 4, which moves 1 / step); and the fallbacks (0-d tensor A) still work."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from ramensim.agents.map import MapConfig, NeuralMap, _native, synthetic
from ramensim.agents.map.decoders import init_decoders

pytestmark = pytest.mark.skipif(_native.get_lib() is None, reason="native kernels unavailable")

TINY = dict(n_levels=4, log2_hashmap_size=10, n_rays=64, n_stratified=6, n_surface=3,
            smooth_lattice=4, geo_hidden=16, color_hidden=16, geo_feat_dim=7, oneblob_bins=4)
F = np.float32


def _map() -> NeuralMap:
    cfg = MapConfig(**TINY)
    return NeuralMap(synthetic.bounds(), cfg, init_decoders(cfg, torch.Generator().manual_seed(0)),
                     torch.Generator().manual_seed(1), torch.Generator().manual_seed(2))


def _emulate(m: NeuralMap, p, mm, vv, g, a, c, step: int):
    """Adam (the C kernel's formula) then the proximal step, numpy float32, one op at a time."""
    cfg = m.cfg
    b1, b2, lr, eps = F(cfg.adam_beta1), F(cfg.adam_beta2), F(cfg.lr), F(cfg.adam_eps)
    bc1 = F(1.0 - cfg.adam_beta1 ** step)
    bc2s = math.sqrt(1.0 - cfg.adam_beta2 ** step)
    mm = mm + (F(1) - b1) * (g - mm)
    vv = vv * b2 + (F(1) - b2) * g * g
    p = p - (lr / bc1) * (mm / (np.sqrt(vv) / F(bc2s) + eps))
    inv = np.sqrt(vv) * F(1.0 / (bc2s * cfg.lr)) + F(cfg.adam_eps / cfg.lr)
    if isinstance(a, float):
        r = (F(1) / (inv + F(a))) * F(a)
    else:
        r = a / (inv + a)
    upd = (p.astype(np.float64) + r.astype(np.float64) * (c - p).astype(np.float64)).astype(F)
    return upd, mm, vv


@pytest.mark.parametrize("scalar_a", [False, True])
@pytest.mark.parametrize("threads", [1, 2])
def test_fused_adam_prox(scalar_a, threads):
    g = torch.Generator().manual_seed(3)
    fused, ref = _map(), _map()
    n = fused.n_params
    fused.grid_threads = threads
    ref._fused_prox = lambda prox: False  # the same C Adam, then the torch ops of apply_prox_inv
    p, mm, vv = (t.numpy().copy() for t in (fused.theta, fused._m, fused._v))
    for step in range(1, 5):
        grad = torch.randn(n, generator=g) * 10.0 ** (1 - step)
        grad[::7] = 0.0  # parameters without a gradient (huge Adam steps, finite 1/step)
        a = 0.3 + step if scalar_a else torch.rand(n, generator=g) * 5 + 1e-3
        c = torch.randn(n, generator=g) * 1e-2
        assert fused._fused_prox((a, c))
        fused.optimizer_step(grad, (a, c))
        ref.optimizer_step(grad, (a, c))
        p, mm, vv = _emulate(fused, p, mm, vv, grad.numpy(), a if scalar_a else a.numpy(),
                             c.numpy(), step)
        assert np.array_equal(fused.theta.numpy(), p), step
        assert torch.equal(fused._m, ref._m) and torch.equal(fused._v, ref._v)
        diff = float((fused.theta - ref.theta).abs().max())
        assert diff <= 1e-6 * float(ref.theta.abs().max()), (step, diff)


def test_other_forms_of_a_take_the_torch_path():
    m = _map()
    n = m.n_params
    assert not m._fused_prox((torch.tensor(0.5), torch.zeros(n)))  # 0-d: rounds differently
    assert not m._fused_prox((torch.ones(n, dtype=torch.float64), torch.zeros(n)))
    assert not m._fused_prox((1.0, torch.zeros(n - 1)))
    before = m.theta.clone()
    m.optimizer_step(torch.ones(n), (torch.tensor(0.5), torch.zeros(n)))  # still works
    assert not torch.equal(m.theta, before) and bool(torch.isfinite(m.theta).all())
