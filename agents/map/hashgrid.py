"""Multi-resolution hash-grid encoding V(x) (docs/ALGORITHM.md section 1, tiny-cuda-nn indexing).

Level l: ``scale = base * b^l - 1``, ``res = ceil(scale) + 1``, ``pos = xn * scale + 0.5``,
``cell = floor(pos)``, ``frac = pos - cell``; the 8 corners ``cell + {0,1}^3`` with
trilinear weights; index ``c.x + c.y*res + c.z*res^2`` on dense levels (``res^3 <= T``),
else ``(c.x*1) ^ (c.y*2654435761) ^ (c.z*805459861)`` in uint32; then ``& (T-1)``
(tiny-cuda-nn's ``index % hashmap_size``; on dense levels it only matters for the top
corner row, ``c = res``). Output: the L levels' F features concatenated (L*F).

Two implementations with one contract: the compiled kernel of ``_native`` and a fused
pure-torch path (all levels and corners in one index computation, one gather, one
``index_add_``). Only the table gets a gradient (positions are data, not parameters).
The table is the flat parameter vector theta viewed as (L*T, F): level l owns rows
``[l*T, (l+1)*T)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from ramensim.core.native import read_define

from . import _native

PRIMES = (1, read_define(_native.CSRC / "hashgrid.h", "P1"), read_define(_native.CSRC / "hashgrid.h", "P2"))
"""The hash primes of x, y, z, defined once in ``csrc/hashgrid.h`` (the C kernel's)."""
"""tiny-cuda-nn's spatial hash primes for x, y, z."""


@dataclass(frozen=True)
class GridSpec:
    """Per-level constants of a hash grid (scales are float32 values, as the kernels use)."""

    n_levels: int
    features: int
    log2_T: int
    scales: torch.Tensor  # float32 (L,)
    res: torch.Tensor  # int32 (L,)
    dense: torch.Tensor  # int32 (L,) 1 = dense level

    @property
    def T(self) -> int:
        return 1 << self.log2_T

    @property
    def n_params(self) -> int:
        return self.n_levels * self.T * self.features

    @property
    def out_dim(self) -> int:
        return self.n_levels * self.features

    @classmethod
    def build(cls, n_levels: int, features: int, log2_T: int, base_resolution: int,
              finest_resolution: float) -> "GridSpec":
        """Per-level scale and resolution: ``b = exp((ln R - ln base) / (L - 1))``,
        ``scale_l = base * b^l - 1``, ``res_l = ceil(scale_l) + 1`` (docs/ALGORITHM.md 1)."""
        if finest_resolution < base_resolution:
            finest_resolution = float(base_resolution)
        b = math.exp((math.log(finest_resolution) - math.log(base_resolution))
                     / max(n_levels - 1, 1))
        scales = torch.tensor([base_resolution * b ** lv - 1.0 for lv in range(n_levels)],
                              dtype=torch.float32)
        res = torch.tensor([math.ceil(float(s)) + 1 for s in scales], dtype=torch.int32)
        T = 1 << log2_T
        dense = torch.tensor([int(int(r) ** 3 <= T) for r in res], dtype=torch.int32)
        return cls(n_levels, features, log2_T, scales, res, dense)


_CORNERS = torch.tensor([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)],
                        dtype=torch.int64)  # (8, 3), corner c has bits (x, y, z)


