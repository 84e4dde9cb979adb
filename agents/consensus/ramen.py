"""RAMEN: uncertainty-weighted decentralised C-ADMM (eq. 14-19).

Per neighbour j, with per-parameter weights ``w_ij`` (own) and ``w_ji`` (neighbour's) from
eq. 19 and elementwise operations:
- consensus target (eq. 14): ``z_ij = (w_ij Theta_i^t + w_ji Theta_j) / (w_ij + w_ji)``;
- dual (eq. 17): ``p_i += 2 sum_j w_ij w_ji / (w_ij + w_ji) (Theta_i^t - Theta_j)``;
- primal (eq. 16): ``L_obj(Theta) + Theta . p_i + sum_j sum_k w_ij[k] (Theta[k] - z_ij[k])^2``,
  gradient ``p_i + 2 sum_j w_ij (Theta - z_ij)``, minimised by B optimiser steps.
With ``w_ij = w_ji = rho`` this is DiNNO (eq. 9) exactly.
The own counts u_i are the learner's current ``visits``; u_j comes with the copy.
"""
from __future__ import annotations

import torch
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ramensim.agents.consensus import _native
from ramensim.agents.consensus.admm import AdmmMethod, admm_arrays
from ramensim.agents.consensus.weights import edge_weights, weight_line
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.agents.consensus.registry import MethodSpec, register


class RamenConfig(BaseModel):
    """RAMEN: uncertainty-weighted C-ADMM (eq. 14-19)."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    rho: float = Field(1e-4, gt=0.0)
    """ADMM penalty rho (objective units per squared parameter unit); the default is the official code's."""
    beta_u: float | None = Field(None, gt=0.0)
    """Upper bound of the weights, eq. 19 (same unit as rho); None means rho (official code)."""
    beta_l: float | None = Field(None, gt=0.0)
    """Lower bound of the weights, eq. 19 (same unit as rho); None means rho / 1000 (official code)."""
    count_observation_only: bool = True
    """Eq. 18 counts only gradients of the observation losses (dimensionless flag; False = official code, smoothness included)."""

    @model_validator(mode="after")
    def _bounds_ordered(self) -> RamenConfig:
        if self.resolved_beta_l() > self.resolved_beta_u():
            raise ValueError(
                f"consensus.ramen: beta_l = {self.resolved_beta_l()} is larger than beta_u = "
                f"{self.resolved_beta_u()}; expected 0 < beta_l <= beta_u (eq. 19 maps visit counts "
                "linearly onto [beta_l, beta_u])."
            )
        return self

    def resolved_beta_u(self) -> float:
        """beta_u with its default (rho) applied."""
        return self.rho if self.beta_u is None else self.beta_u

    def resolved_beta_l(self) -> float:
        """beta_l with its default (rho / 1000) applied."""
        return self.rho / 1000.0 if self.beta_l is None else self.beta_l


