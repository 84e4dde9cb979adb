"""DSGT (gradient tracking): ``Theta_i <- sum_j a_ij (Theta_j - alpha y_j)``,
``y_i <- sum_j a_ij y_j + g_i(Theta_i^new) - g_i(Theta_i^old)`` (sums include self), one
update per mapping round (official code). ``step: plain`` is that textbook step; ``step: adam``
(the scenario default, ``DsgtConfig``) mixes the parameters and takes the learner's Adam step
along the mixed tracker instead (docs/CONSENSUS.md).

``y_i`` starts as ``g_i(Theta^0)``, evaluated by the first ``payload`` or ``round`` call
(whichever comes first; that call costs one extra gradient evaluation). Starting every
tracker at its own gradient keeps ``sum_i y_i = sum_i g_i`` with doubly stochastic mixing;
sending ``y = 0`` before that would bias the fixed point for ever.
Mixing over the copies used, as in DSGD (``mixing_weights``).
"""
from __future__ import annotations

from typing import Sequence

import torch
from pydantic import Field

from ramensim.agents.consensus.base import (EVERY_SCALAR, check_copy, check_mixing_args, check_theta, finish,
                                            mixing_weights)
from ramensim.agents.consensus.dsgd import DsgdConfig
from ramensim.agents.copies import NeighbourCopy
from ramensim.agents.learner import Learner
from ramensim.core.results import RoundResult
from ramensim.agents.consensus.registry import MethodSpec, register


class DsgtConfig(DsgdConfig):
    """DSGT: DSGD with a gradient tracker y_i (the same settings as DSGD's)."""

    alpha: float = Field(1e-2, gt=0.0)
    """Plain step size along the tracked gradient (parameter units per gradient unit)."""


class DsgtMethod:
    """DSGT for one agent."""

    name = "dsgt"
    communicates = True

    def __init__(self, n: int, alpha: float, mixing: str = "uniform", degree: int = 0,
                 step: str = "plain", device: str | torch.device = "cpu") -> None:
        check_mixing_args("dsgt", n, alpha, mixing)
        self.n, self.alpha, self.mixing, self.degree = n, float(alpha), mixing, int(degree)
        self.device = torch.device(device)
        """Where the method's state lives: the device of the agent's map (``map.device``)."""
        self.step = step
        """'plain': Theta <- sum a (Theta - alpha y); 'adam': Theta <- sum a Theta, then the
        learner's Adam step along the mixed tracker sum a y."""
        self._plain = 1.0 if step == "plain" else 0.0
        self.y = torch.zeros(n, dtype=torch.float32, device=self.device)
        """Gradient tracker y_i (gradient units)."""
        self._g_old = torch.zeros(n, dtype=torch.float32, device=self.device)
        self._buf = torch.empty(n, dtype=torch.float32, device=self.device)
        self._ybuf = torch.empty(n, dtype=torch.float32, device=self.device)
        self._started = False

    def round(
        self, learner: Learner, copies: Sequence[NeighbourCopy], n_neighbours: int
    ) -> RoundResult:
        """Mix (Theta - alpha y) and y over self and the copies, then track the new gradient."""
        theta = check_theta(learner, self.n, self.name)
        keys = ("theta", "y", "degree") if self.mixing == "metropolis" else ("theta", "y")
        for c in copies:
            check_copy(c, self.n, self.name, keys)
        self.degree = int(n_neighbours)
        evals = 1 + self.ensure_started(learner)
        a_ii, a_j = mixing_weights(copies, n_neighbours, self.mixing, self.name)
        return self.mix_and_track(learner, theta, copies, a_ii, a_j, self.y, self._g_old, evals)

    def mix_and_track(self, learner: Learner, theta: torch.Tensor, copies: Sequence[NeighbourCopy], a_ii: float,
                      a_j: Sequence[float], y_self: torch.Tensor, g_prev: torch.Tensor, evals: int) -> RoundResult:
        """The round's arithmetic: mix ``(Theta - alpha y)`` and ``y`` with weights ``a_ii``
        (self, tracker ``y_self``) and ``a_j`` (the copies), step, then
        ``y <- mixed y + g(Theta_new) - g_prev`` (gradient units). :meth:`round` passes the
        robot's newest tracker and last gradient; a diagnostic may pass older ones
        (``tools/dsgt_tracker_drift.py --matched-lag``)."""
        with torch.no_grad():
            buf, ybuf = self._buf, self._ybuf
            torch.mul(theta, a_ii, out=buf)
            buf.add_(y_self, alpha=-self.alpha * a_ii * self._plain)
            torch.mul(y_self, a_ii, out=ybuf)
            for a, c in zip(a_j, copies):
                buf.add_(c.theta, alpha=a)
                buf.add_(c.tensors["y"], alpha=-self.alpha * a * self._plain)
                ybuf.add_(c.tensors["y"], alpha=a)
            theta.copy_(buf)
        if self.step == "adam":
            learner.optimizer_step(ybuf.clone())
        scalars, g = learner.loss_and_grad()
        with torch.no_grad():
            torch.sub(g, g_prev, out=self.y)
            self.y.add_(ybuf)
            self._g_old.copy_(g)
            y_norm = float(torch.linalg.vector_norm(self.y).item())
        return finish({"loss": float(scalars["loss"]), "copies_used": float(len(copies)),
                       "self_weight": a_ii, "tracker_norm": y_norm, "grad_evals": float(evals)}, theta,
                      EVERY_SCALAR, self.name)

    def planned_grad_evals(self) -> int:
        """Gradient evaluations of the next round: one, plus one to initialise the tracker
        on the first (:meth:`ensure_started`)."""
        return 1 + (0 if self._started else 1)

    @property
    def started(self) -> bool:
        """True once the tracker has been initialised (:meth:`ensure_started`)."""
        return self._started

    @property
    def last_gradient(self) -> torch.Tensor:
        """g_i at the robot's parameters after its last round (its first gradient before
        that; gradient units): the ``g_prev`` of its next round. The method's own tensor:
        read it, clone it to keep it."""
        return self._g_old

    def ensure_started(self, learner: Learner) -> int:
        """Initialise y_i = g_i(Theta_i) once; returns the gradient evaluations spent (0 or 1)."""
        if self._started:
            return 0
        _, g0 = learner.loss_and_grad()
        with torch.no_grad():
            self.y.copy_(g0)
            self._g_old.copy_(g0)
        self._started = True
        return 1

    def payload(self, learner: Learner) -> dict[str, torch.Tensor]:
        """``theta``, tracker ``y`` and ``degree`` (int32, 1); initialises y on first use."""
        self.ensure_started(learner)
        return {"theta": learner.theta.detach().clone(), "y": self.y.clone(),
                "degree": torch.tensor([self.degree], dtype=torch.int32)}


    def link_payloads(self) -> dict[int, dict[str, torch.Tensor]]:
        """Nothing per link: every neighbour gets the same message."""
        return {}


register(MethodSpec(
    name="dsgt", build=lambda s, cfg, ctx: DsgtMethod(ctx.n, s.alpha, s.mixing, ctx.degree, s.step,
                                                       ctx.device),
    settings=DsgtConfig, description="DSGD with a gradient tracker",
    message_arrays=lambda cfg: {"theta": "float", "y": "float", "degree": "int"},
    steps_per_round="one", memory_vectors=(4, 4)))  # y, g_old and two buffers; per neighbour its copy and a message (theta, y)
