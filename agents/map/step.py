"""One optimiser step's objective, written once: L_obj (eq. 5-6) plus Co-SLAM's smoothness term
and its gradient w.r.t. each map's flat table theta, for one map or a team of maps, and the visit
counts u_i (eq. 18) that the step advances (docs/ALGORITHM.md section 1).

:func:`loss_and_grad` is the definition: which random inputs a step draws and in which order
(each map from its own generator), which terms enter the loss and with which weights, when a
parameter counts as visited (after the observation terms' backward, or after the smoothness
term's as the authors' code), and what the step returns. How each stage's arithmetic is carried
out is the job of a :class:`Stages`:

- :class:`MapStages`: every map on its own measured backends (the compiled kernels or torch,
  ``agents/map/backend.py``): ``NeuralMap.loss_and_grad``;
- ``team_batch.TeamStages``: many maps' stages as one batched torch pass over their stacked
  tables (the team engine's lockstep batches, the form a GPU needs).

A map takes part through :class:`StepMap`, a few public members (``NeuralMap`` has them).

Units: positions in metres (normalised to [0, 1] in the grid), depths in metres, SDF in
truncation units, losses as eq. 6 (rgb unitless, depth and SDF in m^2).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, Sequence

import torch

from .decoders import KEYS, Decoders
from .hashgrid import GridSpec, accumulate_grad, encode
from .objective import observation_grads, observation_losses, smoothness_grads
from .oneblob import oneblob

SCALAR_KEYS = ("loss", "rgb", "depth", "sdf", "fs", "smooth")
"""Keys of the scalars a step returns: the weighted total and the unweighted terms."""

Scalars = dict[str, float]


@dataclass(frozen=True)
class StepDraw:
    """The random inputs of one map's step, drawn from its generator (``StepMap.draw_step``)."""

    rays: torch.Tensor
    """(R, 10) training rays [origin (m), direction, rgb in [0, 1], observed depth (m, 0 = none)]."""
    z: torch.Tensor
    """(R, S) sample depths along each ray (m)."""
    xn: torch.Tensor
    """(R * S, 3) sample positions normalised to the map's bounds, in [0, 1]."""
    lattice: torch.Tensor | None
    """(n^3, 3) the smoothness term's random lattice, normalised; None when its weight is 0."""


class StepMap(Protocol):
    """What a step reads and writes of a map (``NeuralMap`` implements it)."""

    cfg: object
    """The map's ``MapConfig`` (loss weights, truncation, lattice size, ...)."""
    spec: GridSpec
    decoders: Decoders
    count_observation_only: bool
    """Eq. 18 counts the observation terms' gradient only (True, the paper) or also smoothness's."""

    @property
    def theta(self) -> torch.Tensor: ...

    @property
    def grad_buffer(self) -> torch.Tensor:
        """The map's flat gradient buffer (n,), which the step overwrites and returns."""

    def draw_step(self, native: bool | None = None) -> StepDraw | None:
        """The step's random inputs (None before the map's first frame: nothing is drawn)."""

    def count_visits(self, grad: torch.Tensor) -> None:
        """u_i += 1 where ``grad`` is non-zero (eq. 18)."""


class Stages(Protocol):
    """The arithmetic of a step's stages for a list of maps that have data, each with its draw.

    ``observe`` evaluates the observation losses (eq. 5-6) through the grid and the decoders
    and writes each map's gradient of them into its ``grad_buffer``; ``smooth`` evaluates the
    smoothness term and adds ``smooth_weight`` times its gradient. Both return per map what
    the step reports: ``(terms, weighted observation loss)`` and the unweighted smoothness."""

    def draw(self, m: StepMap) -> StepDraw | None: ...

    def observe(self, maps: Sequence[StepMap], draws: Sequence[StepDraw]) -> list[tuple[Scalars, float]]: ...

    def smooth(self, maps: Sequence[StepMap], draws: Sequence[StepDraw]) -> list[float]: ...


