"""Event dataclasses that the simulation emits to whoever listens (e.g. the Rerun recorder).

This module is the leaf of the import graph: channels, agents and ramensim all emit
these through a plain callback ``emit(event)``; nothing here imports a recorder.
All times are simulated seconds.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Callable


@dataclass(frozen=True, slots=True)
class Event:
    """Base class: something that happened at simulated time ``t`` (s)."""

    t: float


EventSink = Callable[[Event], None]


def null_sink(_event: Event) -> None:
    """An event sink that drops everything."""


# --- channel -----------------------------------------------------------------

class Fate(IntEnum):
    """What became of a message: delivered, or dropped for one reason. The one list of drop
    reasons: the channel decides them, messages.csv and the run's totals count them
    (``channels.accounting``), ``MessageDropped.reason`` carries their names and the recorder
    colours them (``recording.style``). A new reason is one member here plus its colour."""

    DELIVERED = 0
    LOSS = 1
    """The message's Bernoulli said lost (1 - success_rate, or the radio models' success)."""
    PACKET_LOSS = 2
    """Packet mode: a fragment was lost (and not recovered by retransmission)."""
    OUT_OF_RANGE = 3
    """The endpoints were out of radio range (at send time or during the transfer)."""
    WINDOW_CLOSED = 4
    """The link's communication window was closed at send time or closed during the transfer."""
    QUEUE_OVERFLOW = 5
    """The transmitter's queue already held ``queue_limit`` messages."""
    NO_LINK = 6
    """No edge of the topology joins the endpoints."""
    COLLISION = 7
    """Shared medium: a broadcast frame of the message collided at the receiver (``channels/medium``)."""
    RETRY_LIMIT = 8
    """Shared medium: a unicast frame failed ``retry_limit`` + 1 times and the sender gave it up."""

    @property
    def reason(self) -> str:
        """The drop reason's name (lower case), '' for DELIVERED."""
        return "" if self is Fate.DELIVERED else self.name.lower()


DROP_REASONS: tuple[str, ...] = tuple(f.reason for f in Fate if f is not Fate.DELIVERED)
CUSTOM_BASE = 128
"""Codes from here on are drop reasons that radio models name themselves (:func:`reason_code`)."""
CUSTOM_REASONS: list[str] = []
"""Names of the radio models' own drop reasons, code = CUSTOM_BASE + index (registered on first use)."""


def reason_code(name: str) -> int:
    """The code of a drop reason a radio model names (``jammed``): a built-in reason's own code,
    else one of :data:`CUSTOM_REASONS`, registered on first use (at most 127 names)."""
    for f in Fate:
        if f.reason == name:
            return int(f)
    if name not in CUSTOM_REASONS:
        if len(CUSTOM_REASONS) >= 255 - CUSTOM_BASE:
            raise ValueError(f"drop reason {name!r}: radio models named {len(CUSTOM_REASONS)} reasons already; "
                             f"at most {255 - CUSTOM_BASE} are kept apart.")
        CUSTOM_REASONS.append(name)
    return CUSTOM_BASE + CUSTOM_REASONS.index(name)


def reason_name(code: int) -> str:
    """The name of a drop reason's code ('' for delivered)."""
    if code >= CUSTOM_BASE:
        return CUSTOM_REASONS[code - CUSTOM_BASE]
    return Fate(code).reason


MEDIUM_REASONS: frozenset[str] = frozenset({Fate.COLLISION.reason, Fate.RETRY_LIMIT.reason})
"""Reasons only a shared medium gives; a run on private links lists them nowhere (its
metrics.json stays what it was before the shared medium existed)."""
"""The names of the drop reasons, in code order (loss, packet_loss, out_of_range, ...)."""

@dataclass(frozen=True, slots=True)
class MessageSent(Event):
    """A message entered the sender's queue for link ``src -> dst``."""

    msg_id: int
    src: int
    dst: int
    nbytes: int
    stamp: float
    """Simulated time (s) at which the payload's state was taken."""


