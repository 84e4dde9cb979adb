"""Many robots' maps as one computation: the stages of the step (``step.py``: L_obj, eq. 5-6, and
its gradient) for every map of a team in one batched torch pass over stacked parameters, the form
a GPU needs (few large operations instead of a few small ones per robot).

:func:`team_loss_and_grad` is :func:`ramensim.agents.map.step.loss_and_grad` with
:class:`TeamStages`. Each map draws its rays, samples and smoothness lattice from its own
generator as alone; the batch only changes how the arithmetic is grouped, so each map's values
are those of its own torch path (``map.native: false``) up to float rounding:

- the hash grids are one table of shape (B * L * T, F): map b's rows are offset by b * L * T,
  so one gather (forward) and one ``index_add_`` (backward) serve every map;
- the frozen decoders are shared (every robot's map holds the same weights): one matrix product
  over all B * R * S samples;
- the observation losses keep a robot axis: rendering weights and compositing are per ray, and
  every mean and count of eq. 5-6 (the rgb and depth errors over rays with depth, the
  free-space and SDF terms with their batch-dependent balance ``1 - n_f / (n_f + n_b)``) is
  taken per robot, so the gradient of the sum over robots is each robot's own gradient;
- the smoothness term (Co-SLAM's, on each map's random lattice) likewise per robot.

Units: positions in metres, depths in metres, SDF in truncation units, losses as eq. 6.
"""
from __future__ import annotations

from typing import Sequence

import torch

from .hashgrid import _torch_indices_weights
from .neural_map import NeuralMap
from .oneblob import oneblob_torch
from .render import sdf_weights
from .step import Scalars, StepDraw, loss_and_grad


def check_team(maps: Sequence[NeuralMap]) -> None:
    """Raise ValueError unless the maps can share one batch: the same grid, configuration,
    device and decoder weights, each on the torch path with its own gradient buffer."""
    m0 = maps[0]
    for k, m in enumerate(maps):
        same_grid = (m.spec.n_params == m0.spec.n_params and m.spec.log2_T == m0.spec.log2_T
                     and torch.equal(m.spec.scales, m0.spec.scales) and torch.equal(m.spec.res, m0.spec.res))
        if not same_grid or m.cfg != m0.cfg or m.device != m0.device:
            raise ValueError(f"team batch: map {k} has another grid, configuration or device than map 0; "
                             "a batch needs maps built from one scenario.")
        if m.grid_native or (m.device.type == "cpu" and m.objective_backend != "torch"):
            raise ValueError(f"team batch: map {k} runs C kernels (grid or objective); the batched "
                             "pass is the torch path (map.native: false, or a GPU).")
        if k and any(not torch.equal(m.decoders.params[key], m0.decoders.params[key])
                     for key in m0.decoders.params):
            raise ValueError(f"team batch: map {k}'s decoders differ from map 0's; a batch shares them.")


def _decoder_forward_backward(m0: NeuralMap, feats: torch.Tensor, pe: torch.Tensor):
    """The shared frozen decoders over every sample: (sdf, raw) and a backward function from
    (d_sdf, d_raw) to d_feats (the hand-written torch backward when the map has it, else
    autograd through the decoders)."""
    dec = m0.decoders
    if dec.fused:
        sdf, raw = dec.fused_forward(feats, pe, keep=True)

        def backward(d_sdf: torch.Tensor, d_raw: torch.Tensor) -> torch.Tensor:
            return dec.fused_backward(feats, pe, d_sdf, d_raw, kept=True)
        return sdf, raw, backward
    f = feats.detach().requires_grad_(True)
    with torch.enable_grad():
        sdf_t, raw_t = dec.forward(f, pe)

    def backward_ag(d_sdf: torch.Tensor, d_raw: torch.Tensor) -> torch.Tensor:
        (g,) = torch.autograd.grad([sdf_t, raw_t], [f], [d_sdf, d_raw])
        return g
    return sdf_t.detach(), raw_t.detach(), backward_ag


