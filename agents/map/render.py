"""Ray sampling and SDF volume rendering, exactly as Co-SLAM (docs/ALGORITHM.md section 1)."""
from __future__ import annotations

import functools

import torch

from . import _native


def sample_depths(depth: torch.Tensor, n_strat: int, n_surf: int, near: float, far: float,
                  surface_range: float, generator: torch.Generator | None) -> torch.Tensor:
    """Sample depths z (R, n_strat + n_surf) in metres along each ray.

    ``n_strat`` evenly spaced in [near, far] plus ``n_surf`` evenly spaced in
    [D - r, D + r] (rays without depth get them in [near, far]), sorted, then jittered
    uniformly within the intervals between midpoints (Co-SLAM's ``perturb``); no jitter
    when ``generator`` is None. The jitter is drawn on the generator's device (the map's
    generators live on the CPU) and moved to ``depth``'s, so a map on CUDA draws the same
    samples as one on the CPU.
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
        u = torch.rand(z.shape, generator=generator, device=generator.device)
        z = lower + (upper - lower) * u.to(dev)
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


@functools.lru_cache(maxsize=16)
def _linspace(lo: float, hi: float, n: int) -> torch.Tensor:
    return torch.linspace(lo, hi, n)


def sample_points(rows: torch.Tensor, n_strat: int, n_surf: int, near: float, far: float,
                  surface_range: float, generator: torch.Generator | None, lo: torch.Tensor,
                  extent: torch.Tensor, native: bool = True,
                  threads: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    """Sample depths ``z`` (R, S) m of training rays (:func:`sample_depths`) and the
    normalised sample positions ``xn`` (R*S, 3) = clamp((o + d z - lo) / extent, 0, 1).

    rows: (R, 10) [origin (m), direction, rgb, depth (m)]. On the CPU with the compiled
    kernels: one pass (``ray_samples`` of ``csrc/render.c``), bit-identical to the torch
    path (the same jitter draws from ``generator``, the same float operations)."""
    R = rows.shape[0]
    S = n_strat + n_surf
    depth = rows[:, 9]
    lib = _native.get_lib() if native and rows.device.type == "cpu" else None
    if (lib is None or S > 1024 or near > far or surface_range < 0
            or not bool(torch.isfinite(depth).all())):  # the kernel merges sorted lists
        z = sample_depths(depth, n_strat, n_surf, near, far, surface_range, generator)
        pts = (rows[:, None, 0:3] + rows[:, None, 3:6] * z[..., None]).reshape(R * S, 3)
        return z, ((pts - lo) / extent).clamp_(0.0, 1.0)
    rows = rows.contiguous().float()
    strat = _linspace(near, far, n_strat)
    off = _linspace(-surface_range, surface_range, n_surf)
    nodepth = _linspace(near, far, n_surf)
    rnd = torch.rand((R, S), generator=generator) if generator is not None else None
    z = torch.empty(R, S, dtype=torch.float32)
    xn = torch.empty(R * S, 3, dtype=torch.float32)
    lo_c, ext_c = lo.contiguous().float(), extent.contiguous().float()
    lib.ray_samples(rows.data_ptr(), R, strat.data_ptr(), n_strat, off.data_ptr(), n_surf,
                    nodepth.data_ptr(), rnd.data_ptr() if rnd is not None else None,
                    lo_c.data_ptr(), ext_c.data_ptr(), z.data_ptr(), xn.data_ptr(),
                    threads or _native.nthreads())
    return z, xn
