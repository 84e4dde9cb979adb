"""local (no communication) and centralised (one learner with everybody's data): B
optimiser steps on L_obj alone per round. The floor and the ceiling of docs/ALGORITHM.md."""
from __future__ import annotations

from typing import Sequence

import torch

from ramensim.agents.consensus.base import EVERY_SCALAR, check_theta, finish
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.consensus.registry import MethodSpec, register
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult


class LocalMethod:
    """B optimiser steps on the local objective; copies are ignored, nothing is sent."""

    communicates = False

    def __init__(self, n: int, primal_steps: int, name: str = "local") -> None:
        if n < 1 or primal_steps < 1:
            raise ValueError(f"{name}: n = {n}, primal_steps = {primal_steps}; expected both >= 1.")
        self.n, self.primal_steps, self.name = n, primal_steps, name

    def round(
        self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int
    ) -> RoundResult:
        """B steps of ``loss_and_grad`` + ``optimizer_step``."""
        theta = check_theta(learner, self.n, self.name)
        losses = []
        for _ in range(self.primal_steps):
            scalars, grad = learner.loss_and_grad()
            losses.append(float(scalars["loss"]))
            learner.optimizer_step(grad)
        return finish({"loss": sum(losses) / len(losses), "loss_last": losses[-1],
                       "copies_used": 0.0, "grad_evals": float(self.primal_steps)}, theta, EVERY_SCALAR, self.name)

    def planned_grad_evals(self) -> int:
        """Gradient evaluations of the next round (B optimiser steps)."""
        return self.primal_steps

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """Nothing: local and centralised agents do not communicate."""
        return {}


    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        """Nothing per link: every neighbour gets the same message."""
        return {}


register(MethodSpec(
    name="local", build=lambda s, cfg, ctx: LocalMethod(ctx.n, cfg.primal_steps, "local"),
    communicates=False, reference=True, description="each robot maps alone (the floor)"))
register(MethodSpec(
    name="centralised", build=lambda s, cfg, ctx: LocalMethod(ctx.n, cfg.primal_steps, "centralised"),
    communicates=False, reference=True, merges_frames=True,
    description="one learner fed by every robot's camera (the ceiling)"))