def team_observation_losses(sdf: torch.Tensor, raw: torch.Tensor, z: torch.Tensor, rgb_obs: torch.Tensor,
                            depth_obs: torch.Tensor, truncation: float,
                            weights: tuple[float, float, float, float]) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
    """Eq. 5-6 per robot: sdf (B, R, S) truncation units, raw (B, R, S, 3), z (B, R, S) m,
    rgb_obs (B, R, 3), depth_obs (B, R) m (0 = no depth). Returns the unweighted terms (B,)
    each and the weighted observation loss (B,), differentiable; each robot's values are
    those of ``objective.observation_losses`` on its own rays."""
    B, R, S = sdf.shape
    w = sdf_weights(sdf.reshape(B * R, S), z.reshape(B * R, S), truncation).reshape(B, R, S)
    rgb = (w[..., None] * torch.sigmoid(raw)).sum(dim=2)          # (B, R, 3)
    depth = (w * z).sum(dim=2)                                     # (B, R) m
    valid = (depth_obs > 0).to(sdf.dtype)                          # rays with depth
    n_valid = valid.sum(dim=1)
    denom = n_valid.clamp_min(1.0)
    l_rgb = (((rgb - rgb_obs) ** 2).sum(dim=2) * valid).sum(dim=1) / (3.0 * denom)
    l_depth = (((depth - depth_obs) ** 2) * valid).sum(dim=1) / denom
    has = (n_valid > 0).to(sdf.dtype)
    l_rgb, l_depth = l_rgb * has, l_depth * has
    D = depth_obs[..., None]
    front = (z < D - truncation).to(sdf.dtype)
    back = (z > D + truncation).to(sdf.dtype)
    band = (1.0 - front) * (1.0 - back) * (D > 0).to(sdf.dtype)
    n_f, n_b = front.sum(dim=(1, 2)), band.sum(dim=(1, 2))
    total = (n_f + n_b).clamp_min(1.0)
    l_fs = (1.0 - n_f / total) * ((sdf * front - front) ** 2).mean(dim=(1, 2))
    l_sdf = (1.0 - n_b / total) * ((((z + sdf * truncation) - D) * band) ** 2).mean(dim=(1, 2))
    obs = weights[0] * l_rgb + weights[1] * l_depth + weights[2] * l_sdf + weights[3] * l_fs
    return {"rgb": l_rgb, "depth": l_depth, "sdf": l_sdf, "fs": l_fs}, obs


def _team_encode(xn: torch.Tensor, tables: torch.Tensor, spec, per_map: int):
    """Features (N, L*F) of points ``xn`` (N, 3) whose first ``per_map`` rows belong to map 0,
    the next to map 1, ...; ``tables`` (B, n). Returns (feats, idx, w) for the backward."""
    idx, w = _torch_indices_weights(xn, spec)                      # (N, L, 8)
    B = tables.shape[0]
    rows_per_map = spec.n_params // spec.features
    offs = torch.arange(B, device=xn.device).repeat_interleave(per_map) * rows_per_map
    idx = idx + offs[:, None, None]
    tab = tables.reshape(-1, spec.features)
    feats = (tab[idx] * w[..., None]).sum(dim=2).reshape(xn.shape[0], spec.out_dim)
    return feats, idx, w


def _team_scatter(grad: torch.Tensor, idx: torch.Tensor, w: torch.Tensor, d_feats: torch.Tensor, spec) -> None:
    """``grad`` (B * n) += the hash grids' backward of ``d_feats`` (one ``index_add_``)."""
    g = d_feats.reshape(idx.shape[0], spec.n_levels, 1, spec.features) * w[..., None]
    grad.view(-1, spec.features).index_add_(0, idx.reshape(-1), g.reshape(-1, spec.features))


