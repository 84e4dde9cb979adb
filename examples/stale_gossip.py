"""Staleness-weighted gossip: a method that reads the simulated time (docs/EXTENDING.md, part 1).

Each mapping round, B local steps, then each neighbour's copy is mixed in with a weight that
halves every ``half_life_s`` seconds of its age (now - the sender's stamp):

    w_j = mix * 2^(-age_j / half_life_s) / (1 + m),    Theta_i <- (1 - sum_j w_j) Theta_i + sum_j w_j Theta_j   (SG-1)

(m = copies used). The round's ``ctx`` (a ``RoundContext``) gives ``ctx.now`` and
``ctx.ages[j]``; a hook without a ``ctx`` parameter is called as before.
"""
from __future__ import annotations

from typing import Sequence

import torch
from pydantic import BaseModel, ConfigDict, Field

from ramensim.agents.consensus.base import check_theta, finish
from ramensim.agents.consensus.registry import MethodSpec, register
from ramensim.agents.copies import NeighbourCopy, RoundContext
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult


class StaleGossipSettings(BaseModel):
    """The block ``consensus.stale_gossip`` of a scenario."""

    model_config = ConfigDict(extra="forbid")

    mix: float = Field(0.5, ge=0.0, le=1.0)
    """Largest share mixed in, for a copy of age 0 (fraction), eq. SG-1."""
    half_life_s: float = Field(2.0, gt=0.0)
    """Age at which a copy's weight halves (seconds), eq. SG-1."""


class StaleGossip:
    name = "stale_gossip"
    communicates = True

    def __init__(self, n: int, steps: int, mix: float, half_life_s: float) -> None:
        self.n, self.steps, self.mix, self.half_life_s = n, steps, mix, half_life_s

    def round(self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int,
              ctx: RoundContext) -> RoundResult:
        theta = check_theta(learner, self.n, self.name)
        losses = []
        for _ in range(self.steps):
            scalars, grad = learner.loss_and_grad()
            losses.append(float(scalars["loss"]))
            learner.optimizer_step(grad)
        weights = [self.mix * 2.0 ** (-ctx.ages[c.agent] / self.half_life_s) / (1 + len(copies)) for c in copies]
        with torch.no_grad():
            theta.mul_(1.0 - sum(weights))
            for w, c in zip(weights, copies):
                theta.add_(c.theta, alpha=w)
        ages = [ctx.ages[c.agent] for c in copies]
        return finish({"loss": sum(losses) / len(losses), "copies_used": float(len(copies)),
                       "oldest_copy_s": max(ages, default=float("nan")),  # NaN without a copy: a diagnostic
                       "mixed_in": float(sum(weights)), "grad_evals": float(self.steps)}, theta)

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        return {"theta": learner.theta.detach().clone()}

    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        return {}


register(MethodSpec(
    name="stale_gossip", settings=StaleGossipSettings,
    build=lambda settings, cfg, ctx: StaleGossip(ctx.n, cfg.primal_steps, settings.mix, settings.half_life_s),
    memory_vectors=(2, 2),
    description="gossip whose copies weigh less as they age (eq. SG-1)"))
