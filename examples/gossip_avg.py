"""Gossip averaging: a consensus method in one file (docs/EXTENDING.md, part 1).

Each mapping round, every robot takes B local optimiser steps on its own data, then mixes
its map with the mean of the neighbours' maps it holds:

    Theta_i <- (1 - mix) Theta_i + mix * mean_j Theta_j                       (G-1)

Load it with ``plugins: [gossip_avg.py]`` in a scenario, or ``--plugin gossip_avg.py``.
"""
from __future__ import annotations

from typing import Sequence

import torch
from pydantic import BaseModel, ConfigDict, Field

from ramensim.agents.consensus.base import check_theta, finish
from ramensim.agents.consensus.registry import MethodSpec, register
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult


class GossipSettings(BaseModel):
    """The block ``consensus.gossip_avg`` of a scenario."""

    model_config = ConfigDict(extra="forbid")

    mix: float = Field(0.5, ge=0.0, le=1.0)
    """Share of the neighbours' mean mixed in after the local steps (fraction), eq. G-1."""


class GossipAveraging:
    """One robot's side of the method."""

    name = "gossip_avg"
    communicates = True  # it sends its map to its neighbours

    def __init__(self, n: int, steps: int, mix: float) -> None:
        self.n, self.steps, self.mix = n, steps, mix

    def round(self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int) -> RoundResult:
        theta = check_theta(learner, self.n, self.name)  # the map's n parameters, changed in place
        losses = []
        for _ in range(self.steps):  # B local steps on this robot's own keyframes
            scalars, grad = learner.loss_and_grad()
            losses.append(scalars["loss"])
            learner.optimizer_step(grad)
        if copies:  # eq. G-1 with the copies the stale policy chose
            mean = torch.stack([c.theta for c in copies]).mean(0)
            theta.mul_(1.0 - self.mix).add_(mean, alpha=self.mix)
        return finish({"loss": sum(losses) / len(losses), "copies_used": float(len(copies)),
                       "grad_evals": float(self.steps)}, theta)

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        return {"theta": learner.theta.detach().clone()}  # what every neighbour receives

    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        return {}  # nothing per link: every neighbour gets the same message


register(MethodSpec(
    name="gossip_avg", settings=GossipSettings,
    build=lambda settings, cfg, ctx: GossipAveraging(ctx.n, cfg.primal_steps, settings.mix),
    memory_vectors=(2, 2),
    description="gossip averaging: B local steps, then mixing with the neighbours' mean (eq. G-1)"))
