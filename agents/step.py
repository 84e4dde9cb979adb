"""The mapper step of one agent: a local learner (neural map or toy problem), its
consensus method, its neighbour copies and its message encoding, behind the
:class:`ramensim.agents.process.MapperStep` interface the SimPy processes drive."""
from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import torch

from ramensim.agents.consensus.base import ConsensusMethod, call_hook
from ramensim.agents.copies import CopyStore, NeighbourCopy, RoundContext
from ramensim.agents.encoding import decode, encode
from ramensim.core.frames import Frame
from ramensim.agents.learner import Learner
from ramensim.agents.process import Outbox
from ramensim.agents.rounds.round import RoundOutcome, RoundWork


class ConsensusStep:
    """Runs mapping rounds (docs/ALGORITHM.md section 2) on whatever copies the store holds.

    ``degree()`` returns the agent's current number of neighbours in the graph;
    ``theta0`` is the shared initial parameter vector (needed by the sparse encoding);
    ``wire`` maps array keys to wire types (``consensus.wire``, ``agents/encoding.py``).
    """

    def __init__(self, agent: int, learner: Learner, method: ConsensusMethod, store: CopyStore,
                 encoding: str, theta0: torch.Tensor, degree: Callable[[], int],
                 stale_policy: str = "latest", max_age_s: float = math.inf,
                 add_frame: Callable[[Frame, bool], None] | None = None, first_round_steps: int = 0,
                 wire: Mapping[str, str] | None = None) -> None:
        self.agent = agent
        self.learner = learner
        self.method = method
        self.store = store
        self.encoding = encoding
        self.wire = dict(wire or {})
        """Per-array wire types overriding ``encoding``'s (``consensus.wire``; empty: none)."""
        self.theta0 = theta0
        self.degree = degree
        self.stale_policy = stale_policy
        self.max_age_s = max_age_s
        self._add_frame = add_frame if add_frame is not None else getattr(learner, "add_frame", None)
        self.messages_received = 0
        self.first_round_steps = int(first_round_steps)
        self._in_flight = False
        self._held_frames: list[tuple[Frame, bool]] = []

    # MapperStep -----------------------------------------------------------------
    def add_frame(self, frame: Frame, keyframe: bool) -> None:
        """Give the learner a camera frame; while a round is in flight (submitted to the team
        engine, not yet collected) the frame is held and applied when the round is collected,
        so that a round's inputs stay those it started with (``agents/rounds/round.py``)."""
        if self._add_frame is None:
            return
        if self._in_flight:
            self._held_frames.append((frame, keyframe))
            return
        self._add_frame(frame, keyframe)

    def run_round(self, now: float) -> RoundOutcome:
        """One round at ``now`` (s), computed at once."""
        work = self.begin_round(now)
        try:
            return work()
        finally:
            self.end_round()

    def begin_round(self, now: float) -> RoundWork:
        """Fix a round's inputs at ``now`` (s): the copies the stale policy selects, this agent's
        degree; return the computation, which touches only this agent's learner and method
        (safe on another thread while the event loop goes on; run on the learner the engine
        hands it, the map itself or lockstep mode's proxy of it). Until :meth:`end_round`,
        frames are held back."""
        selection = self.store.select(now, self.stale_policy, self.max_age_s)
        degree = self.degree()
        ctx = RoundContext.of(self.agent, now, selection.copies, degree)
        self._in_flight = True

        def compute(learner: Learner) -> RoundOutcome:
            warmup = self._first_round_steps(learner)
            result = call_hook(self.method.round, learner, selection.copies, degree, ctx=ctx)
            if warmup:
                result.grad_evals += warmup
                result.scalars["grad_evals"] = float(result.grad_evals)
            return RoundOutcome(result, selection.copy_ages())
        return RoundWork(self.learner, compute)

    def end_round(self) -> None:
        """The round's result is collected: apply the frames held back meanwhile, in order."""
        self._in_flight = False
        held, self._held_frames = self._held_frames, []
        for frame, keyframe in held:
            self.add_frame(frame, keyframe)

    def planned_grad_evals(self) -> int | None:
        """Gradient evaluations the next round will charge the compute clock (the method's
        ``planned_grad_evals`` plus the first round's warm-up steps), or None when the method
        cannot say in advance (then its rounds are computed inline)."""
        plan = getattr(self.method, "planned_grad_evals", None)
        if plan is None:
            return None
        n = plan()
        return None if n is None else int(n) + self.first_round_steps

    def _first_round_steps(self, learner: Learner) -> int:
        """The authors' first-frame mapping: ``first_round_steps`` optimiser steps on L_obj
        alone before the first round (0 after it), on the round's ``learner``."""
        steps, self.first_round_steps = self.first_round_steps, 0
        for _ in range(steps):
            _, grad = learner.loss_and_grad()
            learner.optimizer_step(grad)
        return steps

    def make_payload(self, now: float) -> Outbox:
        ctx = RoundContext(self.agent, now, self.degree())
        enc = encode(call_hook(self.method.payload, self.learner, ctx=ctx), self.encoding, self.theta0, self.wire)
        links = {}
        link_kind = "float32" if self.encoding == "sparse" else self.encoding
        for j, tensors in self.method.link_payloads().items():
            extra = encode(tensors, link_kind, wire=self.wire)
            links[j] = (extra, extra.nbytes)
        return Outbox(enc, enc.nbytes, links)

    def is_finite(self) -> bool:
        return bool(torch.isfinite(self.learner.theta).all().item())

    # channel side ----------------------------------------------------------------
    def receive(self, src: int, payload: Any, stamp: float, now: float) -> None:
        """Keep a neighbour's message as its latest copy (decoded to dense tensors)."""
        self.messages_received += 1
        held = self.store.get(src)
        if held is not None and stamp <= held.stamp:
            return  # an older state overtaken by a newer one: nothing to decode
        if isinstance(payload, tuple):  # shared state + this link's extras
            base, extra = payload
            tensors = {**decode(base, self.theta0), **decode(extra)}
        else:
            tensors = decode(payload, self.theta0)
        # next to the map's own state (a no-op on the CPU; a map on CUDA keeps its copies there)
        device = self.learner.theta.device
        tensors = {k: v.to(device) for k, v in tensors.items()}
        self.store.put(NeighbourCopy(src, tensors, stamp, now))
