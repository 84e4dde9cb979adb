"""The SimPy processes of one agent: camera, mapper (on its own compute clock) and radio.

Agents never wait for each other: the mapper works on whatever neighbour copies it holds
when a round starts, and the radio hands messages to the channel without blocking.
All times are simulated seconds.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Protocol, Sequence

import numpy as np
import simpy

from ramensim.agents.frames import Frame
from ramensim.channels.events import Diverged, EventSink, FrameCaptured, Notice, RoundCompleted, null_sink

log = logging.getLogger(__name__)


@dataclass
class RoundOutcome:
    """What one mapping round did: optimiser ``iterations`` (for the cost model), named
    ``scalars`` and, per neighbour, the age (s) of the copy used (None = left out)."""

    iterations: int
    scalars: dict[str, float] = field(default_factory=dict)
    copy_ages: dict[int, float | None] = field(default_factory=dict)


class MapperStep(Protocol):
    """The pluggable work of an agent's mapper (neural map + consensus, or a toy problem)."""

    def add_frame(self, frame: Frame, keyframe: bool) -> None: ...

    def has_data(self) -> bool: ...

    def run_round(self, now: float) -> RoundOutcome: ...

    def make_payload(self, now: float) -> tuple[Any, int]:
        """Snapshot of the state to send: (payload, honest size in bytes)."""
        ...

    def is_finite(self) -> bool: ...


class RadioPort(Protocol):
    """What an agent needs of the channel."""

    def neighbours(self, agent: int) -> list[int]: ...

    def window_open(self, a: int, b: int, t: float) -> bool: ...

    def next_window_open(self, a: int, b: int, t: float) -> float | None: ...

    def window_close_after(self, a: int, b: int, t: float) -> float: ...

    def send(self, src: int, dst: int, payload: Any, nbytes: int, stamp: float) -> Any: ...


@dataclass
class ClockModel:
    """Cost of a round on the compute clock: ``iterations * seconds_per_iteration *
    speed_factor * U(1-jitter, 1+jitter)`` (s), or measured wall time x speed factor."""

    seconds_per_iteration: float
    speed_factor: float = 1.0
    jitter: float = 0.0
    wall: bool = False

    def cost(self, iterations: int, wall_seconds: float, rng: np.random.Generator) -> float:
        base = wall_seconds if self.wall else iterations * self.seconds_per_iteration
        factor = 1.0 + rng.uniform(-self.jitter, self.jitter) if self.jitter > 0 else 1.0
        return max(base * self.speed_factor * factor, 1e-9)


@dataclass
class RadioSchedule:
    """'every_round' or 'periodic' (every ``period_s`` s)."""

    mode: str = "every_round"
    period_s: float = 5.0


