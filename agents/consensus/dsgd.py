"""DSGD: ``Theta_i <- a_ii Theta_i + sum_j a_ij Theta_j - alpha grad L_i(Theta_i)``, one
update per mapping round (official code). ``step: plain`` is that textbook step; ``step: adam``
(the scenario default, ``DsgdConfig``) mixes the parameters and then takes the learner's Adam
step along ``grad L_i`` instead, as a hash-grid map learns nothing with a plain step at any
stable alpha (docs/CONSENSUS.md).

Missing or left-out copies: the mixing row is taken over the copies used (see
``mixing_weights``), so it always sums to one.
"""
from __future__ import annotations

from typing import Literal, Sequence

import torch
from pydantic import BaseModel, ConfigDict, Field

from ramensim.agents.consensus.base import (EVERY_SCALAR, check_copy, check_mixing_args, check_theta, finish,
                                            mixing_weights)
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult
from ramensim.agents.consensus.registry import MethodSpec, register


class DsgdConfig(BaseModel):
    """DSGD: one mixing + gradient step per round."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    alpha: float = Field(1e-2, gt=0.0)
    """Plain gradient step size (parameter units per gradient unit)."""
    mixing: Literal["uniform", "metropolis"] = "uniform"
    """Mixing weights: uniform 1/(m+1) over self and the m copies used, or Metropolis 1/(max(deg_i, deg_j)+1)."""
    step: Literal["adam", "plain"] = "adam"
    """Local step: 'adam' mixes the parameters and then takes the learner's Adam step along the (tracked) gradient, as a hash-grid map needs an adaptive step; 'plain' is the textbook step Theta - alpha * g."""


class DsgdMethod:
    """DSGD for one agent."""

    name = "dsgd"
    communicates = True

    def __init__(self, n: int, alpha: float, mixing: str = "uniform", degree: int = 0,
                 step: str = "plain", device: str | torch.device = "cpu") -> None:
        check_mixing_args("dsgd", n, alpha, mixing)
        self.n, self.alpha, self.mixing, self.degree = n, float(alpha), mixing, int(degree)
        self.device = torch.device(device)
        """Where the method's state lives: the device of the agent's map (``map.device``)."""
        self.step = step
        """'plain': Theta <- mix - alpha g; 'adam': Theta <- mix, then the learner's Adam step with g."""
        self._buf = torch.empty(n, dtype=torch.float32, device=self.device)

    def planned_grad_evals(self) -> int:
        """Gradient evaluations of the next round: one."""
        return 1

    def round(
        self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int
    ) -> RoundResult:
        """Gradient at Theta_i, then mix and step (one gradient evaluation)."""
        theta = check_theta(learner, self.n, self.name)
        keys = ("theta", "degree") if self.mixing == "metropolis" else ("theta",)
        for c in copies:
            check_copy(c, self.n, self.name, keys)
        self.degree = int(n_neighbours)
        a_ii, a_j = mixing_weights(copies, n_neighbours, self.mixing, self.name)
        scalars, grad = learner.loss_and_grad()
        with torch.no_grad():
            buf = self._buf
            torch.mul(theta, a_ii, out=buf)
            for a, c in zip(a_j, copies):
                buf.add_(c.theta, alpha=a)
            if self.step == "plain":
                buf.add_(grad, alpha=-self.alpha)
            theta.copy_(buf)
        if self.step == "adam":
            learner.optimizer_step(grad)
        return finish({"loss": float(scalars["loss"]), "copies_used": float(len(copies)),
                       "self_weight": a_ii, "grad_evals": 1.0}, theta, EVERY_SCALAR, self.name)

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """``theta`` snapshot and this agent's ``degree`` (int32, 1) for Metropolis mixing."""
        return {"theta": learner.theta.detach().clone(),
                "degree": torch.tensor([self.degree], dtype=torch.int32)}


    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        """Nothing per link: every neighbour gets the same message."""
        return {}


register(MethodSpec(
    name="dsgd", build=lambda s, cfg, ctx: DsgdMethod(ctx.n, s.alpha, s.mixing, ctx.degree, s.step,
                                                       ctx.device),
    settings=DsgdConfig, description="decentralised SGD: mixing plus one gradient step per round",
    message_arrays=lambda cfg: {"theta": "float", "degree": "int"},
    steps_per_round="one", memory_vectors=(1, 2)))  # a mixing buffer; per neighbour its copy and a message (theta)