def _torch_indices_weights(xn: torch.Tensor, spec: GridSpec) -> tuple[torch.Tensor, torch.Tensor]:
    """Row indices into the (L*T, F) table and trilinear weights, all levels at once.

    xn: (N, 3) float32 in [0, 1]. Returns idx int64 (N, L, 8) and w float32 (N, L, 8).
    """
    dev = xn.device
    scales = spec.scales.to(dev)
    res = spec.res.to(dev).long()
    dense = spec.dense.to(dev).bool()
    pos = xn[:, None, :] * scales[None, :, None] + 0.5  # (N, L, 3), same rounding as C
    cell = torch.floor(pos)
    frac = pos - cell
    corners = _CORNERS.to(dev)
    c = cell.long()[:, :, None, :] + corners[None, None, :, :]  # (N, L, 8, 3)
    dense_idx = c[..., 0] + c[..., 1] * res[None, :, None] + c[..., 2] * (res * res)[None, :, None]
    hash_idx = (c[..., 0] * PRIMES[0]) ^ (c[..., 1] * PRIMES[1]) ^ (c[..., 2] * PRIMES[2])
    idx = torch.where(dense[None, :, None], dense_idx, hash_idx) & (spec.T - 1)
    idx = idx + (torch.arange(spec.n_levels, device=dev) * spec.T)[None, :, None]
    wsel = torch.where(corners[None, None, :, :].bool(), frac[:, :, None, :],
                       1.0 - frac[:, :, None, :])  # (N, L, 8, 3)
    w = wsel[..., 0] * wsel[..., 1] * wsel[..., 2]
    return idx, w


def encode_torch(xn: torch.Tensor, table: torch.Tensor, spec: GridSpec) -> torch.Tensor:
    """Pure-torch forward: (N, 3) -> (N, L*F). ``table`` is flat (n,) or (L*T, F)."""
    idx, w = _torch_indices_weights(xn, spec)
    tab = table.reshape(-1, spec.features)
    feats = tab[idx] * w[..., None]  # (N, L, 8, F)
    return feats.sum(dim=2).reshape(xn.shape[0], spec.out_dim)


def backward_torch(xn: torch.Tensor, grad_out: torch.Tensor, spec: GridSpec,
                   grad_table: torch.Tensor) -> None:
    """Pure-torch backward: accumulate dL/dtable into ``grad_table`` (flat, n) in place."""
    idx, w = _torch_indices_weights(xn, spec)
    g = grad_out.reshape(xn.shape[0], spec.n_levels, 1, spec.features) * w[..., None]
    grad_table.view(-1, spec.features).index_add_(0, idx.reshape(-1),
                                                  g.reshape(-1, spec.features))


def _use_native(*tensors: torch.Tensor) -> bool:
    return all(t.device.type == "cpu" for t in tensors) and _native.get_lib() is not None


def encode(xn: torch.Tensor, table: torch.Tensor, spec: GridSpec, native: bool = True,
           out: torch.Tensor | None = None, threads: int = 0) -> torch.Tensor:
    """Forward encoding without autograd: (N, 3) float32 in [0, 1] -> (N, L*F) float32.
    ``threads``: threads of the C kernel (0: torch's intra-op count)."""
    if native and _use_native(xn, table):
        lib = _native.get_lib()
        xn = xn.contiguous().float()
        if out is None:
            out = torch.empty(xn.shape[0], spec.out_dim, dtype=torch.float32)
        lib.hash_fwd(xn.data_ptr(), xn.shape[0], table.contiguous().data_ptr(), spec.n_levels,
                     spec.features, spec.T, spec.scales.data_ptr(), spec.res.data_ptr(),
                     spec.dense.data_ptr(), out.data_ptr(), threads or _native.nthreads())
        return out
    feats = encode_torch(xn, table, spec)
    if out is not None:
        out.copy_(feats)
        return out
    return feats


