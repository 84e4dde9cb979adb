"""The frozen decoders' forward and hand-written backward without autograd (docs/ALGORITHM.md
section 1), in one of two backends: the fused C kernel ``csrc/mapmlp.c`` or torch matrix
products. The backend module measures both; ``decoders.Decoders`` uses the chosen one."""
from __future__ import annotations

import torch

from . import _native
from .threads import capped, thread_count

KEYS = ("geo.0", "geo.1", "color.0", "color.1")
"""The four weight matrices of the decoders (torch ``Linear`` layout, (out, in))."""


class DecoderKernel:
    """Forward and hand-written backward of the frozen decoders, no autograd, in one of two
    backends with one contract (chosen by measurement in the backend module): ``c`` = the fused OpenMP
    kernel ``csrc/mapmlp.c``; ``torch`` = batched matrix products (torch's GEMM).

    Forward (docs/ALGORITHM.md section 1): ``hid = relu(W0g f + W0p p)``, ``[s, h] = W1 hid``,
    ``chid = relu(C0p p + C0h h)``, ``raw = C1 chid``. Backward, from ``ds = dL/ds`` (N,) and
    ``dr = dL/draw`` (N, 3): ``dchid = (dr C1) * [chid > 0]``, ``dh = dchid C0h``,
    ``dhid = ([ds, dh] W1) * [hid > 0]``, ``df = dhid W0g`` (N, L*F). The backward needs only
    the ReLU masks ``[hid > 0]``, ``[chid > 0]`` (the weights are frozen): ``forward(...,
    keep=True)`` stores them (a buffer reused across calls) and ``backward(..., kept=True)``
    reads them instead of recomputing the forward (bit-identical result, about a third of
    the backward's arithmetic).
    """

    def __init__(self, backend: str, weights: dict[str, torch.Tensor], grid_dim: int,
                 pe_dim: int, device: torch.device, threads: int = 0) -> None:
        w0, w1, c0, c1 = (weights[k].detach().to(device=device, dtype=torch.float32)
                          .contiguous() for k in KEYS)
        self.backend, self.grid_dim, self.pe_dim = backend, grid_dim, pe_dim
        self.gh = w0.shape[0]
        self.threads = threads
        """Threads of this stage (0: torch's intra-op count at call time)."""
        self._kept: tuple | None = None
        """ReLU masks of the last ``forward(keep=True)``: (samples, masks...)."""
        self._mask_buf = torch.empty(0, dtype=torch.int8)
        if backend == "c":
            self._lib = _native.get_mlp_lib(grid_dim, pe_dim, w0.shape[0], w1.shape[0],
                                            c0.shape[0])
            if self._lib is None:
                raise RuntimeError("the fused C decoder kernel is unavailable")
            # the OneBlob columns of both first layers as one (NP, GH + CH) matrix: the
            # kernel adds its rows for each sample's non-zero OneBlob features only
            pe_t = torch.cat([w0[:, grid_dim:], c0[:, :pe_dim]], dim=0).t().contiguous()
            self._w = [w0, w1, c0, c1, pe_t]
            self._wt = [c1.t().contiguous(), c0[:, pe_dim:].t().contiguous(),
                        w1.t().contiguous(), w0[:, :grid_dim].t().contiguous()]
        elif backend == "torch":
            # (in, out) layouts for x @ W; the two OneBlob blocks in one product
            self._w0g_t = w0[:, :grid_dim].t().contiguous()
            self._pe_t = torch.cat([w0[:, grid_dim:], c0[:, :pe_dim]], dim=0).t().contiguous()
            self._w1_t = w1.t().contiguous()
            self._c0h_t = c0[:, pe_dim:].t().contiguous()
            self._c1_t = c1.t().contiguous()
            self._w0g, self._w1 = w0[:, :grid_dim].contiguous(), w1
            self._c0h, self._c1 = c0[:, pe_dim:].contiguous(), c1
        else:
            raise ValueError(f"unknown decoder backend {backend!r}; expected 'c' or 'torch'")

    def _nthreads(self) -> int:
        return capped(self.threads) if self.threads > 0 else _native.nthreads()

    def _torch_fwd(self, feats: torch.Tensor, pe: torch.Tensor):
        pt = pe @ self._pe_t
        hid = torch.addmm(pt[:, :self.gh], feats, self._w0g_t).relu_()
        geo = hid @ self._w1_t
        chid = torch.addmm(pt[:, self.gh:], geo[:, 1:], self._c0h_t).relu_()
        return hid, geo, chid, chid @ self._c1_t

    @torch.no_grad()
    def forward(self, feats: torch.Tensor, pe: torch.Tensor,
                keep: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """(sdf in truncation units (N,), raw colour (N, 3)); ``keep``: also store the ReLU
        masks for ``backward(..., kept=True)`` (replacing those of an earlier call)."""
        feats, pe = feats.contiguous(), pe.contiguous()
        n = feats.shape[0]
        self._kept = None
        if self.backend == "torch":
            with thread_count(capped(self.threads)):
                hid, geo, chid, raw = self._torch_fwd(feats, pe)
            if keep:
                self._kept = (n, hid > 0, chid > 0)
            return geo[:, 0].contiguous(), raw
        sdf = torch.empty(n, dtype=torch.float32)
        raw = torch.empty(n, 3, dtype=torch.float32)
        masks = 0
        if keep:
            nbytes = int(self._lib.mlp_mask_bytes(n))
            if self._mask_buf.numel() < nbytes:
                self._mask_buf = torch.empty(nbytes, dtype=torch.int8)
            masks = self._mask_buf.data_ptr()
            self._kept = (n,)
        self._lib.mlp_fwd_keep(feats.data_ptr(), pe.data_ptr(), n,
                               *(w.data_ptr() for w in self._w), sdf.data_ptr(), raw.data_ptr(),
                               masks, self._nthreads())
        return sdf, raw

    @torch.no_grad()
    def sdf(self, feats: torch.Tensor, pe: torch.Tensor) -> torch.Tensor:
        """The SDF alone (truncation units, (N,)), bit-identical to ``forward``'s: the C kernel
        skips the colour layers and geometry outputs 1.. (about half the work); the torch
        backend runs the whole forward."""
        if self.backend == "torch":
            return self.forward(feats, pe)[0]
        feats, pe = feats.contiguous(), pe.contiguous()
        out = torch.empty(feats.shape[0], dtype=torch.float32)
        w0, w1, _c0, _c1, pe_t = self._w
        self._lib.mlp_sdf(feats.data_ptr(), pe.data_ptr(), feats.shape[0], w0.data_ptr(), w1.data_ptr(),
                          pe_t.data_ptr(), out.data_ptr(), self._nthreads())
        return out

    @torch.no_grad()
    def backward(self, feats: torch.Tensor, pe: torch.Tensor, dsdf: torch.Tensor,
                 draw: torch.Tensor, kept: bool = False) -> torch.Tensor:
        """d loss / d grid features (N, L*F) from d loss / d sdf (N,) and d loss / d raw
        colour (N, 3); ``kept``: use the ReLU masks the last ``forward(feats, pe,
        keep=True)`` stored (same batch) instead of recomputing the forward."""
        feats, pe = feats.contiguous(), pe.contiguous()
        dsdf, draw = dsdf.contiguous(), draw.contiguous()
        n = feats.shape[0]
        if kept and (self._kept is None or self._kept[0] != n):
            raise RuntimeError("DecoderKernel.backward(kept=True) needs a forward(keep=True) "
                               "of the same batch first")
        if self.backend == "torch":
            with thread_count(capped(self.threads)):
                if kept:
                    _, hid_on, chid_on = self._kept
                    dchid = (draw @ self._c1).mul_(chid_on)
                    dgeo = torch.cat([dsdf[:, None], dchid @ self._c0h], dim=1)
                    dhid = (dgeo @ self._w1).mul_(hid_on)
                    return dhid @ self._w0g
                hid, _, chid, _ = self._torch_fwd(feats, pe)
                dchid = (draw @ self._c1).mul_(chid > 0)
                dgeo = torch.cat([dsdf[:, None], dchid @ self._c0h], dim=1)
                dhid = (dgeo @ self._w1).mul_(hid > 0)
                return dhid @ self._w0g
        dfeats = torch.empty(n, self.grid_dim, dtype=torch.float32)
        if kept:
            self._lib.mlp_bwd_masks(self._mask_buf.data_ptr(), n,
                                    *(w.data_ptr() for w in self._wt), dsdf.data_ptr(),
                                    draw.data_ptr(), dfeats.data_ptr(), self._nthreads())
            return dfeats
        self._lib.mlp_bwd(feats.data_ptr(), pe.data_ptr(), n, *(w.data_ptr() for w in self._w),
                          *(w.data_ptr() for w in self._wt), dsdf.data_ptr(), draw.data_ptr(),
                          dfeats.data_ptr(), self._nthreads())
        return dfeats
