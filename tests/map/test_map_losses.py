"""Rendering weights, losses and smoothness against hand-computed values."""
from __future__ import annotations

import math

import pytest
import torch

from ramensim.agents.map.losses import render_losses, sdf_losses, smoothness_loss, smoothness_points
from ramensim.agents.map.render import composite, sample_depths, sdf_weights


def sig(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-x))


def test_sdf_and_free_space_losses_by_hand():
    z = torch.tensor([[0.5, 0.95, 1.0, 1.2]])
    D = torch.tensor([1.0])
    s = torch.tensor([[0.5, 0.3, -0.2, -1.0]])
    fs, sd = sdf_losses(z, D, s, 0.1)
    # front = [1,0,0,0], band = [0,1,1,0]; fs_w = 1 - 1/3, sdf_w = 1 - 2/3
    assert fs.item() == pytest.approx((2 / 3) * (0.5 - 1) ** 2 / 4, rel=1e-6)
    assert sd.item() == pytest.approx((1 / 3) * (0.02 ** 2 + 0.02 ** 2) / 4, rel=1e-4)


def test_invalid_depth_contributes_nothing():
    z = torch.tensor([[0.5, 0.95, 1.0, 1.2], [0.5, 0.95, 1.0, 1.2]])
    s = torch.tensor([[0.5, 0.3, -0.2, -1.0], [9.0, 9.0, 9.0, 9.0]])
    fs, sd = sdf_losses(z, torch.tensor([1.0, 0.0]), s, 0.1)
    # same sums as the single valid ray, means over 8 samples instead of 4
    assert fs.item() == pytest.approx((2 / 3) * 0.25 / 8, rel=1e-6)
    assert sd.item() == pytest.approx((1 / 3) * 0.0008 / 8, rel=1e-4)
    rgb_l, d_l = render_losses(torch.tensor([[0.5, 0.5, 0.5], [1.0, 1.0, 1.0]]),
                               torch.tensor([1.5, 7.0]),
                               torch.tensor([[0.0, 0.5, 1.0], [0.0, 0.0, 0.0]]),
                               torch.tensor([1.0, 0.0]))
    assert rgb_l.item() == pytest.approx(0.5 / 3)
    assert d_l.item() == pytest.approx(0.25)


def test_weights_cut_after_first_surface():
    tr = 0.15
    s = torch.tensor([[1.0, 0.5, -0.5, -1.0, 0.5, -0.5]])
    z = torch.tensor([[0.1, 0.2, 0.3, 0.4, 0.5, 0.6]])
    w = sdf_weights(s, z, tr)
    raw = [sig(v / tr) * sig(-v / tr) for v in (1.0, 0.5, -0.5)]  # z < 0.2 + 0.15
    expect = [r / (sum(raw) + 1e-8) for r in raw] + [0.0, 0.0, 0.0]
    assert torch.allclose(w[0], torch.tensor(expect), atol=1e-6)
    rgb, depth = composite(w, torch.zeros(1, 6, 3), z)
    assert depth.item() == pytest.approx(sum(e * zz for e, zz in zip(expect, [0.1, 0.2, 0.3])), rel=1e-5)
    assert torch.allclose(rgb, torch.full((1, 3), 0.5), atol=1e-6)


def test_weights_without_sign_change_keep_only_first_truncation():
    s = torch.tensor([[1.0, 0.8, 0.6, 0.4]])
    z = torch.tensor([[1.0, 1.05, 1.2, 1.3]])
    w = sdf_weights(s, z, 0.1)  # z* = z_0 = 1.0: keep z < 1.1
    assert w[0, 2].item() == 0.0 and w[0, 3].item() == 0.0
    assert w[0, :2].sum().item() == pytest.approx(1.0, abs=1e-4)


def test_sample_depths_sorted_and_around_surface():
    g = torch.Generator().manual_seed(0)
    z = sample_depths(torch.tensor([2.0, 0.0]), 8, 5, 0.0, 4.0, 0.1, g)
    assert z.shape == (2, 13)
    assert bool((z[:, 1:] >= z[:, :-1]).all())
    assert int(((z[0] > 1.5) & (z[0] < 2.5)).sum()) >= 5
    assert float(z.min()) >= 0.0 and float(z.max()) <= 4.0


def test_smoothness_by_hand():
    # lattice 2^3, feature = x + 2y + 4z (z-major order): diffs 1, 2, 4 on 4 pairs each
    idx = torch.arange(8)
    x, y, zz = idx % 2, (idx // 2) % 2, idx // 4
    f = (x + 2 * y + 4 * zz).float()[:, None]
    assert smoothness_loss(f, 2).item() == pytest.approx(4 * (1 + 4 + 16) / 8)


def test_smoothness_lattice_inside_bounds():
    lo, hi = torch.tensor([0.0, 0.0, 0.0]), torch.tensor([4.0, 4.0, 3.0])
    p = smoothness_points(lo, hi, 8, 0.1, 0.05, torch.Generator().manual_seed(1))
    assert p.shape == (512, 3)
    assert bool((p >= lo).all()) and bool((p <= hi).all())
    d = p[1] - p[0]
    assert torch.allclose(d, torch.tensor([0.1, 0.0, 0.0]), atol=1e-5)