def encode_grid(axes: tuple[torch.Tensor, torch.Tensor, torch.Tensor], table: torch.Tensor, spec: GridSpec,
                out: torch.Tensor | None = None, threads: int = 0) -> torch.Tensor:
    """``encode`` of every point of a regular grid, through the C kernel (``hash_fwd_grid``):
    ``axes`` are the normalised coordinates along x, y and z (float32 (nx,), (ny,), (nz,)), the
    points ``(axes[0][i], axes[1][j], axes[2][k])`` in C order over (nx, ny, nz); the result
    (nx * ny * nz, L*F) is ``encode``'s on those points bit for bit (each axis's part of the
    positions, floors, weights and hash terms computed once per axis value). CPU tensors and
    the compiled kernels only (the callers check ``_native.get_lib()``)."""
    lib = _native.get_lib()
    assert lib is not None
    xa, ya, za = (a.contiguous().float() for a in axes)
    n = xa.shape[0] * ya.shape[0] * za.shape[0]
    if out is None:
        out = torch.empty(n, spec.out_dim, dtype=torch.float32)
    lib.hash_fwd_grid(xa.data_ptr(), xa.shape[0], ya.data_ptr(), ya.shape[0], za.data_ptr(), za.shape[0],
                      table.contiguous().data_ptr(), spec.n_levels, spec.features, spec.T,
                      spec.scales.data_ptr(), spec.res.data_ptr(), spec.dense.data_ptr(), out.data_ptr(),
                      threads or _native.nthreads())
    return out


def accumulate_grad(xn: torch.Tensor, grad_out: torch.Tensor, spec: GridSpec,
                    grad_table: torch.Tensor, native: bool = True, threads: int = 0) -> None:
    """Backward of ``encode``: ``grad_table += dfeats/dtable^T grad_out`` (one scatter)."""
    if native and _use_native(xn, grad_out, grad_table) and grad_table.is_contiguous():
        lib = _native.get_lib()
        xn = xn.contiguous().float()
        grad_out = grad_out.contiguous().float()
        lib.hash_bwd(xn.data_ptr(), xn.shape[0], grad_out.data_ptr(), spec.n_levels,
                     spec.features, spec.T, spec.scales.data_ptr(), spec.res.data_ptr(),
                     spec.dense.data_ptr(), grad_table.data_ptr(), threads or _native.nthreads())
        return
    backward_torch(xn, grad_out, spec, grad_table)


class HashGridFunction(torch.autograd.Function):
    """Autograd wrapper: forward = ``encode``, backward = one scatter into a flat table
    gradient (no gradient for the positions)."""

    @staticmethod
    def forward(ctx, xn: torch.Tensor, table: torch.Tensor, spec: GridSpec,  # type: ignore[override]
                native: bool) -> torch.Tensor:
        ctx.save_for_backward(xn)
        ctx.spec = spec
        ctx.native = native
        ctx.table_shape = table.shape
        return encode(xn, table.detach(), spec, native)

    @staticmethod
    def backward(ctx, grad_out: torch.Tensor):  # type: ignore[override]
        (xn,) = ctx.saved_tensors
        grad_table = torch.zeros(ctx.spec.n_params, dtype=torch.float32, device=xn.device)
        accumulate_grad(xn, grad_out, ctx.spec, grad_table, ctx.native)
        return None, grad_table.view(ctx.table_shape), None, None


def hash_encode(xn: torch.Tensor, table: torch.Tensor, spec: GridSpec,
                native: bool = True) -> torch.Tensor:
    """Differentiable (w.r.t. ``table``) hash-grid encoding: (N, 3) -> (N, L*F)."""
    return HashGridFunction.apply(xn, table, spec, native)


def vertex_positions(spec: GridSpec, level: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Grid vertices c in [0, res)^3 of a level: normalised positions (res^3, 3) in xn
    units (``xn = (c - 0.5) / scale``) and their table rows within the level (res^3,)."""
    r = int(spec.res[level])
    s = float(spec.scales[level])
    ax = torch.arange(r, dtype=torch.int64)
    cz, cy, cx = torch.meshgrid(ax, ax, ax, indexing="ij")
    c = torch.stack([cx.reshape(-1), cy.reshape(-1), cz.reshape(-1)], dim=1)
    if int(spec.dense[level]):
        rows = c[:, 0] + c[:, 1] * r + c[:, 2] * r * r
    else:
        rows = (c[:, 0] * PRIMES[0]) ^ (c[:, 1] * PRIMES[1]) ^ (c[:, 2] * PRIMES[2])
    rows = rows & (spec.T - 1)
    return (c.float() - 0.5) / s, rows
