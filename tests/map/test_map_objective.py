"""The fused C objective (csrc/mapkernels.c ``render_loss``) against the torch autograd
reference (render.py + losses.py): losses and gradients w.r.t. the decoder outputs, on
batches with rays without depth, rays with no sign change, samples in front of / inside /
behind the truncation band, and a batch without any valid ray; and its independence of the
thread count; and the smoothness term likewise."""
from __future__ import annotations

import pytest
import torch

from ramensim.agents.map import _native
from ramensim.agents.map.objective import (MAX_SAMPLES_PER_RAY, TERMS, c_unavailable,
                                           observation_grads, smoothness_grads)

pytestmark = pytest.mark.skipif(_native.get_lib() is None, reason="native kernels unavailable")

W = (5.0, 0.1, 1000.0, 10.0)
TR = 0.1


def _batch(R: int, S: int, seed: int, no_depth_every: int = 5):
    g = torch.Generator().manual_seed(seed)
    z = torch.sort(torch.rand(R, S, generator=g) * 4.0 + 0.1, dim=1)[0]
    depth = torch.rand(R, generator=g) * 3.0 + 0.5
    if no_depth_every:
        depth[::no_depth_every] = 0.0
    sdf = ((depth[:, None] - z) / TR).clamp(-1, 1) + 0.1 * torch.randn(R, S, generator=g)
    sdf[1] = torch.rand(S, generator=g) + 0.1  # no sign change on ray 1
    raw = torch.randn(R, S, 3, generator=g) * 2.0
    rgb = torch.rand(R, 3, generator=g)
    return sdf, raw, z, rgb, depth


def _check(batch, threads: int) -> None:
    """Against the torch reference in float64: in float32 the reference itself is off by up
    to ~1e-3 of an entry where sigmoid(-s / tr) is near 1 (autograd's sigmoid backward
    y (1 - y) cancels there; the kernel's u (sig(-a) - sig(a)) does not)."""
    ref_t, ref_obs, ref_ds, ref_dr = observation_grads(*(t.double() for t in batch), TR, W,
                                                       "torch")
    t, obs, ds, dr = observation_grads(*batch, TR, W, "c", threads)
    assert set(t) == set(TERMS)
    for k in TERMS:
        assert t[k] == pytest.approx(ref_t[k], rel=1e-5, abs=1e-9), k
    assert obs == pytest.approx(ref_obs, rel=1e-5)
    for a, b in ((ds, ref_ds), (dr, ref_dr)):
        scale = float(b.abs().max())
        assert scale > 0
        assert float((a - b).abs().max()) <= 1e-5 * scale


@pytest.mark.parametrize("R, S, seed", [(64, 32, 0), (37, 9, 1), (5, 2, 2)])
def test_c_objective_matches_autograd(R, S, seed):
    for threads in (1, 2, 3):
        _check(_batch(R, S, seed), threads)


def test_no_valid_ray_gives_zero_render_terms():
    sdf, raw, z, rgb, depth = _batch(16, 8, 3)
    depth[:] = 0.0
    ref = observation_grads(sdf, raw, z, rgb, depth, TR, W, "torch")
    t, obs, ds, dr = observation_grads(sdf, raw, z, rgb, depth, TR, W, "c", 2)
    assert t["rgb"] == t["depth"] == ref[0]["rgb"] == 0.0
    assert torch.equal(dr, torch.zeros_like(dr)) and torch.equal(ref[3], torch.zeros_like(dr))
    assert float((ds - ref[2]).abs().max()) <= 1e-5 * max(float(ref[2].abs().max()), 1e-12)


def test_result_does_not_depend_on_thread_count():
    batch = _batch(200, 24, 4)
    a = observation_grads(*batch, TR, W, "c", 1)
    b = observation_grads(*batch, TR, W, "c", 3)
    assert a[0] == b[0] and a[1] == b[1]
    assert torch.equal(a[2], b[2]) and torch.equal(a[3], b[3])


def test_availability():
    assert c_unavailable(torch.device("cpu"), 32) is None
    assert "samples per ray" in c_unavailable(torch.device("cpu"), MAX_SAMPLES_PER_RAY + 1)
    assert c_unavailable(torch.device("meta"), 32) == "CPU only"
    with pytest.raises(ValueError, match="objective backend"):
        observation_grads(*_batch(4, 4, 5), TR, W, "fortran")


@pytest.mark.parametrize("n, C", [(4, 2), (7, 3), (1, 2)])
def test_c_smoothness_matches_autograd(n, C):
    g = torch.Generator().manual_seed(n)
    feats = torch.randn(n ** 3, C, generator=g) * 1e-2
    ref_l, ref_g = smoothness_grads(feats.double(), n, 0.7, "torch")
    for threads in (1, 3):
        loss, grad = smoothness_grads(feats, n, 0.7, "c", threads)
        assert loss == pytest.approx(ref_l, rel=1e-5, abs=1e-12)
        assert float((grad - ref_g).abs().max()) <= 1e-5 * max(float(ref_g.abs().max()), 1e-12)
    a, b = smoothness_grads(feats, n, 0.7, "c", 1), smoothness_grads(feats, n, 0.7, "c", 3)
    assert a[0] == b[0] and torch.equal(a[1], b[1])
    with pytest.raises(ValueError, match="n\\^3"):
        smoothness_grads(feats[:-1], n, 0.7, "c")


def test_extreme_sdf_stays_finite_like_the_reference():
    """A diverging map (huge decoder outputs) must give the reference's finite values, not a
    NaN from exp overflow (sig(-a) for a -> -inf)."""
    sdf, raw, z, rgb, depth = _batch(32, 12, 6)
    sdf = sdf * 1e3
    raw = raw * 1e3
    ref = observation_grads(sdf.double(), raw.double(), z.double(), rgb.double(),
                            depth.double(), TR, W, "torch")
    t, obs, ds, dr = observation_grads(sdf, raw, z, rgb, depth, TR, W, "c", 2)
    assert all(torch.isfinite(x).all() for x in (ds, dr))
    assert obs == pytest.approx(ref[1], rel=1e-5)