class AgentProcess:
    """Camera, mapper and radio processes of agent ``agent`` in ``env``.

    ``frame_times`` are the capture times (s, relative to the agent's start) of its frames
    and ``render(k)`` produces frame k; every ``keyframe_every``-th frame is a keyframe
    unless ``is_keyframe(k)`` says otherwise. ``frame_agent(k)`` names the robot that took
    frame k (the centralised learner is fed by every robot's camera).
    """

    def __init__(self, env: simpy.Environment, agent: int, step: MapperStep, radio: RadioPort | None,
                 frame_times: Sequence[float], render: Callable[[int], Frame], keyframe_every: int,
                 clock: ClockModel, schedule: RadioSchedule, rng: np.random.Generator,
                 start_delay: float = 0.0, emit: EventSink = null_sink,
                 on_round: Callable[[int, int], None] | None = None,
                 is_keyframe: Callable[[int], bool] | None = None,
                 frame_agent: Callable[[int], int] | None = None) -> None:
        self.env = env
        self.agent = agent
        self.step = step
        self.radio = radio
        self.frame_times = list(frame_times)
        self.render = render
        self.keyframe_every = max(1, int(keyframe_every))
        self.clock = clock
        self.schedule = schedule
        self.rng = rng
        self.start_delay = float(start_delay)
        self.emit = emit
        self.on_round = on_round
        self.is_keyframe = is_keyframe or (lambda k: k % self.keyframe_every == 0)
        self.frame_agent = frame_agent or (lambda k: agent)
        self.rounds = 0
        self.frames_seen = 0
        self.diverged: tuple[int, str] | None = None
        self.busy_s = 0.0
        self._data_ready = env.event()
        self._state: tuple[Any, int, float] | None = None  # payload, nbytes, stamp
        self._sent_stamp: dict[int, float] = {}
        env.process(self._camera())
        env.process(self._mapper())
        if radio is not None:
            if schedule.mode == "periodic":
                env.process(self._periodic_radio())
            env.process(self._window_watch())

    # -- camera -------------------------------------------------------------
    def _camera(self):
        env = self.env
        for k, t_rel in enumerate(self.frame_times):
            t = self.start_delay + t_rel
            if t > env.now:
                yield env.timeout(t - env.now)
            if self.diverged is not None:
                return
            frame = self.render(k)
            keyframe = self.is_keyframe(k)
            self.step.add_frame(frame, keyframe)
            self.frames_seen += 1
            self.emit(FrameCaptured(env.now, self.frame_agent(k), frame.index, keyframe, frame.rgb, frame.depth,
                                    frame.c2w, frame.K.as_tuple()))
            if not self._data_ready.triggered:
                self._data_ready.succeed()

    # -- mapper -------------------------------------------------------------
    def _mapper(self):
        env = self.env
        if self.start_delay > 0:
            yield env.timeout(self.start_delay)
        yield self._data_ready
        while True:
            t0 = env.now
            wall0 = time.perf_counter()
            outcome = self.step.run_round(t0)
            wall = time.perf_counter() - wall0
            cost = self.clock.cost(outcome.iterations, wall, self.rng)
            yield env.timeout(cost)
            self.busy_s += cost
            self.rounds += 1
            loss = outcome.scalars.get("loss", 0.0)
            if not (math.isfinite(loss) and self.step.is_finite()):
                reason = "non-finite loss" if not math.isfinite(loss) else "non-finite map parameters"
                self.diverged = (self.rounds, reason)
                log.warning("agent %d diverged in round %d at t=%.2f s: %s", self.agent, self.rounds,
                            env.now, reason)
                self.emit(Diverged(env.now, self.agent, self.rounds, reason))
                self.emit(Notice(env.now, f"agent {self.agent} diverged in round {self.rounds}: {reason}",
                                 "error", self.agent))
                return
            self.emit(RoundCompleted(env.now, self.agent, self.rounds, cost, dict(outcome.scalars),
                                     dict(outcome.copy_ages)))
            if self.on_round is not None:
                self.on_round(self.agent, self.rounds)
            if self.radio is not None:
                payload, nbytes = self.step.make_payload(env.now)
                self._state = (payload, nbytes, env.now)
                if self.schedule.mode == "every_round":
                    self._send_state()

    # -- radio --------------------------------------------------------------
    def _send_state(self, only: Sequence[int] | None = None) -> None:
        """Send the latest state to every current neighbour whose window is open (and
        which has not yet received this very state)."""
        if self._state is None or self.radio is None or self.diverged is not None:
            return
        payload, nbytes, stamp = self._state
        now = self.env.now
        targets = self.radio.neighbours(self.agent) if only is None else only
        for j in targets:
            if only is None and self._sent_stamp.get(j) == stamp:
                continue  # this very state already went to j; a window opening resends it
            if not self.radio.window_open(self.agent, j, now):
                continue
            self.radio.send(self.agent, j, payload, nbytes, stamp)
            self._sent_stamp[j] = stamp

    def _periodic_radio(self):
        env = self.env
        if self.start_delay > 0:
            yield env.timeout(self.start_delay)
        while self.diverged is None:
            yield env.timeout(self.schedule.period_s)
            self._send_state()

    def _window_watch(self):
        """When a window to a neighbour opens, send the latest state at once, so that
        'exchange only every 30 s' works whatever the length of a round.

        Uses the channel's ``next_window_open(a, b, t)`` (earliest time >= t at which the
        window is open; None if never) and ``window_close_after(a, b, t)`` (when the window
        open at t closes; inf if never): while a window is open, the next opening is the
        first one after it closes."""
        env = self.env
        radio = self.radio
        assert radio is not None
        while self.diverged is None:
            now = env.now
            openings: dict[int, float] = {}
            for j in radio.neighbours(self.agent):
                if radio.window_open(self.agent, j, now):
                    close = radio.window_close_after(self.agent, j, now)
                    if not math.isfinite(close):
                        continue  # always open: every round's send covers it
                    t_open = radio.next_window_open(self.agent, j, close)
                else:
                    t_open = radio.next_window_open(self.agent, j, now)
                if t_open is not None and t_open > now:
                    openings[j] = t_open
            if not openings:
                return
            nxt = min(openings.values())
            yield env.timeout(nxt - now)
            self._send_state([j for j, t in openings.items() if t <= nxt])