class RamenMethod(AdmmMethod):
    """RAMEN (eq. 14-19) for one agent."""

    name = "ramen"
    copy_keys = ("theta", "visits")

    def __init__(self, n: int, primal_steps: int, beta_l: float, beta_u: float, primal: str = "joint",
                 dual: str = "node", agent: int = 0, local_gradient_scale: float = 1.0,
                 dual_step: float = 1.0, device: str | torch.device = "cpu") -> None:
        super().__init__(n, primal_steps, primal, dual, agent, local_gradient_scale, dual_step, device)
        if not 0.0 < beta_l <= beta_u:
            raise ValueError(f"ramen: beta_l = {beta_l}, beta_u = {beta_u}; expected 0 < beta_l <= beta_u.")
        self.beta_l = float(beta_l)
        self.beta_u = float(beta_u)

    def _scratch_layout(self) -> dict[str, tuple[int, torch.dtype]]:
        """ADMM's work vectors and RAMEN's: A, w_ij, w_ji, 2 h_ij (n float32), u_i + u_j (n, the
        counts' dtype: int32 from the map; replaced in a round whose counts have another) and the
        edge kernel's partial sums (3 doubles per block); lent per round."""
        f32 = torch.float32
        return {**super()._scratch_layout(), "_a": (self.n, f32), "_wi": (self.n, f32), "_wj": (self.n, f32),
                "_h": (self.n, f32), "_usum": (self.n, torch.int32),
                "_part": (3 * (-(-self.n // _native.SUM_BLOCK)), torch.float64)}

    def _begin(self, learner: Learner) -> None:
        self._a.zero_()
        if self._usum.dtype != learner.visits.dtype:
            self._usum = torch.empty(self.n, dtype=learner.visits.dtype, device=self.device)

    def _edge(self, learner: Learner, c: NeighbourCopy, d: torch.Tensor,
              incr: torch.Tensor | None) -> tuple[float, float, float, torch.Tensor]:
        # the raw difference goes straight into ``incr`` when it is wanted (no copy)
        t, a, wi, wj, h = self._t if incr is None else incr, self._a, self._wi, self._wj, self._h
        if self._kernel_takes(learner, c, d, t):
            return self._edge_native(learner, c, d, t)
        edge_weights(learner.visits, c.tensors["visits"], self.beta_l, self.beta_u, wi, wj, self._usum)  # eq. 19
        torch.mul(wi, wj, out=h)
        torch.add(wi, wj, out=wj)  # wj now holds w_ij + w_ji
        h.div_(wj).mul_(2.0)  # 2 h_ij = 2 w_ij w_ji / (w_ij + w_ji), the dual coefficient (eq. 17)
        torch.sub(self._theta_t, c.theta, out=t)
        d.addcmul_(h, t)  # dual increment of this edge (eq. 17)
        a.add_(wi, alpha=2.0)  # A = 2 sum_j w_ij   (gradient of eq. 16)
        res = float(torch.dot(t, t).item())
        wmean = float(wi.mean().item())
        # penalty at Theta_i^t: w_ij (Theta_i^t - z_ij)^2 = (h t)^2 / w_ij   (eq. 14)
        torch.mul(h, t, out=wj).mul_(0.5).square_().div_(wi)
        return res, wmean, float(wj.sum().item()), h

    def _kernel_takes(self, learner: Learner, c: NeighbourCopy, d: torch.Tensor,
                      t: torch.Tensor) -> bool:
        """Whether the compiled edge kernel takes this edge: int32 counts and a float32
        Theta_j, contiguous on the CPU (the toy learner's int64 counts go the torch way; the
        method's own buffers, ``d`` and ``t`` among them, always are float32 vectors)."""
        if _native.get_lib() is None:
            return False

        def ok(x: torch.Tensor, dtype: torch.dtype) -> bool:
            return (x.dtype == dtype and x.is_contiguous() and x.device.type == "cpu"
                    and x.numel() == self.n)
        return (ok(learner.visits, torch.int32) and ok(c.tensors["visits"], torch.int32)
                and ok(c.theta, torch.float32))

    def _edge_native(self, learner: Learner, c: NeighbourCopy, d: torch.Tensor,
                     t: torch.Tensor) -> tuple[float, float, float, torch.Tensor]:
        """:meth:`_edge` in two passes of ``csrc/ramenedge.c``: the same per-parameter values
        (2 h_ij, the difference, D and A bit for bit; the weights themselves are not stored);
        the three sums in double (they differ from the torch path's float32 sums at rounding)."""
        lib = _native.get_lib()
        ui, uj = learner.visits, c.tensors["visits"]
        threads = max(1, torch.get_num_threads())
        lo_hi = torch.empty(2, dtype=torch.int64)
        lib.usum_minmax(ui.data_ptr(), uj.data_ptr(), self.n, lo_hi.data_ptr(), threads)
        lo, hi = (int(v) for v in lo_hi.tolist())
        # hi == lo: edge_weights' w = beta_u everywhere, here as 0 * u + beta_u (the same floats)
        eps, zeta = weight_line(lo, hi, self.beta_l, self.beta_u) or (0.0, self.beta_u)
        sums = torch.empty(3, dtype=torch.float64)
        lib.ramen_edge(ui.data_ptr(), uj.data_ptr(), self.n, eps, zeta, self.beta_l, self.beta_u,
                       self._theta_t.data_ptr(), c.theta.data_ptr(), self._h.data_ptr(),
                       t.data_ptr(), d.data_ptr(), self._a.data_ptr(), sums.data_ptr(),
                       self._part.data_ptr(), threads)
        res, wsum, pen = sums.tolist()
        return res, wsum / self.n if self.n else 0.0, pen, self._h

    def _curvature(self) -> torch.Tensor:
        return self._a

    def _add_consensus_grad(self, grad: torch.Tensor, theta: torch.Tensor) -> None:
        with torch.no_grad():
            torch.sub(theta, self._theta_t, out=self._t)
            grad.addcmul_(self._a, self._t)
            grad.add_(self._c)

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """``theta`` and ``visits`` (u_i, eq. 18) snapshots (link duals: ``link_payloads``)."""
        return {"theta": learner.theta.detach().clone(), "visits": learner.visits.detach().clone()}


register(MethodSpec(
    name="ramen",
    build=lambda s, cfg, ctx: RamenMethod(ctx.n, cfg.primal_steps, s.resolved_beta_l(), s.resolved_beta_u(),
                                          cfg.primal_update, cfg.dual_update, ctx.agent, cfg.local_gradient_scale,
                                          cfg.dual_step, ctx.device),
    settings=RamenConfig, sends_uncertainty=True,
    message_arrays=lambda cfg: admm_arrays(cfg, visits="int"),
    # the dual p; per neighbour the copy (theta, visits, link half), the link dual and own half,
    # and a message (theta, visits, half); lent per round: ADMM's incr, theta_t, c, t and RAMEN's
    # a, w_i, w_j, h, u-sum
    memory_vectors=(1, 8), round_vectors=9,
    description="uncertainty-weighted C-ADMM (eq. 14-19)"))
