"""A method added the way a user adds one: this file plus its registry line.

'gossip': B local Adam steps, then Theta <- (1 - mix) Theta + mix * mean of the copies
used. Not a method of the paper; it only proves that a new method needs no other edit."""
from __future__ import annotations

from typing import Sequence

import torch
from pydantic import BaseModel, ConfigDict, Field

from ramensim.agents.consensus.base import check_theta, finish
from ramensim.agents.consensus.registry import MethodSpec, register
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult


class GossipConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")

    mix: float = Field(0.5, ge=0.0, le=1.0)
    """Share of the neighbours' mean mixed in after the local steps (fraction)."""


class GossipMethod:
    name = "gossip"
    communicates = True

    def __init__(self, n: int, primal_steps: int, mix: float) -> None:
        self.n, self.primal_steps, self.mix = n, primal_steps, mix
        self.rounds_with_copies = 0

    def round(self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int) -> RoundResult:
        theta = check_theta(learner, self.n, self.name)
        losses = []
        for _ in range(self.primal_steps):
            scalars, grad = learner.loss_and_grad()
            losses.append(float(scalars["loss"]))
            learner.optimizer_step(grad)
        if copies:
            self.rounds_with_copies += 1
            mean = torch.stack([c.theta for c in copies]).mean(0)
            theta.mul_(1.0 - self.mix).add_(mean, alpha=self.mix)
        return finish({"loss": sum(losses) / len(losses), "copies_used": float(len(copies)),
                       "grad_evals": float(self.primal_steps)}, theta)

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        return {"theta": learner.theta.detach().clone()}


    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        """Nothing per link: every neighbour gets the same message."""
        return {}


register(MethodSpec(name="gossip", settings=GossipConfig,
                    build=lambda s, cfg, ctx: GossipMethod(ctx.n, cfg.primal_steps, s.mix),
                    description="test-only: local steps, then mixing with the neighbours' mean"))
