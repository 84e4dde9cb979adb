"""The geometry and colour decoders (docs/ALGORITHM.md section 1; Co-SLAM's ColorSDFNet).

Geometry: ``[V(x), gamma(x)] (L*F + 3*bins) -> hidden -> 1 + geo_feat``, no biases, ReLU;
output 0 is the SDF s in units of the truncation, the rest is the feature h.
Colour: ``[gamma(x), h] -> hidden -> 3``, no biases, ReLU; raw colour (sigmoid at render).
Weights are a dict of four matrices (torch ``Linear`` layout, (out, in)):
``geo.0``, ``geo.1``, ``color.0``, ``color.1``.
"""
from __future__ import annotations

import math

import torch

from . import backend as _backend
from .config import MapConfig
from .decoder_kernel import KEYS, DecoderKernel

__all__ = ["KEYS", "DecoderKernel", "Decoders", "check_decoders", "decoder_shapes", "init_decoders"]



def decoder_shapes(cfg: MapConfig) -> dict[str, tuple[int, int]]:
    """Expected (out, in) shape of each decoder matrix for ``cfg``."""
    grid = cfg.n_levels * cfg.features_per_level
    pe = 3 * cfg.oneblob_bins
    return {"geo.0": (cfg.geo_hidden, grid + pe), "geo.1": (1 + cfg.geo_feat_dim, cfg.geo_hidden),
            "color.0": (cfg.color_hidden, pe + cfg.geo_feat_dim), "color.1": (3, cfg.color_hidden)}


def init_decoders(cfg: MapConfig, generator: torch.Generator) -> dict[str, torch.Tensor]:
    """Fresh weights, uniform in +-1/sqrt(fan_in) (torch ``Linear``'s default range)."""
    out = {}
    for k, (o, i) in decoder_shapes(cfg).items():
        bound = 1.0 / math.sqrt(i)
        out[k] = (torch.rand(o, i, generator=generator, dtype=torch.float32) * 2 - 1) * bound
    return out


def check_decoders(weights: dict[str, torch.Tensor], cfg: MapConfig, source: str) -> None:
    """Raise ValueError naming ``source`` if ``weights`` do not fit ``cfg``."""
    shapes = decoder_shapes(cfg)
    missing = [k for k in shapes if k not in weights]
    if missing:
        raise ValueError(f"Decoder weights from {source} lack the matrices {missing}; expected "
                         f"the keys {list(shapes)} as written by ramensim.agents.map.pretrain.save_decoders.")
    for k, shp in shapes.items():
        got = tuple(weights[k].shape)
        if got != shp:
            raise ValueError(f"Decoder weights from {source}: matrix {k!r} has shape {got} but "
                             f"the map configuration needs {shp} (levels x features, OneBlob "
                             f"bins and decoder widths must match the pretrained decoders); "
                             f"pretrain decoders for this configuration or use the defaults.")


class Decoders:
    """Evaluates the two decoders; split first-layer matrices avoid concatenations.

    Frozen decoders on the CPU get a :class:`DecoderKernel` (forward + hand-written
    backward, no autograd graph) whose backend is ``backend`` (``auto``: chosen by
    measurement, agents/map/backend.py; ``c`` / ``torch``: forced); ``native=False`` forces
    ``torch``. Trainable decoders (pretraining) use autograd through :meth:`forward`.
    """

    def __init__(self, weights: dict[str, torch.Tensor], cfg: MapConfig, device: torch.device,
                 trainable: bool = False, backend: str | None = None) -> None:
        grid = cfg.n_levels * cfg.features_per_level
        pe = 3 * cfg.oneblob_bins
        self.params = {k: weights[k].detach().to(device=device, dtype=torch.float32).clone()
                       .requires_grad_(trainable) for k in KEYS}
        self.grid_dim, self.pe_dim = grid, pe
        self.trainable = trainable
        self.kernel: DecoderKernel | None = None
        self.choice = None
        if not trainable and device.type == "cpu":
            forced = backend or (cfg.decoder_backend if cfg.native else "torch")
            self.choice = _backend.select("decoder", _backend.decoder_shape(cfg), device, forced,
                                          threads=cfg.threads)
            self.kernel = DecoderKernel(self.choice.backend, self.params, grid, pe, device,
                                        self.choice.threads)

    @property
    def fused(self) -> bool:
        """True when a forward + hand-written backward kernel (either backend) is in use."""
        return self.kernel is not None

    @property
    def backend(self) -> str:
        """'c', 'torch' (frozen, no autograd) or 'autograd' (trainable / non-CPU)."""
        return self.kernel.backend if self.kernel is not None else "autograd"

    def fused_forward(self, feats: torch.Tensor, pe: torch.Tensor,
                      keep: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """Forward, no autograd: (sdf (N,), raw colour (N, 3)); ``keep``: store the ReLU
        masks for ``fused_backward(..., kept=True)``."""
        assert self.kernel is not None
        return self.kernel.forward(feats, pe, keep)

    def fused_sdf(self, feats: torch.Tensor, pe: torch.Tensor) -> torch.Tensor:
        """The SDF alone, no autograd (truncation units, (N,)); equal to ``fused_forward``'s."""
        assert self.kernel is not None
        return self.kernel.sdf(feats, pe)

    def fused_backward(self, feats: torch.Tensor, pe: torch.Tensor, dsdf: torch.Tensor,
                       draw: torch.Tensor, kept: bool = False) -> torch.Tensor:
        """d loss / d grid features (N, L*F) from d loss / d sdf (N,) and d loss / d raw
        colour (N, 3): from the masks of ``fused_forward(..., keep=True)`` (``kept``) or
        recomputing the forward pass."""
        assert self.kernel is not None
        return self.kernel.backward(feats, pe, dsdf, draw, kept)

    def weights(self) -> dict[str, torch.Tensor]:
        """Detached copies of the four matrices."""
        return {k: v.detach().clone() for k, v in self.params.items()}

    def pe_terms(self, pe: torch.Tensor) -> torch.Tensor:
        """``pe @ [W_geo0[:, grid:]; W_col0[:, :pe]]^T`` (N, geo_hidden + color_hidden):
        the OneBlob parts of both first layers in one matrix product."""
        w0, c0 = self.params["geo.0"], self.params["color.0"]
        w = torch.cat([w0[:, self.grid_dim:], c0[:, :self.pe_dim]], dim=0)
        return pe @ w.t()

    def forward(self, grid_feats: torch.Tensor, pe: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(sdf in truncation units (N,), raw colour (N, 3)) from grid features (N, L*F)
        and OneBlob features (N, 3*bins)."""
        w0, w1 = self.params["geo.0"], self.params["geo.1"]
        c0, c1 = self.params["color.0"], self.params["color.1"]
        gh = w0.shape[0]
        pt = self.pe_terms(pe)
        hid = torch.relu(torch.addmm(pt[:, :gh], grid_feats, w0[:, :self.grid_dim].t()))
        sdf = hid @ w1[0]
        h = hid @ w1[1:].t()
        chid = torch.relu(torch.addmm(pt[:, gh:], h, c0[:, self.pe_dim:].t()))
        return sdf, chid @ c1.t()