class TeamStages:
    """The step's stages for B maps (same grid, configuration, device and decoders; torch path)
    as one batched pass over their stacked tables (see the module's docstring). One instance
    serves one step: ``observe`` stacks the tables that ``smooth`` reads again."""

    def __init__(self) -> None:
        self._tables: torch.Tensor | None = None  # (B, n): the maps' theta, stacked
        self._grad: torch.Tensor | None = None    # (B, n): the batch's gradient, before the maps' buffers

    @staticmethod
    def draw(m: NeuralMap) -> StepDraw | None:
        return m.draw_step(native=False)

    def observe(self, maps: Sequence[NeuralMap], draws: Sequence[StepDraw]) -> list[tuple[Scalars, float]]:
        """Eq. 5-6 for every map in one pass; each map's gradient into its ``grad_buffer``."""
        m0 = maps[0]
        cfg, spec = m0.cfg, m0.spec
        B, R, S = len(maps), draws[0].rays.shape[0], draws[0].z.shape[1]
        self._tables = torch.stack([m.theta for m in maps])           # (B, n)
        xn = torch.cat([d.xn for d in draws])
        pe = oneblob_torch(xn, cfg.oneblob_bins)
        feats, idx, w = _team_encode(xn, self._tables, spec, R * S)
        sdf, raw, backward = _decoder_forward_backward(m0, feats, pe)
        rows = torch.stack([d.rays for d in draws])                  # (B, R, 10)
        sdf_b = sdf.reshape(B, R, S).detach().requires_grad_(True)
        raw_b = raw.reshape(B, R, S, 3).detach().requires_grad_(True)
        weights = (cfg.rgb_weight, cfg.depth_weight, cfg.sdf_weight, cfg.fs_weight)
        with torch.enable_grad():
            terms, obs = team_observation_losses(sdf_b, raw_b, torch.stack([d.z for d in draws]),
                                                 rows[..., 6:9], rows[..., 9], cfg.truncation, weights)
            d_sdf, d_raw = torch.autograd.grad(obs.sum(), [sdf_b, raw_b])
        d_feats = backward(d_sdf.reshape(-1), d_raw.reshape(-1, 3))
        self._grad = torch.zeros(B, spec.n_params, dtype=torch.float32, device=m0.device)
        _team_scatter(self._grad, idx, w, d_feats, spec)
        for b, m in enumerate(maps):
            m.grad_buffer.copy_(self._grad[b])
        obs_f = obs.detach().double().tolist()
        terms_f = {key: t.detach().double().tolist() for key, t in terms.items()}
        return [({key: terms_f[key][b] for key in ("rgb", "depth", "sdf", "fs")}, obs_f[b])
                for b in range(B)]

    def smooth(self, maps: Sequence[NeuralMap], draws: Sequence[StepDraw]) -> list[float]:
        """Co-SLAM's smoothness term for every map in one pass; ``smooth_weight`` times its
        gradient added to each map's ``grad_buffer``."""
        assert self._tables is not None and self._grad is not None, "observe() first"
        cfg, spec = maps[0].cfg, maps[0].spec
        B, n = len(maps), cfg.smooth_lattice
        xs = torch.cat([d.lattice for d in draws])
        fsm, sidx, sw = _team_encode(xs, self._tables, spec, n ** 3)
        f = fsm.reshape(B, n, n, n, -1).detach().requires_grad_(True)
        with torch.enable_grad():
            tv = (((f[:, 1:] - f[:, :-1]) ** 2).sum(dim=(1, 2, 3, 4))
                  + ((f[:, :, 1:] - f[:, :, :-1]) ** 2).sum(dim=(1, 2, 3, 4))
                  + ((f[:, :, :, 1:] - f[:, :, :, :-1]) ** 2).sum(dim=(1, 2, 3, 4))) / float(n ** 3)
            (g_s,) = torch.autograd.grad(cfg.smooth_weight * tv.sum(), [f])
        self._grad.zero_()
        _team_scatter(self._grad, sidx, sw, g_s.reshape(B * n ** 3, -1), spec)
        for b, m in enumerate(maps):
            m.grad_buffer.add_(self._grad[b])
        return tv.detach().double().tolist()


@torch.no_grad()
def team_loss_and_grad(maps: Sequence[NeuralMap]) -> list[tuple[Scalars, torch.Tensor]]:
    """``[m.loss_and_grad() for m in maps]`` as one batched computation (see the module's
    docstring): per map its scalars (``loss`` = weighted total, the unweighted terms) and its
    flat gradient buffer (n,), valid until its next call; each map's visit counts (eq. 18)
    updated. A map without a frame yet gets zero loss and gradient, as alone."""
    if not maps:
        return []
    check_team(maps)
    return loss_and_grad(maps, TeamStages())