@dataclass(frozen=True, slots=True)
class MessageDelivered(Event):
    """A message arrived whole at ``dst``; ``age`` = t - stamp (s)."""

    msg_id: int
    src: int
    dst: int
    nbytes: int
    stamp: float
    latency: float
    """Seconds from entering the queue to arrival."""
    age: float


@dataclass(frozen=True, slots=True)
class MessageDropped(Event):
    """A message was lost; ``reason`` is one of :data:`DROP_REASONS` (a :class:`Fate`'s name)."""

    msg_id: int
    src: int
    dst: int
    nbytes: int
    stamp: float
    reason: str


@dataclass(frozen=True, slots=True)
class LinkQuality(Event):
    """The quality of directed link ``src -> dst`` changed, seen when a message was sent at t:
    ``success`` the probability that a message sent now arrives (before windows, queues,
    packets); ``state`` good | bad (Gilbert-Elliott), iid, or trace; ``walls`` crossed by the
    segment between the robots (-1 when path loss is off); ``distance_m`` between them
    (NaN when path loss is off)."""

    src: int
    dst: int
    success: float
    state: str
    walls: int
    distance_m: float


@dataclass(frozen=True, slots=True)
class LinkChange(Event):
    """The undirected link {a, b} came up (``up``) or went down (range, window)."""

    a: int
    b: int
    up: bool
    cause: str


@dataclass(frozen=True, slots=True)
class RadioState(Event):
    """On a shared medium (``channel.medium.kind: shared``) agent ``agent``'s radio began to be
    ``state``: transmitting, deferring (it has a frame and senses the air busy), collided (an
    exchange of its failed) or idle."""

    agent: int
    state: str


# --- agents ------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class FrameCaptured(Event):
    """Agent ``agent`` took frame ``index``. ``rgb`` float32 HxWx3 in [0, 1], ``depth``
    float32 HxW metres (0 = invalid), ``c2w`` 4x4 camera-to-world (OpenCV axes),
    ``K`` = (fx, fy, cx, cy, width, height) in pixels."""

    agent: int
    index: int
    keyframe: bool
    rgb: Any
    depth: Any
    c2w: Any
    K: tuple[float, float, float, float, int, int]


@dataclass(frozen=True, slots=True)
class RoundCompleted(Event):
    """Agent ``agent`` finished mapping round ``round`` at t; ``scalars`` are named
    numbers of that round (losses, dual norm, ...); ``copy_ages`` maps neighbour id
    to the age (s) of the copy used, ``None`` if the neighbour was left out."""

    agent: int
    round: int
    duration: float
    """Simulated seconds the round cost on the agent's compute clock."""
    scalars: dict[str, float] = field(default_factory=dict)
    copy_ages: dict[int, float | None] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Diverged(Event):
    """Agent ``agent`` produced a non-finite map or loss in round ``round``; it stops mapping."""

    agent: int
    round: int
    reason: str


@dataclass(frozen=True, slots=True)
class MapSnapshot(Event):
    """A mesh extracted from agent ``agent``'s map: vertices (V,3) m, faces (F,3),
    colours (V,3) uint8. Empty arrays when the map holds no surface."""

    agent: int
    vertices: Any
    faces: Any
    colors: Any


@dataclass(frozen=True, slots=True)
class UncertaintySnapshot(Event):
    """RAMEN's visit counts on the coarsest grid level: ``points`` (N,3) m, ``counts`` (N,)."""

    agent: int
    points: Any
    counts: Any


@dataclass(frozen=True, slots=True)
class MetricsEvaluated(Event):
    """Paper metrics of agent ``agent``'s map at t (artifacts_cm, holes_cm,
    completion_ratio_pct, ...). ``agent`` is -1 for run-wide numbers."""

    agent: int
    metrics: dict[str, float]


@dataclass(frozen=True, slots=True)
class Notice(Event):
    """A notable event in words (divergence, window open/close, ...); ``level`` is
    info, warning or error."""

    text: str
    level: str = "info"
    agent: int | None = None
