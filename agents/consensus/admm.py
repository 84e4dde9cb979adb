"""The round shared by the two C-ADMM methods (DiNNO eq. 9, RAMEN eq. 14-17).

Both primal gradients have the form (eq. 9 / eq. 16)

    grad = grad L_obj(Theta) + p_i^{t+1} + A * (Theta - Theta_i^t) + D

where ``D = sum_j 2 h_ij (Theta_i^t - Theta_j)`` is also the dual increment
(``p^{t+1} = p^t + D``, eq. 17 / 9b), ``h_ij = w_ij w_ji / (w_ij + w_ji)`` and
``A = 2 sum_j w_ij`` (DiNNO: ``w = rho``, so ``h = rho / 2`` and ``A = 2 rho m``).
Derivation for RAMEN: ``z_ij = Theta_i^t - (w_ji / (w_ij + w_ji)) (Theta_i^t - Theta_j)``
(eq. 14), so ``2 w_ij (Theta - z_ij) = 2 w_ij (Theta - Theta_i^t) + 2 h_ij (Theta_i^t - Theta_j)``.

So a round computes ``A`` and ``C = p^{t+1} + D`` once, and each of the B primal steps
costs three in-place passes over n numbers, whatever the number of neighbours, with no
allocation (``_add_consensus_grad``).
"""
from __future__ import annotations

import math
from typing import Sequence

import torch

from ramensim.agents.consensus.base import EVERY_SCALAR, check_copy, check_theta, finish
from ramensim.agents.consensus.scratch import LentBuffers
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner, Prox
from ramensim.core.results import RoundResult


DUALS = ("node", "per_link", "antisymmetric")
"""Dual updates of the C-ADMM methods (see ``ConsensusConfig.dual_update``)."""


def admm_arrays(cfg: object, **own: str) -> dict[str, str]:
    """The arrays a C-ADMM method's messages carry (``MethodSpec.message_arrays``): ``theta``,
    the method's ``own`` (RAMEN: ``visits="int"``) and, with ``antisymmetric`` duals, the link
    half ``lam`` (float, one per link, :meth:`AdmmMethod.link_payloads`)."""
    link = {"lam": "float"} if getattr(cfg, "dual_update", None) == "antisymmetric" else {}
    return {"theta": "float", **own, **link}


