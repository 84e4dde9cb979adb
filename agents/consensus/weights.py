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

import math

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
        scratch = torch.empty(u_i.shape, dtype=dtype, device=u_i.device)
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


def weighted_consensus_error(
    thetas: list[torch.Tensor], visits: list[torch.Tensor], beta_l: float, beta_u: float
) -> float:
    """Consensus error weighted by eq. 19 (Theta units): the disagreement RAMEN's penalty sees.

    Over all unordered pairs i < j of the m maps, with ``wbar_ij = (w_ij + w_ji) / 2`` the
    mean of the edge's two eq. 19 weights from the maps' own visit counts u_i, u_j::

        E_w = sqrt( sum_{i<j} sum_k wbar_ij[k] (theta_i[k] - theta_j[k])^2
                    / sum_{i<j} sum_k wbar_ij[k] )                                  (CE-2)

    With equal weights (no visits yet, or DiNNO's w = rho everywhere) this is the unweighted
    error of ``evaluation.summary.consensus_error`` (CE-1): a parameter that neither robot of
    a pair observed weighs beta_l / beta_u (1/1000 by default) of one both observed most. The
    weights' unit cancels, so only beta_l / beta_u matters. Sums in float64. Fewer than two
    maps -> 0.0.
    """
    m = len(thetas)
    if m < 2:
        return 0.0
    if len(visits) != m:
        raise ValueError(f"weighted_consensus_error: {m} parameter vectors but {len(visits)} visit-count vectors; "
                         "expected one visit count per map.")
    flat = [t.detach().reshape(-1).to(torch.float32) for t in thetas]
    counts = [u.detach().reshape(-1) for u in visits]
    n = flat[0].numel()
    if any(f.numel() != n for f in flat) or any(u.numel() != n for u in counts):
        raise ValueError("weighted_consensus_error: every map's theta and visit counts must hold the same "
                         f"number of values; got {[f.numel() for f in flat]} and {[u.numel() for u in counts]}.")
    if n == 0:
        return 0.0
    w_i = torch.empty(n, dtype=torch.float32, device=flat[0].device)
    w_j = torch.empty(n, dtype=torch.float32, device=flat[0].device)
    num = den = 0.0
    for i in range(m):
        for j in range(i + 1, m):
            edge_weights(counts[i], counts[j], beta_l, beta_u, w_i, w_j)
            w_i.add_(w_j).mul_(0.5)
            d = (flat[i] - flat[j]).double()
            num += float(torch.dot(w_i.double(), d.square_()))
            den += float(w_i.sum(dtype=torch.float64))
    return math.sqrt(num / den) if den > 0.0 else 0.0
