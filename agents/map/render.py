"""Ray sampling and SDF volume rendering, exactly as Co-SLAM (docs/ALGORITHM.md section 1)."""
from __future__ import annotations

import torch


def sample_depths(depth: torch.Tensor, n_strat: int, n_surf: int, near: float, far: float,
                  surface_range: float, generator: torch.Generator | None) -> torch.Tensor:
    """Sample depths z (R, n_strat + n_surf) in metres along each ray.

    ``n_strat`` evenly spaced in [near, far] plus ``n_surf`` evenly spaced in
    [D - r, D + r] (rays without depth get them in [near, far]), sorted, then jittered
    uniformly within the intervals between midpoints (Co-SLAM's ``perturb``); no jitter
    when ``generator`` is None.
    """
    R = depth.shape[0]
    dev = depth.device
    z = torch.linspace(near, far, n_strat, device=dev).expand(R, n_strat)
    if n_surf > 0:
        off = torch.linspace(-surface_range, surface_range, n_surf, device=dev)
        zs = depth[:, None] + off[None, :]
        invalid = depth <= 0
        if bool(invalid.any()):
            zs[invalid] = torch.linspace(near, far, n_surf, device=dev)
        z, _ = torch.sort(torch.cat([z, zs], dim=1), dim=1)
    if generator is not None:
        mids = 0.5 * (z[:, 1:] + z[:, :-1])
        upper = torch.cat([mids, z[:, -1:]], dim=1)
        lower = torch.cat([z[:, :1], mids], dim=1)
        z = lower + (upper - lower) * torch.rand(z.shape, generator=generator, device=dev)
    return z.contiguous()


def sdf_weights(sdf: torch.Tensor, z: torch.Tensor, truncation: float) -> torch.Tensor:
    """Co-SLAM rendering weights (R, S) from the SDF ``sdf`` (truncation units).

    ``w = sigmoid(s/tr) * sigmoid(-s/tr)``; the first sign change of s along the ray
    (samples k, k+1 with s_k s_{k+1} < 0) gives z* = z_k; weights with z >= z* + tr are
    zeroed; then ``w / (sum w + 1e-8)``. With no sign change z* = z_0 (Co-SLAM's argmax
    of an all-zero mask).
    """
    w = torch.sigmoid(sdf / truncation) * torch.sigmoid(-sdf / truncation)
    signs = sdf[:, 1:] * sdf[:, :-1]
    first = torch.argmax((signs < 0).to(torch.uint8), dim=1, keepdim=True)
    z_min = torch.gather(z, 1, first)
    w = w * (z < z_min + truncation)
    return w / (w.sum(dim=1, keepdim=True) + 1e-8)


def composite(weights: torch.Tensor, raw_rgb: torch.Tensor, z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Rendered colour (R, 3) = sum w sigmoid(c) and depth (R,) = sum w z (metres)."""
    rgb = (weights[..., None] * torch.sigmoid(raw_rgb)).sum(dim=1)
    depth = (weights * z).sum(dim=1)
    return rgb, depth