class AdmmMethod(LentBuffers):
    """Common state and round of DiNNO and RAMEN; subclasses fill ``_prepare``.

    Owned per robot: the dual ``p`` and the per-link duals and halves. The round's work vectors
    (``_theta_t``, ``_c``, ``_incr``, ``_t`` and a subclass's own) are lent for the round from
    ``agents/consensus/scratch.py``'s pool: one set per round running at once, not per robot."""

    name = "admm"
    communicates = True
    copy_keys: tuple[str, ...] = ("theta",)

    def __init__(self, n: int, primal_steps: int, primal: str = "joint", dual: str = "node",
                 agent: int = 0, local_gradient_scale: float = 1.0, dual_step: float = 1.0,
                 device: str | torch.device = "cpu") -> None:
        if n < 1 or primal_steps < 1:
            raise ValueError(
                f"{self.name}: n = {n} parameters and primal_steps = {primal_steps}; expected both >= 1."
            )
        if primal not in ("joint", "prox"):
            raise ValueError(f"{self.name}: primal update {primal!r}; expected 'joint' or 'prox'.")
        if dual not in DUALS:
            raise ValueError(f"{self.name}: dual update {dual!r}; expected one of {DUALS}.")
        self.n = n
        self.device = torch.device(device)
        """Where the method's state lives: the device of the agent's map (``map.device``)."""
        self.primal_steps = primal_steps
        self.primal = primal
        """'joint': the optimiser steps on grad L_obj + consensus gradient (paper, official code);
        'prox': the optimiser steps on grad L_obj + p_i, then the exact proximal step of the
        penalty in the optimiser's metric (docs/CONSENSUS.md, "The primal step")."""
        self.dual = dual
        self.agent = agent
        self.local_gradient_scale = float(local_gradient_scale)
        if not 0.0 < dual_step <= 2.0:
            raise ValueError(f"{self.name}: dual_step = {dual_step}; expected 0 < gamma <= 2.")
        self.dual_step = float(dual_step)
        """gamma: the dual advances by gamma times the increment of eq. 9b / 17."""
        self.p = torch.zeros(n, dtype=torch.float32, device=self.device)
        """Dual p_i (eq. 16-17), gradient units: with per-link duals, their sum."""
        self.links: dict[int, torch.Tensor] = {}
        """Per-link duals lambda_ij by neighbour (``per_link``, ``antisymmetric``)."""
        self._dual_stamp: dict[int, float] = {}
        self.half_links: dict[int, torch.Tensor] = {}
        """``antisymmetric``: this end's half of each link's dual (lambda_ij = own half -
        the neighbour's half), the extra array of the messages on that link."""

    def _scratch_layout(self) -> dict[str, tuple[int, torch.dtype]]:
        """The round's work vectors (n float32 each): the raw difference, Theta_i^t, C = p + D
        and a scratch / prox-centre vector (lent per round, ``agents/consensus/scratch.py``)."""
        f32 = torch.float32
        return {"_incr": (self.n, f32), "_theta_t": (self.n, f32), "_c": (self.n, f32), "_t": (self.n, f32)}

    # --- per round -------------------------------------------------------------------
    def _begin(self, learner: Learner) -> None:
        """Reset the subclass's per-round accumulators (A)."""
        raise NotImplementedError

    def _edge(self, learner: Learner, c: NeighbourCopy, d: torch.Tensor,
              incr: torch.Tensor | None) -> tuple[float, float, float, torch.Tensor | float]:
        """One copy: add the edge's dual increment ``2 h_ij (Theta_i^t - Theta_j)`` to ``d``,
        add ``2 w_ij`` to A; unless ``incr`` is None write the raw difference ``Theta_i^t -
        Theta_j`` (parameter units) into it. Return ``(|Theta_i^t - Theta_j|^2, mean w_ij,
        penalty, 2 h_ij)``; the last (the edge's dual coefficient, objective units per squared
        parameter unit) may be a scratch buffer valid until the next call."""
        raise NotImplementedError

    def _prepare(self, learner: Learner, copies: Sequence[NeighbourCopy]) -> dict[str, float]:
        """Fill ``self._c`` with D = sum_j 2 h_ij (Theta_i^t - Theta_j), A, and advance the dual
        (eq. 9b / 17) as ``self.dual`` says; return ``penalty`` (consensus term of the augmented
        objective at Theta_i^t), ``residual_sq`` and ``mean_weight``."""
        self._begin(learner)
        d, incr = self._c, self._incr
        d.zero_()
        res = pen = wsum = 0.0
        for c in copies:
            r, w, q, coef = self._edge(learner, c, d, None if self.dual == "node" else incr)
            res, wsum, pen = res + r, wsum + w, pen + q
            if self.dual == "node":
                continue
            j = c.agent
            lam = self.links.get(j)
            if lam is None:
                lam = self.links[j] = torch.zeros(self.n, dtype=torch.float32, device=self.device)
            fresh = c.stamp > self._dual_stamp.get(j, -math.inf)  # a copy not yet used for the dual
            if fresh:
                self._dual_stamp[j] = c.stamp
            if self.dual == "per_link":
                if fresh:
                    lam.add_(incr.mul_(coef), alpha=self.dual_step)  # gamma 2 h_ij (Theta_i^t - Theta_j)
                continue
            # antisymmetric, scaled: this end's half advances by half the raw difference on each
            # new copy (parameter units); the link's dual is 2 h_ij (own half - the neighbour's
            # half, sent with its messages), with this round's coefficient
            half = self.half_links.get(j)
            if half is None:
                half = self.half_links[j] = torch.zeros(self.n, dtype=torch.float32, device=self.device)
            if fresh:
                half.add_(incr, alpha=0.5 * self.dual_step)
            held = c.tensors.get("lam")
            if held is None:
                lam.copy_(half)
            else:
                torch.sub(half, held, out=lam)
            lam.mul_(coef)
        if self.dual == "node":
            self.p.add_(d, alpha=self.dual_step)  # every copy used advances the one node dual
        else:
            self.p.zero_()
            for lam in self.links.values():
                self.p.add_(lam)
        m = len(copies)
        return {"penalty": pen, "residual_sq": res, "mean_weight": wsum / m if m else 0.0}

    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        """Per-link extras of the next message: with ``antisymmetric`` duals, this end's half
        of each link's dual goes to the other end (copied by the encoder)."""
        if self.dual != "antisymmetric":
            return {}
        return {j: {"lam": half} for j, half in self.half_links.items()}

    def _add_consensus_grad(self, grad: torch.Tensor, theta: torch.Tensor) -> None:
        """Inner loop: ``grad += A * (theta - theta_t) + C`` in place (no allocation)."""
        raise NotImplementedError

    def _curvature(self) -> torch.Tensor | float:
        """``A = 2 sum_j w_ij`` of this round (a vector for RAMEN, a number for DiNNO)."""
        raise NotImplementedError

    def _prox(self) -> Prox:
        """The round's consensus terms as ``(A/2)|Theta - c|^2 + const`` with ``c = Theta_i^t -
        C / A`` for ``C`` = what ``self._c`` holds when called: ``D`` (the penalty ``sum_j
        w_ij |Theta - z_ij|^2 = D . Theta + (A/2)|Theta - Theta_i^t|^2 + const``, c the weighted
        mean of the targets z_ij, eq. 14 / 16) or ``p + D`` (penalty and dual term ``p . Theta``).
        Needs A > 0: at least one copy; RAMEN's weights are >= beta_l > 0. The dual may enter
        only when ``p / A`` is bounded: with unscaled duals it is not, as eq. 19 rescales
        RAMEN's weights by the growing max count so A shrinks while p keeps the size it was
        accumulated with; ``D / A`` and the scaled antisymmetric dual's ``p / A`` are."""
        a = self._curvature()
        torch.div(self._c, a, out=self._t)
        torch.sub(self._theta_t, self._t, out=self._t)
        return a, self._t

    def round(
        self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int
    ) -> RoundResult:
        """One mapping round (official-code order): weights, dual update with Theta_i^t,
        then B primal steps on the augmented objective starting from Theta_i^t."""
        theta = check_theta(learner, self.n, self.name)
        for c in copies:
            check_copy(c, self.n, self.name, self.copy_keys)
        self._take_scratch()
        try:
            return self._round(learner, theta, copies)
        finally:
            self._give_scratch()

    def _round(self, learner: Learner, theta: torch.Tensor, copies: Sequence[NeighbourCopy]) -> RoundResult:
        with torch.no_grad():
            self._theta_t.copy_(theta)
            stats = self._prepare(learner, copies)  # dual update, e.g. p^{t+1} = p^t + D (eq. 9b / 17)
            m = len(copies)
            # the dual goes into the proximal step when it is bounded against A (scaled
            # antisymmetric duals: |p / A| <= max_j |own half - neighbour's half|); the
            # unscaled node / per-link duals stay in the optimiser's gradient
            dual_in_prox = self.dual == "antisymmetric"
            if not dual_in_prox:
                prox = self._prox() if self.primal == "prox" and m else None  # D alone
            self._c.add_(self.p)  # C = p^{t+1} + D
            if dual_in_prox:
                prox = self._prox() if self.primal == "prox" and m else None  # p + D
            lin = float(torch.dot(self._theta_t, self.p).item())
            dual_norm = float(torch.linalg.vector_norm(self.p).item())
        losses: list[float] = []
        for _ in range(self.primal_steps):
            scalars, grad = learner.loss_and_grad()
            losses.append(float(scalars["loss"]))
            if self.local_gradient_scale != 1.0:
                grad.mul_(self.local_gradient_scale)
            if prox is None:
                self._add_consensus_grad(grad, theta)
                learner.optimizer_step(grad)
            else:
                if not dual_in_prox:
                    grad.add_(self.p)  # the dual's linear term, with grad L_obj
                learner.optimizer_step(grad, prox)
        out = {
            "loss": sum(losses) / len(losses),
            "loss_last": losses[-1],
            "aug_objective": losses[0] + lin + stats["penalty"],
            "dual_norm": dual_norm,
            "primal_residual": math.sqrt(stats["residual_sq"] / (m * self.n)) if m else 0.0,
            "copies_used": float(m),
            "mean_weight": stats["mean_weight"],
            "grad_evals": float(self.primal_steps),
        }
        return finish(out, theta, EVERY_SCALAR, self.name)

    def planned_grad_evals(self) -> int:
        """Gradient evaluations of the next round (B primal steps), known before it runs, so
        the team engine can price the round on the compute clock at its start."""
        return self.primal_steps

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """``theta`` snapshot (and ``visits`` for RAMEN)."""
        return {"theta": learner.theta.detach().clone()}
