"""Events of the radio models beyond the core message events (``ramensim.core.events``)."""
from __future__ import annotations

from dataclasses import dataclass

from ramensim.core.events import Event


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
