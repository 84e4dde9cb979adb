"""The observation losses of L_obj (eq. 5-6; Co-SLAM's get_sdf_loss) and the smoothness term.

Per sample with observed depth D > 0: ``front = z < D - tr``, ``band = not front and
z <= D + tr`` (and D > 0); ``fs_w = 1 - n_f/(n_f+n_b)``, ``sdf_w = 1 - n_b/(n_f+n_b)``;
means run over all samples of the batch, masked entries count as zero.
"""
from __future__ import annotations

import functools

import torch


def sdf_losses(z: torch.Tensor, depth: torch.Tensor, sdf: torch.Tensor,
               truncation: float) -> tuple[torch.Tensor, torch.Tensor]:
    """(free-space loss, sdf loss), unweighted by the config weights.

    z: sample depths (R, S) m; depth: observed D (R,) m; sdf: network output (R, S) in
    truncation units. free space: ``fs_w * mean((s*front - front)^2)`` (s -> 1 truncation);
    sdf: ``sdf_w * mean(((z + s*tr) - D)^2 * band)`` (metres^2).
    """
    D = depth[:, None]
    front = (z < D - truncation).float()
    back = (z > D + truncation).float()
    valid = (D > 0).float()
    band = (1.0 - front) * (1.0 - back) * valid
    n_f = front.sum()
    n_b = band.sum()
    total = (n_f + n_b).clamp_min(1.0)
    fs_w = 1.0 - n_f / total
    sdf_w = 1.0 - n_b / total
    fs = fs_w * torch.mean((sdf * front - front) ** 2)
    sd = sdf_w * torch.mean((((z + sdf * truncation) - D) * band) ** 2)
    return fs, sd


def render_losses(rgb: torch.Tensor, depth: torch.Tensor, target_rgb: torch.Tensor,
                  target_depth: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(rgb MSE, depth MSE in m^2) over rays with a valid observed depth (> 0)."""
    valid = target_depth > 0
    if not bool(valid.all()):
        rgb, depth = rgb[valid], depth[valid]
        target_rgb, target_depth = target_rgb[valid], target_depth[valid]
    if depth.numel() == 0:
        zero = rgb.sum() * 0.0
        return zero, zero
    return torch.mean((rgb - target_rgb) ** 2), torch.mean((depth - target_depth) ** 2)


def smoothness_loss(feats: torch.Tensor, n: int) -> torch.Tensor:
    """Co-SLAM's smoothness: squared finite differences of grid features on an n^3
    lattice, summed over the three axes and divided by n^3. ``feats``: (n^3, C) in
    (z, y, x) lattice order."""
    f = feats.reshape(n, n, n, -1)
    tv = ((f[1:] - f[:-1]) ** 2).sum() + ((f[:, 1:] - f[:, :-1]) ** 2).sum() \
        + ((f[:, :, 1:] - f[:, :, :-1]) ** 2).sum()
    return tv / float(n ** 3)


def smoothness_points(lo: torch.Tensor, hi: torch.Tensor, n: int, spacing: float,
                      margin: float, generator: torch.Generator) -> torch.Tensor:
    """Random n^3 lattice of points in metres ((n^3, 3), z-major), spacing ``spacing``,
    offset at random inside the bounds with ``margin`` (Co-SLAM's ``smoothness``); a
    lattice larger than the bounds starts at lo + margin (points are clamped later)."""
    extent = hi - lo
    size = (n - 1) * spacing
    offset_max = (extent - size - 2 * margin).clamp_min(0.0)
    r = torch.rand(4, 3, generator=generator)
    offset = r[0] * offset_max + margin
    return (_lattice(n) + r[1]) * spacing + lo + offset


@functools.lru_cache(maxsize=4)
def _lattice(n: int) -> torch.Tensor:
    """Integer lattice coordinates (x, y, z) of an n^3 lattice in z-major order, (n^3, 3)
    float32 (built once per n: read-only, shared)."""
    ax = torch.arange(n, dtype=torch.float32)
    gz, gy, gx = torch.meshgrid(ax, ax, ax, indexing="ij")
    return torch.stack([gx, gy, gz], dim=-1).reshape(-1, 3)