def loss_and_grad(maps: Sequence[StepMap], stages: Stages) -> list[tuple[Scalars, torch.Tensor]]:
    """Per map ``(scalars, grad)``: L_obj = sum_k w_k L_k (eq. 6, k = rgb, depth, sdf, fs) +
    smooth_weight * L_smooth, its unweighted terms (``SCALAR_KEYS``), and its gradient w.r.t.
    theta in the map's ``grad_buffer`` (n,), valid until its next step. Each map's visit counts
    advance once (eq. 18). A map without a frame yet gets zero loss and gradient and its visits
    stay. ``stages`` computes the stages (:class:`MapStages`, or the team's batched ones)."""
    out: list[tuple[Scalars, torch.Tensor] | None] = [None] * len(maps)
    live: list[int] = []
    draws: list[StepDraw] = []
    for k, m in enumerate(maps):
        m.grad_buffer.zero_()
        d = stages.draw(m)
        if d is None:
            out[k] = ({key: 0.0 for key in SCALAR_KEYS}, m.grad_buffer)
            continue
        live.append(k)
        draws.append(d)
    if live:
        team = [maps[k] for k in live]
        cfg = team[0].cfg
        observed = stages.observe(team, draws)
        for m in team:
            if m.count_observation_only:
                m.count_visits(m.grad_buffer)
        smooth = stages.smooth(team, draws) if cfg.smooth_weight > 0 else [0.0] * len(team)
        for m in team:
            if not m.count_observation_only:  # the authors' code: counted after the smoothness backward
                m.count_visits(m.grad_buffer)
        for k, m, (terms, obs), s in zip(live, team, observed, smooth):
            out[k] = ({"loss": obs + cfg.smooth_weight * s, **terms, "smooth": s}, m.grad_buffer)
    return out  # type: ignore[return-value]


class MapStages:
    """Each map's stages on its own backends, one map after the other: the hash grid through
    the C kernel or torch (``grid_native``), the decoders' fused forward and hand-written
    backward (or autograd through them when they are trainable or on a GPU, which also leaves
    their gradients in ``decoder_grads``), the observation losses and smoothness through the
    C kernels or torch autograd (``objective_backend``), each on the map's measured threads
    (``grid_threads``, ``torch_threads``). Besides :class:`StepMap` it reads those members of
    a ``NeuralMap`` and ``native`` (its compiled sampler and OneBlob). Stateless: one instance,
    :data:`MAP_STAGES`, serves every map."""

    @staticmethod
    def draw(m) -> StepDraw | None:
        return m.draw_step()

    @staticmethod
    def observe(maps, draws) -> list[tuple[Scalars, float]]:
        return [MapStages._observe(m, d) for m, d in zip(maps, draws)]

    @staticmethod
    def smooth(maps, draws) -> list[float]:
        return [MapStages._smooth(m, d) for m, d in zip(maps, draws)]

    @staticmethod
    def _observe(m, d: StepDraw) -> tuple[Scalars, float]:
        cfg = m.cfg
        t_rgb, t_depth = d.rays[:, 6:9], d.rays[:, 9]
        R, S = d.z.shape
        pe = oneblob(d.xn, cfg.oneblob_bins, m.native, m.grid_threads)
        feats = encode(d.xn, m.theta, m.spec, m.grid_native, threads=m.grid_threads)
        weights = (cfg.rgb_weight, cfg.depth_weight, cfg.sdf_weight, cfg.fs_weight)
        dec = m.decoders
        if dec.fused:  # hand-written decoder backward: rendering and losses by the objective stage
            sdf_f, raw_f = dec.fused_forward(feats, pe, keep=True)
            terms, obs, d_sdf, d_raw = observation_grads(
                sdf_f.reshape(R, S), raw_f.reshape(R, S, 3), d.z, t_rgb, t_depth, cfg.truncation,
                weights, m.objective_backend, m.torch_threads)
            d_feats = dec.fused_backward(feats, pe, d_sdf.reshape(-1), d_raw.reshape(-1, 3), kept=True)
        else:  # autograd through the decoders too (trainable decoders, GPU)
            feats.requires_grad_(True)
            sdf_t, raw_t = dec.forward(feats, pe)
            terms, obs_t = observation_losses(sdf_t.reshape(R, S), raw_t.reshape(R, S, 3), d.z,
                                              t_rgb, t_depth, cfg.truncation, weights)
            inputs = [feats]
            if dec.trainable:
                inputs += [dec.params[k] for k in KEYS]
            grads = torch.autograd.grad(obs_t, inputs)
            d_feats = grads[0]
            if dec.trainable:
                m.decoder_grads = dict(zip(KEYS, grads[1:]))
            obs = float(obs_t.detach())
        accumulate_grad(d.xn, d_feats, m.spec, m.grad_buffer, m.grid_native, threads=m.grid_threads)
        return terms, obs

    @staticmethod
    def _smooth(m, d: StepDraw) -> float:
        cfg = m.cfg
        fsm = encode(d.lattice, m.theta, m.spec, m.grid_native, threads=m.grid_threads)
        smooth, g_s = smoothness_grads(fsm, cfg.smooth_lattice, cfg.smooth_weight, m.objective_backend,
                                       m.torch_threads)
        accumulate_grad(d.lattice, g_s, m.spec, m.grad_buffer, m.grid_native, threads=m.grid_threads)
        return smooth


MAP_STAGES = MapStages()
"""The stages of a map computing its own step (``NeuralMap.loss_and_grad``)."""
