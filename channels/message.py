"""A message on the radio: an opaque payload plus what the channel learns while carrying it."""
from __future__ import annotations

from typing import Any

from ramensim.core.events import DROP_REASONS

QUEUED = "queued"
DELIVERED = "delivered"
DROPPED = "dropped"

REASONS = DROP_REASONS
"""Why a message was dropped (the names of ``ramensim.core.events.Fate``; ``MessageDropped.reason``)."""


class Message:
    """One message from ``src`` to ``dst``; the same object is returned to the sender and
    handed to the receiver.

    ``payload`` is opaque (agents put real tensors in it); ``nbytes`` is the payload size the
    sender computed, in bytes (the channel adds headers to get ``wire_bytes``); ``stamp`` is
    the simulated time (s) at which the payload's state was taken. Times are seconds.
    ``status`` is queued until the message is delivered or dropped (then ``reason`` says why).
    """

    __slots__ = (
        "id", "src", "dst", "payload", "nbytes", "stamp", "t_sent", "t_start", "t_done",
        "status", "reason", "wire_bytes", "packets", "retries", "_fate", "latency_draw",
    )

    def __init__(self, msg_id: int, src: int, dst: int, payload: Any, nbytes: int, stamp: float, t_sent: float) -> None:
        self.id = msg_id
        """Unique id, in order of ``send`` calls."""
        self.src = src
        self.dst = dst
        self.payload = payload
        self.nbytes = nbytes
        self.stamp = stamp
        self.t_sent = t_sent
        """When ``send`` was called (s)."""
        self.t_start = t_sent
        """When transmission began, after queueing (s)."""
        self.t_done = t_sent
        """When the message arrived or was dropped (s); meaningful once status is not queued."""
        self.status = QUEUED
        self.reason = ""
        self.wire_bytes = 0
        """Bytes put on the air: payload, headers and retransmissions."""
        self.packets = 1
        """Fragments (count; 1 in message mode)."""
        self.retries = 0
        """Packet retransmissions (count)."""
        self._fate = 0
        self.latency_draw = 0.0
        """Its propagation delay (s), drawn at send time; applied after the shared medium's last bit."""

    @property
    def latency(self) -> float:
        """Seconds from ``send`` to arrival (or drop)."""
        return self.t_done - self.t_sent

    @property
    def age(self) -> float:
        """Age of the payload on arrival, t_done - stamp (s)."""
        return self.t_done - self.stamp

    def __repr__(self) -> str:
        return (
            f"Message(id={self.id}, {self.src}->{self.dst}, nbytes={self.nbytes}, stamp={self.stamp}, "
            f"t_sent={self.t_sent}, status={self.status}{', reason=' + self.reason if self.reason else ''})"
        )
