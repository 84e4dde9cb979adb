"""Per-parameter consensus weights of RAMEN from visit counts (eq. 19).

For an edge (i, j): ``u_sum = u_i + u_j``; ``eps = (beta_u - beta_l) / (max u_sum - min u_sum)``;
``zeta = beta_l - eps * min u_sum``; ``w_ij = eps u_i + zeta``, ``w_ji = eps u_j + zeta``.
Both ends evaluate the same expressions on the same numbers, so ``w_ij`` computed by i is
bit-identical to ``w_ji`` computed by j from the same copies (symmetry).

Edge cases (docs/ALGORITHM.md section 3): ``max == min`` (e.g. before any update) gives
``w = beta_u`` everywhere (DiNNO); weights are clamped to ``[beta_l, beta_u]`` (when
``min u_sum > 0`` the raw formula can fall below ``beta_l`` or below zero).
"""
from __future__ import annotations

import torch


def weight_line(lo: int, hi: int, beta_l: float, beta_u: float) -> tuple[float, float] | None:
    """``(eps, zeta)`` of eq. 19 from the min ``lo`` and max ``hi`` of ``u_i + u_j`` (w per unit
    count, and w at zero counts, in beta's unit); ``None`` when ``hi == lo`` (w = beta_u)."""
    if hi == lo:
        return None
    eps = (beta_u - beta_l) / float(hi - lo)
    return eps, beta_l - eps * float(lo)


def edge_weights(
    u_i: torch.Tensor,
    u_j: torch.Tensor,
    beta_l: float,
    beta_u: float,
    out_i: torch.Tensor,
    out_j: torch.Tensor,
    scratch: torch.Tensor | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Eq. 19: write ``w_ij`` into ``out_i`` and ``w_ji`` into ``out_j`` (float32, n) and return them.

    ``u_i``, ``u_j``: visit counts (integer tensors, n). ``scratch``: optional buffer (n, of the
    counts' promoted integer dtype) for ``u_sum``; allocated if not given or of another dtype.
    Weights have the unit of beta (the ADMM penalty).
    """
    if not 0.0 < beta_l <= beta_u:
        raise ValueError(
            f"edge_weights: beta_l = {beta_l}, beta_u = {beta_u}; expected 0 < beta_l <= beta_u."
        )
    if u_i.shape != u_j.shape:
        raise ValueError(
            f"edge_weights: visit counts have shapes {tuple(u_i.shape)} and {tuple(u_j.shape)}; "
            "expected two vectors of the same length n (one per shared parameter)."
        )
    dtype = torch.promote_types(u_i.dtype, u_j.dtype)
    if scratch is None or scratch.dtype != dtype or scratch.shape != u_i.shape:
        scratch = torch.empty(u_i.shape, dtype=dtype)
    torch.add(u_i, u_j, out=scratch)
    lo_t, hi_t = torch.aminmax(scratch) if scratch.numel() else (torch.zeros(()), torch.zeros(()))
    line = weight_line(int(lo_t.item()), int(hi_t.item()), beta_l, beta_u)
    if line is None:
        out_i.fill_(beta_u)
        out_j.fill_(beta_u)
        return out_i, out_j
    eps, zeta = line
    for u, out in ((u_i, out_i), (u_j, out_j)):
        # integer counts -> float32 into ``out`` (the conversion torch.mul(u, eps) makes into
        # a fresh temporary: same values, no 4 bytes x n allocation per call)
        out.copy_(u)
        out.mul_(eps).add_(zeta).clamp_(beta_l, beta_u)
    return out_i, out_j
