"""Settings of the radio (``ChannelConfig``) and of who may talk to whom (``TopologyConfig``).

Every field has a default and states its unit. Ranges are validated here; checks that need
the number of agents (agent ids in ``edges`` or in a window schedule) happen when the
``Topology`` / ``Channel`` is built, and raise ``ValueError`` naming the key.
"""
from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_serializer, model_validator
from pydantic.json_schema import SkipJsonSchema

from ramensim.channels.burst import BurstConfig
from ramensim.channels.latency import LatencyConfig
from ramensim.channels.medium.config import MediumConfig
from ramensim.channels.pathloss import PathLossConfig
from ramensim.channels.radios import get_radio, is_radio
from ramensim.channels.trace import TraceConfig

__all__ = ["BurstConfig", "ChannelConfig", "LatencyConfig", "MediumConfig", "PathLossConfig", "TopologyConfig",
           "TraceConfig", "WindowConfig", "parse_pair_key"]

_PAIR_KEY = re.compile(r"^\s*(\d+)\s*-\s*(\d+)\s*$")


def parse_pair_key(key: str) -> tuple[int, int] | None:
    """``"0-1"`` -> ``(0, 1)`` (sorted, undirected); ``"*"`` -> ``None`` (all pairs).

    Raises ``ValueError`` for anything else.
    """
    if key.strip() == "*":
        return None
    m = _PAIR_KEY.match(key)
    if m is None:
        raise ValueError(
            f"channel.windows.schedule key {key!r} is not a link: expected 'a-b' with two agent "
            "ids (e.g. '0-1') or '*' for every link."
        )
    a, b = int(m.group(1)), int(m.group(2))
    if a == b:
        raise ValueError(
            f"channel.windows.schedule key {key!r} names the same agent twice: a link joins two "
            "different agents (e.g. '0-1')."
        )
    return (a, b) if a < b else (b, a)


class WindowConfig(BaseModel):
    """When links may carry messages.

    always: every link, all the time. periodic: every link is open during
    ``[phase_s + k*period_s, phase_s + k*period_s + open_s)`` for every integer k
    (e.g. period 30, open 2: "exchange only every 30 s"). schedule: per undirected link
    ``"a-b"`` a list of ``[t0, t1)`` intervals (seconds); key ``"*"`` applies to links that
    are not listed; a link with neither is always closed.

    The rule: a message must be sent while its link's window is open, must start its
    transmission (after queueing) while it is open, and its whole serialisation must end
    before the window closes; otherwise it is dropped (window_closed) at the send time, the
    start time or the closing time. Propagation (latency) may end after the close.
    """

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    kind: Literal["always", "periodic", "schedule"] = "always"
    """How windows are given (always | periodic | schedule)."""
    period_s: float = Field(30.0, gt=0.0)
    """Time between the openings of a periodic window in seconds."""
    open_s: float = Field(2.0, ge=0.0)
    """How long a periodic window stays open in seconds (<= period_s)."""
    phase_s: float = 0.0
    """Time of a periodic window's opening in seconds (windows repeat every period_s from it)."""
    schedule: dict[str, list[tuple[float, float]]] = Field(default_factory=dict)
    """Per link "a-b" (or "*" for all others): open intervals [[t0, t1], ...] in seconds, t0 < t1."""

    @model_validator(mode="after")
    def _check(self) -> WindowConfig:
        if self.open_s > self.period_s:
            raise ValueError(
                f"channel.windows: open_s={self.open_s} s is longer than period_s={self.period_s} s; "
                "a periodic window cannot stay open longer than its period."
            )
        for key, intervals in self.schedule.items():
            parse_pair_key(key)
            for i, (t0, t1) in enumerate(intervals):
                if not t0 < t1:
                    raise ValueError(
                        f"channel.windows.schedule[{key!r}][{i}] = [{t0}, {t1}]: an open interval "
                        "needs t0 < t1 (seconds)."
                    )
        if self.kind != "schedule" and self.schedule:
            raise ValueError(
                f"channel.windows.schedule is set but windows.kind is {self.kind!r}; set "
                "kind: schedule to use it, or remove the schedule."
            )
        return self


