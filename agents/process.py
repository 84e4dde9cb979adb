"""The SimPy processes of one agent: camera, mapper (on its own compute clock) and radio.

Agents never wait for each other: the mapper works on whatever neighbour copies it holds
when a round starts, and the radio hands messages to the channel without blocking.
All times are simulated seconds.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any, Protocol, Sequence

import numpy as np
import simpy

from ramensim.core.frames import Frame, FrameFeed
from ramensim.core.events import Diverged, EventSink, FrameCaptured, Notice, RoundCompleted, null_sink
from ramensim.agents.rounds.engine import Engine
from ramensim.agents.rounds.round import RoundOutcome, RoundWork, live_round

__all__ = ["AgentProcess", "ClockModel", "MapperStep", "Outbox", "RadioPort", "RadioSchedule", "RoundOutcome"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Outbox:
    """The state an agent sends after a round, taken at its end: ``payload`` (``nbytes`` on
    the air) for every neighbour, plus per-link extras ``links[j] = (extra, extra_nbytes)``
    that only the message to j carries (e.g. the dual of that link)."""

    payload: Any
    nbytes: int
    links: dict[int, tuple[Any, int]] = field(default_factory=dict)

    def for_link(self, j: int) -> tuple[Any, int]:
        """What goes to neighbour ``j``: ``(payload, nbytes)`` or ``((payload, extra), nbytes + extra_nbytes)``."""
        extra = self.links.get(j)
        if extra is None:
            return self.payload, self.nbytes
        return (self.payload, extra[0]), self.nbytes + extra[1]


class MapperStep(Protocol):
    """The pluggable work of an agent's mapper (neural map + consensus, or a toy problem):
    every call :class:`AgentProcess` and the life of a round (``agents/rounds/round.py``) make of it."""

    def add_frame(self, frame: Frame, keyframe: bool) -> None: ...

    def run_round(self, now: float) -> RoundOutcome:
        """One round at ``now`` (s), computed at once (the inline path)."""
        ...

    def begin_round(self, now: float) -> RoundWork:
        """Fix a round's inputs at ``now`` (s) and return its computation (a ``RoundWork``: the
        learner it trains and ``compute(learner)``), which the team engine runs now or off the
        event loop, on the learner or a stand-in (lockstep mode's proxy); frames that arrive
        meanwhile are held until :meth:`end_round`."""
        ...

    def end_round(self) -> None:
        """The round's result was collected: apply the frames held back meanwhile."""
        ...

    def planned_grad_evals(self) -> int | None:
        """Gradient evaluations the next round will report, or None when unknown in advance
        (then its rounds are computed inline)."""
        ...

    def make_payload(self, now: float) -> Outbox:
        """Snapshot of the state to send, with honest sizes in bytes."""
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
    """An agent's compute clock. A round costs ``iterations * seconds_per_iteration *
    speed_factor * U(1-jitter, 1+jitter)`` simulated seconds (or, with ``wall``, the measured
    wall time x speed factor); the agent starts ``start_delay`` s after time 0. ``rng`` draws
    the jitter (needed only when ``jitter > 0``)."""

    seconds_per_iteration: float
    speed_factor: float = 1.0
    jitter: float = 0.0
    wall: bool = False
    start_delay: float = 0.0
    rng: np.random.Generator | None = None

    def cost(self, iterations: int, wall_seconds: float) -> float:
        """Simulated seconds of a round of ``iterations`` that took ``wall_seconds`` of wall time."""
        base = wall_seconds if self.wall else iterations * self.seconds_per_iteration
        if self.jitter > 0:
            if self.rng is None:
                raise ValueError("ClockModel: jitter > 0 needs a seeded rng (none was given).")
            factor = 1.0 + self.rng.uniform(-self.jitter, self.jitter)
        else:
            factor = 1.0
        return max(base * self.speed_factor * factor, 1e-9)


@dataclass
class RadioSchedule:
    """'every_round' or 'periodic' (every ``period_s`` s)."""

    mode: str = "every_round"
    period_s: float = 5.0


class AgentProcess:
    """Camera, mapper and radio processes of agent ``agent`` in ``env``.

    ``frames`` is what its camera delivers (capture times relative to its start, rendering,
    keyframe choice, the robot that took each frame); ``clock`` prices its rounds and holds
    its start delay; ``radio`` is the channel (None: the agent never sends) and ``schedule``
    when it sends. Every event goes to ``emit``. With ``engine``, rounds whose cost is known
    at their start are computed by the team engine (``agents/rounds/``) while the simulated
    round runs, several agents' at once; the results are those of computing them inline.
    Every round lives one way, whatever the engine: ``agents/rounds/round.py``.
    """

    def __init__(self, env: simpy.Environment, agent: int, step: MapperStep, frames: FrameFeed,
                 clock: ClockModel, radio: RadioPort | None = None,
                 schedule: RadioSchedule | None = None, emit: EventSink = null_sink,
                 engine: Engine | None = None, on_error: str = "isolate") -> None:
        self.env = env
        self.agent = agent
        self.step = step
        self.frames = frames
        self.clock = clock
        self.radio = radio
        self.schedule = schedule or RadioSchedule()
        self.start_delay = float(clock.start_delay)
        self.emit = emit
        self.engine = engine
        """The team engine that computes this agent's rounds off the event loop (None: inline)."""
        self.on_error = on_error
        """``run.on_robot_error``: a round that raises stops this robot alone (isolate) or the run (stop)."""
        self.rounds = 0
        self.frames_seen = 0
        self.diverged: tuple[int, str] | None = None
        self.failed: str | None = None
        """Why this agent stopped on an error of its own (its camera's frame reader failed)."""
        self.busy_s = 0.0
        self._data_ready = env.event()
        self._state: tuple[Outbox, float] | None = None  # what to send, stamp
        self._sent_stamp: dict[int, float] = {}
        env.process(self._camera())
        env.process(self._mapper())
        if radio is not None:
            if self.schedule.mode == "periodic":
                env.process(self._periodic_radio())
            env.process(self._window_watch())

    def mark_failed(self, exc: BaseException) -> None:
        """Stop this agent for good because its round raised ``exc`` (``run.on_robot_error:
        isolate``): its reason names the exception's type, message and where it was raised (the
        innermost frame outside ramensim and the installed packages: a plugin's file:line)."""
        env = self.env
        self.failed = f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]} ({_raised_at(exc)})"
        log.error("agent %d failed in round %d at t=%.2f s: %s", self.agent, self.rounds + 1, env.now, self.failed)
        self.emit(Notice(env.now, f"agent {self.agent} failed: {self.failed}", "error", self.agent))

    def mark_diverged(self, reason: str) -> bool:
        """Stop this agent for good: its map diverged in the current round (``reason``: why).
        Logs it and emits ``Diverged`` and a ``Notice``; the camera and mapper stop at their next
        step. Used by the mapper (non-finite loss or map) and by the run's divergence rule
        (``ramensim.divergence``: loss growth, evaluation collapse). False if it had already."""
        if self.diverged is not None:
            return False
        env = self.env
        self.diverged = (self.rounds, reason)
        log.warning("agent %d diverged in round %d at t=%.2f s: %s", self.agent, self.rounds, env.now, reason)
        self.emit(Diverged(env.now, self.agent, self.rounds, reason))
        self.emit(Notice(env.now, f"agent {self.agent} diverged in round {self.rounds}: {reason}", "error",
                         self.agent))
        return True

    # -- camera -------------------------------------------------------------
    def _camera(self):
        env = self.env
        feed = self.frames
        for k, t_rel in enumerate(feed.times):
            t = self.start_delay + t_rel
            if t > env.now:
                yield env.timeout(t - env.now)
            if self.diverged is not None or self.failed is not None:
                return
            try:
                frame = feed.render(k)
            except (OSError, ValueError, RuntimeError) as exc:
                self.failed = f"frame {k} could not be read: {' '.join(str(exc).split())}"
                log.error("agent %d stops at t=%.2f s: %s", self.agent, env.now, self.failed)
                self.emit(Notice(env.now, f"agent {self.agent} failed: {self.failed}", "error", self.agent))
                return
            keyframe = feed.is_keyframe(k)
            self.step.add_frame(frame, keyframe)
            self.frames_seen += 1
            self.emit(FrameCaptured(env.now, feed.taken_by(k), frame.index, keyframe, frame.rgb, frame.depth,
                                    frame.c2w, frame.K.as_tuple()))
            if not self._data_ready.triggered:
                self._data_ready.succeed()

    # -- mapper -------------------------------------------------------------
    def _mapper(self):
        env = self.env
        if self.start_delay > 0:
            yield env.timeout(self.start_delay)
        yield self._data_ready
        while self.diverged is None and self.failed is None:
            try:  # one path: plan, fix inputs, submit, wait the cost, collect, check
                outcome, cost = yield from live_round(env, self.step, self.engine, self.clock, self.agent)
                result = outcome.result
            except simpy.Interrupt:
                raise
            except Exception as exc:  # noqa: BLE001 - a robot's own fault stays with it
                if self.on_error != "isolate":
                    raise
                self.mark_failed(exc)
                return
            self.busy_s += cost
            self.rounds += 1
            loss = result.loss
            if not (math.isfinite(loss) and self.step.is_finite()):
                self.mark_diverged(_divergence_reason(loss, self.step.is_finite(), getattr(result, "nonfinite", ())))
                return
            self.emit(RoundCompleted(env.now, self.agent, self.rounds, cost, dict(result.scalars),
                                     dict(outcome.copy_ages)))
            if self.radio is not None:
                try:
                    self._state = (self.step.make_payload(env.now), env.now)
                except Exception as exc:  # noqa: BLE001 - the method's payload hook is the robot's own
                    if self.on_error != "isolate":
                        raise
                    self.mark_failed(exc)
                    return
                if self.schedule.mode == "every_round":
                    self._send_state()

    # -- radio --------------------------------------------------------------
    def _send_state(self, only: Sequence[int] | None = None) -> None:
        """Send the latest state to every current neighbour whose window is open (and
        which has not yet received this very state)."""
        if self._state is None or self.radio is None or self.diverged is not None or self.failed is not None:
            return
        outbox, stamp = self._state
        now = self.env.now
        targets = self.radio.neighbours(self.agent) if only is None else only
        for j in targets:
            if only is None and self._sent_stamp.get(j) == stamp:
                continue  # this very state already went to j; a window opening resends it
            if not self.radio.window_open(self.agent, j, now):
                continue
            payload, nbytes = outbox.for_link(j)
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


def _divergence_reason(loss: float, map_finite: bool, nonfinite: tuple[str, ...]) -> str:
    """Why a round diverged, naming what was non-finite: the loss itself, else the map's
    parameters, else the method's state (the keys its ``finish`` named)."""
    if "loss" in nonfinite or (not nonfinite and not math.isfinite(loss)):
        return "non-finite loss"
    if not map_finite:
        return "non-finite map parameters"
    state = [k for k in nonfinite if k not in ("loss", "theta_norm")]
    return f"non-finite method state ({', '.join(state)})" if state else "non-finite loss"


def _raised_at(exc: BaseException) -> str:
    """``file:line`` where ``exc`` was raised: the innermost frame of the user's code (outside
    the ramensim package and the installed packages), else the innermost frame."""
    import os
    import traceback

    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return "unknown place"
    pkg = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    own = [f for f in frames if not os.path.abspath(f.filename).startswith(pkg)
           and "site-packages" not in f.filename and "dist-packages" not in f.filename]
    f = (own or frames)[-1]
    return f"{f.filename}:{f.lineno}"

