"""Settings of the shared medium (``channel.medium``): who hears whom and how radios take turns.

``kind: links`` (the default) is the channel as it always was: every directed link (or every
sender, ``channel.transmitter: agent``) owns ``channel.bandwidth_bps``. ``kind: shared`` puts
every radio on one channel of that rate: a transmission occupies the air of every radio that
hears it (``sense_range_m``, walls with ``channel.path_loss``), and the radios share it by
``access``: ``fair`` (a fluid airtime share, eq. M-1 of ``channels/medium/fair.py``) or ``dcf``
(802.11 DCF, CSMA/CA with binary exponential backoff: ``channels/medium/dcf.py``). Times are
given in microseconds as 802.11 states them; sizes in bytes.
"""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator


class MediumConfig(BaseModel):
    """The air the radios share (docs/RADIO.md, "A shared medium")."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    kind: Literal["links", "shared"] = "links"
    """Private bandwidth per link, as before (links), or one channel that every radio within hearing shares (shared)."""
    access: Literal["fair", "dcf"] = "fair"
    """How radios that hear each other share the air (shared): a fluid equal split of the rate among the active senders each hears (fair) or 802.11 DCF, CSMA/CA with backoff, ACKs and collisions (dcf)."""
    delivery: Literal["unicast", "broadcast"] = "unicast"
    """One transmission per message, acknowledged and retried (unicast), or one transmission that every neighbour in hearing receives at once, unacknowledged (broadcast: the messages a robot sends at one instant with one stamp go out together)."""
    loss: Literal["message", "frame"] = "message"
    """Where the radio's loss (success_rate and the radio models of eq. Q-1) applies on a shared medium: one coin per message, keyed by link and send time as on private links, so the paper's knob keeps its meaning (message), or one coin per data frame with dcf, a lost unicast frame being retried like a collided one and costing airtime (frame)."""
    sense_range_m: float | None = Field(50.0, gt=0.0, le=1.0e7, allow_inf_nan=False)
    """Two radios hear each other (sense the carrier, decode and collide) while this close (metres); None = every radio hears every other."""
    cs_threshold_dbm: float = Field(-92.0, ge=-200.0, le=60.0, allow_inf_nan=False)
    """With channel.path_loss enabled: radios also need a received power (eq. PL-1, walls included) of at least this to hear each other (dBm)."""
    update_s: float = Field(0.5, gt=0.0, le=3600.0, allow_inf_nan=False)
    """Who hears whom is recomputed from the positions at the start of every step of this length (seconds)."""
    max_frame_bytes: int = Field(65535, ge=1, le=1 << 24)
    """Largest data frame, MAC header included (bytes; 802.11n A-MPDU aggregation reaches 65535): a message goes out as ceil(bytes / (this - mac_header_bytes)) frames (dcf)."""
    cw_min: int = Field(16, ge=1, le=1 << 16)
    """Backoff window at stage 0 (slots, a power of two): the counter is drawn from 0..cw_min-1 (dcf)."""
    max_stage: int = Field(6, ge=0, le=16)
    """Doublings of the window after failures: stage i draws from 0..2^min(i, max_stage) cw_min - 1 (count; dcf)."""
    retry_limit: int | None = Field(7, ge=0, le=1 << 20)
    """Retransmissions of a frame before it and its message are dropped (retry_limit) (count; None = never give up, the analytic model's assumption; dcf)."""
    rts_cts: bool = False
    """Reserve the air with RTS/CTS before each unicast frame (true | false; dcf)."""
    slot_us: float = Field(9.0, gt=0.0, le=1.0e6, allow_inf_nan=False)
    """Backoff slot (microseconds; 802.11a/g/n/ac: 9)."""
    sifs_us: float = Field(16.0, ge=0.0, le=1.0e6, allow_inf_nan=False)
    """Short interframe space before a CTS, data frame after CTS, or ACK (microseconds; 802.11a/n/ac: 16)."""
    difs_us: float = Field(34.0, ge=0.0, le=1.0e6, allow_inf_nan=False)
    """Idle time a radio waits before it counts down or sends (microseconds; SIFS + 2 slots = 34)."""
    propagation_us: float = Field(1.0, gt=0.0, le=1.0e6, allow_inf_nan=False)
    """Propagation delay of a frame between any two radios (microseconds; 1 us = 300 m)."""
    phy_header_us: float = Field(20.0, ge=0.0, le=1.0e6, allow_inf_nan=False)
    """Preamble and PHY header of every frame (microseconds; OFDM: 20)."""
    mac_header_bytes: int = Field(34, ge=0, le=1 << 16)
    """MAC header and FCS of a data frame (bytes)."""
    ack_bytes: int = Field(14, ge=1, le=1 << 16)
    """ACK frame (bytes, after the PHY header)."""
    rts_bytes: int = Field(20, ge=1, le=1 << 16)
    """RTS frame (bytes, after the PHY header)."""
    cts_bytes: int = Field(14, ge=1, le=1 << 16)
    """CTS frame (bytes, after the PHY header)."""

    @model_validator(mode="after")
    def _check(self) -> MediumConfig:
        w = self.cw_min
        if w & (w - 1):
            raise ValueError(
                f"channel.medium.cw_min = {w} is not a power of two; 802.11 backoff windows are 2^k slots "
                f"(e.g. {1 << max(0, w.bit_length() - 1)} or {1 << w.bit_length()}).")
        if self.loss == "frame" and self.access != "dcf":
            raise ValueError(
                "channel.medium.loss = 'frame' needs channel.medium.access = 'dcf': the fair share has no frames "
                "to lose (it is a fluid); use loss: message with fair, or access: dcf.")
        if self.max_frame_bytes <= self.mac_header_bytes:
            raise ValueError(
                f"channel.medium.max_frame_bytes = {self.max_frame_bytes} does not exceed channel.medium."
                f"mac_header_bytes = {self.mac_header_bytes}: a frame has to carry at least one payload byte "
                "after its header (bytes).")
        return self