class ChannelConfig(BaseModel):
    """The radio between agents: loss, fragmentation, bandwidth, queues, latency, windows, range."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    success_rate: float = Field(1.0, ge=0.0, le=1.0)
    """Probability that a transmitted message arrives (probability, 0..1): the paper's knob; applied per message in both modes."""
    draws: Literal["keyed", "send_order"] = "keyed"
    """How a message's random fate (loss, latency, packets) is drawn: keyed by its link and send time, so that methods run with one seed face the same channel (keyed; eq. D-1 of ramensim.channels.draws), or from one stream per kind in send order, as before 2026-11-24 (send_order)."""
    seed: int | None = Field(None, ge=0, le=(1 << 63) - 1)
    """The channel's own seed (integer >= 0): its draws (loss, latency, bursts, packets) then come from this seed instead of the run's root seed, so that runs with different root seeds meet the same channel realisation, or one root seed another; unset (the default): from the run's seed (setting it to the run's seed changes nothing)."""
    loss_unit: Literal["message", "edge_round"] = "message"
    """What one loss Bernoulli decides: each message, or each undirected edge per round of loss_round_s, shared by both directions (edge_round: the authors' model, eq. D-2; needs draws: keyed)."""
    loss_round_s: float = Field(1.0, gt=0.0, le=1.0e6, allow_inf_nan=False)
    """Length of a round for loss_unit: edge_round (seconds): messages on one edge in one round share their fate."""
    mode: Literal["message", "packet"] = "message"
    """Loss model: one Bernoulli per message, or per MTU fragment (message | packet)."""
    mtu_bytes: int = Field(1500, ge=2, le=1 << 30)
    """Largest packet on the air in bytes, header included (packet mode)."""
    packet_loss: float = Field(0.0, ge=0.0, le=1.0)
    """Probability that one packet transmission is lost (probability, 0..1; packet mode)."""
    reassembly: Literal["all_or_nothing", "retransmit"] = "all_or_nothing"
    """Packet mode: the message is lost if any fragment is lost, or lost fragments are resent (all_or_nothing | retransmit)."""
    max_retries: int = Field(3, ge=0, le=1000)
    """Retransmissions allowed per packet before the message is abandoned (count; retransmit)."""
    retry_delay_s: float = Field(0.0, ge=0.0, le=60.0)
    """Time the sender waits after a lost packet before resending it, e.g. an ACK timeout (seconds; retransmit)."""
    bandwidth_bps: float = Field(100e6, gt=0.0)
    """Link rate in bits per second: serialising S bytes takes 8*S/bandwidth_bps seconds."""
    header_bytes: int = Field(64, ge=0, le=1 << 20)
    """Protocol overhead added per message (message mode) or per packet (packet mode), in bytes."""
    queue_limit: int = Field(32, ge=0, le=1 << 24)
    """Messages that may wait behind the one being transmitted on a transmitter (count); more are dropped (queue_overflow)."""
    transmitter: Literal["link", "agent"] = "link"
    """Who shares a FIFO queue and its bandwidth: each directed link, or all links of a sender (link | agent)."""
    latency: LatencyConfig = Field(default_factory=LatencyConfig)
    """Propagation delay after serialisation (seconds, drawn per message)."""
    windows: WindowConfig = Field(default_factory=WindowConfig)
    """When links may carry messages (communication windows)."""
    range_m: float | None = Field(None, gt=0.0)
    """Radio range in metres: a link exists only while its endpoints are this close; None = unlimited."""
    range_check_resolution_s: float = Field(0.01, ge=0.0, le=60.0)
    """Packet mode: range is checked at packet boundaries at most this often during a transfer (seconds; 0 = every boundary)."""
    link_monitor_period_s: float | None = Field(None, gt=0.0)
    """Poll every link this often and emit LinkChange events when one comes up or goes down (seconds; None = off; needs env.run(until=...))."""
    burst: BurstConfig = Field(default_factory=BurstConfig)
    """Burst loss: i.i.d. per message, or a Gilbert-Elliott chain per link at the same long-run success_rate."""
    path_loss: PathLossConfig = Field(default_factory=PathLossConfig)
    """Path loss from distance and the walls crossed (off by default)."""
    trace: TraceConfig = Field(default_factory=TraceConfig)
    """Replay of recorded delivery and latency per link from a CSV file (off by default)."""
    medium: MediumConfig = Field(default_factory=MediumConfig)
    """Whether links own their bandwidth (kind: links, the default) or every radio within hearing shares one air (kind: shared; docs/RADIO.md)."""
    radios: SkipJsonSchema[dict[str, Any]] = Field(default_factory=dict, exclude=True)
    """Settings blocks of radio models added by plugins, keyed by model name: written in a scenario as
    ``channel.<name>`` beside the keys above (never as ``radios``), validated by the model's settings
    class (:mod:`ramensim.channels.radios`)."""

    @model_validator(mode="wrap")
    @classmethod
    def _plugin_radios(cls, data: Any, handler: Any) -> ChannelConfig:
        """Move the blocks of registered plugin radio models (``channel.<name>``) into
        :attr:`radios`, validated with their settings classes; any other unknown key stays
        and is refused as usual (with its 'did you mean')."""
        blocks: dict[str, Any] = {}
        if isinstance(data, dict):
            extra = [k for k in data if isinstance(k, str) and k not in cls.model_fields]
            if extra:
                data = dict(data)
                for key in extra:
                    if is_radio(key):
                        spec = get_radio(key)
                        raw = data.pop(key)
                        blocks[key] = raw if spec.settings is None else _validated_block(spec, raw)
            if "radios" in data:
                raise ValueError("key 'radios' is internal; write a plugin radio model's settings as "
                                 "channel.<model name>")
        model = handler(data)
        if blocks:
            model.radios = {**model.radios, **blocks}
        return model

    @model_serializer(mode="wrap")
    def _dump_radios(self, handler: Any, info: Any) -> Any:
        """Plugin radio blocks dump back where the scenario wrote them (``channel.<name>``)."""
        out = handler(self)
        for key, block in self.radios.items():
            out[key] = block.model_dump(mode=info.mode) if isinstance(block, BaseModel) else block
        return out

    @model_validator(mode="after")
    def _check(self) -> ChannelConfig:
        if self.mode == "packet" and self.mtu_bytes <= self.header_bytes:
            raise ValueError(
                f"channel.mtu_bytes={self.mtu_bytes} must exceed channel.header_bytes="
                f"{self.header_bytes}: a packet has to carry at least one payload byte."
            )
        if self.loss_unit == "edge_round" and self.draws != "keyed":
            raise ValueError(
                "channel.loss_unit = 'edge_round' (one Bernoulli per edge and round) needs channel.draws = "
                "'keyed': in send order the two directions of an edge draw from one stream and cannot share "
                "a coin; remove channel.draws or set it to keyed."
            )
        if self.medium.kind == "shared" and self.mode == "packet":
            raise ValueError(
                "channel.mode = 'packet' cannot be combined with channel.medium.kind = 'shared': on a shared "
                "medium a message goes out as frames of channel.medium.max_frame_bytes that contend for the air "
                "(and are retried by the DCF); remove channel.mode (message) or set channel.medium.kind: links.")
        b = self.burst
        if b.kind == "gilbert_elliott" and not (1.0 - b.bad_loss <= self.success_rate <= 1.0 - b.good_loss):
            raise ValueError(
                f"channel.success_rate={self.success_rate} cannot be the long-run success of a Gilbert-Elliott "
                f"link with channel.burst.good_loss={b.good_loss} and bad_loss={b.bad_loss}: expected "
                f"{1.0 - b.bad_loss:g} <= success_rate <= {1.0 - b.good_loss:g}."
            )
        return self


