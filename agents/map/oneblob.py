"""OneBlob positional encoding gamma(x) (docs/ALGORITHM.md section 1; Co-SLAM / tiny-cuda-nn).

For bin k of an axis value t in [0, 1] with n bins:
``out[k] = C((k+1)/n - t) - C(k/n - t)``, ``C(s) = sum_{m in {-1,0,1}} Fq(s + m)``,
``Fq(s) = clamp(15/16 * u * (1 - 2/3 u^2 + 1/5 u^4) + 0.5, 0, 1)``, ``u = s * n``:
a quartic kernel of radius 1/n, periodic. Output (N, 3*n), axis-major (x bins, y bins,
z bins). It has no parameters and positions get no gradient, so it is computed without
autograd.
"""
from __future__ import annotations

import torch

from . import _native


def _fq(s: torch.Tensor, n_bins: int) -> torch.Tensor:
    u = s * float(n_bins)
    u2 = u * u
    return (0.9375 * u * (1.0 - (2.0 / 3.0) * u2 + 0.2 * u2 * u2) + 0.5).clamp_(0.0, 1.0)


def oneblob_torch(xn: torch.Tensor, n_bins: int) -> torch.Tensor:
    """Pure-torch OneBlob: (N, 3) in [0, 1] -> (N, 3 * n_bins) float32."""
    edges = torch.arange(n_bins + 1, dtype=torch.float32, device=xn.device) / float(n_bins)
    s = edges[None, None, :] - xn[:, :, None]  # (N, 3, n+1)
    c = _fq(s - 1.0, n_bins) + _fq(s, n_bins) + _fq(s + 1.0, n_bins)
    return (c[..., 1:] - c[..., :-1]).reshape(xn.shape[0], 3 * n_bins)


def oneblob(xn: torch.Tensor, n_bins: int, native: bool = True, threads: int = 0) -> torch.Tensor:
    """OneBlob encoding (N, 3) -> (N, 3 * n_bins), compiled kernel on CPU when available;
    ``threads``: its OpenMP threads (0: torch's intra-op count). Same values on any count."""
    lib = _native.get_lib() if native and xn.device.type == "cpu" else None
    if lib is None:
        return oneblob_torch(xn, n_bins)
    xn = xn.contiguous().float()
    out = torch.empty(xn.shape[0], 3 * n_bins, dtype=torch.float32)
    lib.oneblob(xn.data_ptr(), xn.shape[0], n_bins, out.data_ptr(),
                threads or _native.nthreads())
    return out