def _validated_block(spec: Any, raw: Any) -> BaseModel:
    """A plugin radio model's block validated by its settings class; ValueError naming its keys."""
    from pydantic import ValidationError

    try:
        return spec.settings.model_validate(raw if raw is not None else {})
    except ValidationError as exc:
        problems = "; ".join(
            f"key 'channel.{spec.name}.{'.'.join(str(x) for x in e['loc'])}' has value {e.get('input')!r}: "
            f"{e['msg']}" if e['loc'] else f"channel.{spec.name}: {e['msg']}"
            for e in exc.errors(include_url=False)[:5])
        raise ValueError(f"radio model {spec.name!r}: {problems}") from None


class TopologyConfig(BaseModel):
    """The communication graph: which pairs of agents are neighbours (undirected)."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    kind: Literal["complete", "path", "ring", "star", "grid", "disk", "explicit"] = "complete"
    """Graph family (complete | path | ring | star | grid | disk | explicit); disk is dynamic, from positions."""
    edges: list[tuple[int, int]] = Field(default_factory=list)
    """Undirected edges [[a, b], ...] between agent ids (explicit only)."""
    grid_shape: tuple[int, int] | None = None
    """Rows and columns of a grid (agents numbered row by row; rows*cols = agents); None = the most square shape."""
    star_centre: int = Field(0, ge=0)
    """Agent id at the centre of a star."""
    disk_radius_m: float | None = Field(None, gt=0.0)
    """Disk graph: agents within this distance in metres are neighbours at that time (required for disk)."""

    @field_validator("grid_shape")
    @classmethod
    def _grid_positive(cls, v: tuple[int, int] | None) -> tuple[int, int] | None:
        if v is not None and (v[0] < 1 or v[1] < 1):
            raise ValueError(f"topology.grid_shape={list(v)}: rows and columns must be >= 1.")
        return v

    @model_validator(mode="after")
    def _check(self) -> TopologyConfig:
        if self.kind == "explicit" and not self.edges:
            raise ValueError(
                "topology.kind is 'explicit' but topology.edges is empty; list the links as "
                "[[a, b], ...] with agent ids."
            )
        if self.kind != "explicit" and self.edges:
            raise ValueError(
                f"topology.edges is set but topology.kind is {self.kind!r}; set kind: explicit to "
                "use your edges, or remove them."
            )
        for i, (a, b) in enumerate(self.edges):
            if a == b:
                raise ValueError(
                    f"topology.edges[{i}] = [{a}, {b}] joins agent {a} to itself; an edge needs "
                    "two different agent ids."
                )
            if a < 0 or b < 0:
                raise ValueError(
                    f"topology.edges[{i}] = [{a}, {b}] names a negative agent id; ids run from 0."
                )
        if self.kind == "disk" and self.disk_radius_m is None:
            raise ValueError(
                "topology.kind is 'disk' but topology.disk_radius_m is not set; give the "
                "neighbour radius in metres."
            )
        return self
