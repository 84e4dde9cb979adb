"""The one place where radio models are declared and looked up (docs/RADIO.md, docs/EXTENDING.md).

A radio model changes the success probability of a message sent on ``src -> dst`` at time t
(and, for a replay, its latency). Each model is declared once with
``register_radio(RadioModelSpec(...))``: its name (the scenario key ``channel.<name>``), its
settings class (the block under that key), when the block turns it on, its role in eq. Q-1
and how to build it for one channel. The built-ins (``burst``, ``path_loss``, ``trace``)
register at the end of their modules; a plugin (:mod:`ramensim.plugins`) registers the same
way. :class:`ramensim.channels.quality.LinkModels` combines the models that are on:

* ``override`` (the trace): ``quality(src, dst, t) -> (success, latency_s | None) | None``;
  a link it answers (not None) takes that success and latency, and the other models are not
  asked;
* ``base`` (the burst chain; at most one is on): ``quality(src, dst, t) -> (success, state)``
  replaces the i.i.d. ``success_rate`` (state: a short label for the LinkQuality event);
* ``factor`` (path loss, a plugin's distance loss): ``quality(src, dst, t) -> (factor, walls,
  distance_m)``, a success factor in [0, 1] multiplied in (walls crossed, -1 when the model
  does not count them; distance in metres, NaN when it does not know it). A factor of 0 means
  the endpoints are out of range (``out_of_range`` in the message log). A fourth element, a
  latency in seconds (or None), replaces the ``channel.latency`` draw of that message: a
  latency model (with factor 1 when it loses nothing). A fifth, a drop reason's name (e.g.
  ``"jammed"``), names the messages this factor loses in messages.csv instead of ``loss``: the
  one loss uniform u of the message is lost (u >= success) by this model when it would have
  arrived without its factor (u < success / factor).

A ``quality`` that accepts a keyword ``state`` is given a :class:`ChannelState`: the queue
lengths and bytes waiting on the link and at the sender, the sender's offered load and, on a
shared medium, whether its radio senses the air busy (loss that grows with load, written
without counting calls).

Models are asked in registration order (built-ins first), so with the built-ins alone the
product of eq. Q-1 is computed exactly as before.
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Literal, Protocol

import numpy as np

from ramensim.core.registry import Registry

if TYPE_CHECKING:  # pragma: no cover - typing only
    from pydantic import BaseModel

Role = Literal["override", "base", "factor"]

ChannelBlock = Any
"""The scenario's validated ``channel`` block, a :class:`ramensim.channels.config.ChannelConfig`
(``success_rate``, ..., each radio model's settings). Named here, not imported: that class
composes the settings classes of the radio models, whose modules register here, so this
registry sits below it."""


class FirstHit(Protocol):
    """``first_hit(origins (m, 3), directions (m, 3) unit) -> (m,)`` distance in metres to the
    first surface along each ray (inf on a miss): what the world's ray caster answers."""

    def __call__(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray: ...


Position = Callable[[int, float], np.ndarray]
"""``position(agent, t) -> (3,)``: an agent's position in metres in the world frame at simulated
time t (s)."""


@dataclass(frozen=True)
class RadioContext:
    """What a radio model may use when it is built for one channel."""

    channel: ChannelBlock
    """The whole ``channel`` block (e.g. ``success_rate``)."""
    n_agents: int
    seed_seq: np.random.SeedSequence
    """The radio models' seed sequence (a child of the channel's generator)."""
    position: Position | None = None
    """``position(agent, t) -> (3,)`` metres in the world frame at simulated time t (None
    when the channel was built without positions, e.g. a bare channel in a test)."""
    first_hit: FirstHit | None = None
    """The scene's ray caster (distance to the first surface along each ray), or None."""
    base_dir: Path | None = None
    """Folder that relative paths of the model's settings resolve against (the scenario's)."""
    name: str = ""
    """The model's registered name (set for each model when it is built)."""

    def generator(self) -> np.random.Generator:
        """A generator of this model's own, keyed by its name under :attr:`seed_seq`: the same
        scenario and seed give the same draws, whatever other models are on."""
        key = zlib.crc32(self.name.encode("utf-8"))
        return np.random.default_rng(np.random.SeedSequence(
            self.seed_seq.entropy, spawn_key=(*self.seed_seq.spawn_key, 7_000_003, key)))


@dataclass(frozen=True, slots=True)
class ChannelState:
    """The channel as a radio model sees it when it decides a message (issue 67): handed to a
    ``quality`` that accepts a keyword ``state``. Counts exclude the message being decided."""

    queue_link: int
    """Messages waiting (not yet on the air) on this directed link's transmitter (count)."""
    queue_sender: int
    """Messages waiting at the sender, every link of it together (count)."""
    bytes_link: int
    """Payload bytes waiting on this link's transmitter."""
    bytes_sender: int
    """Payload bytes waiting at the sender."""
    offered_bps: float
    """What the sender handed the channel over the last second, this message excluded (bit/s)."""
    medium_busy: bool | None = None
    """Shared medium: whether the sender's radio senses the air busy now; None on private links."""
    medium_waiting: int | None = None
    """Shared medium: messages' jobs queued at the sender's radio; None on private links."""


_CHANNEL_KEYS = frozenset({
    "success_rate", "draws", "seed", "loss_unit", "loss_round_s", "mode", "mtu_bytes", "packet_loss", "reassembly",
    "max_retries", "retry_delay_s", "bandwidth_bps", "header_bytes", "queue_limit", "transmitter", "latency",
    "windows", "range_m", "range_check_resolution_s", "link_monitor_period_s", "medium", "radios"})
"""Keys of the channel block that are not radio models (``ChannelConfig``'s other fields; a
test checks this list against the class)."""


def _always(settings: Any) -> bool:
    return True


@dataclass(frozen=True)
class RadioModelSpec:
    """A radio model as the channel and the scenario schema see it."""

    name: str
    """The scenario key ``channel.<name>`` that holds its settings."""
    build: Callable[[Any, RadioContext], Any]
    """``build(settings, ctx) -> model`` (an object with ``quality(src, dst, t)`` for its role,
    see the module docstring), or None when these settings leave it off."""
    settings: type[BaseModel] | None = None
    """Pydantic model of its settings block (``channel.<name>``)."""
    role: Role = "factor"
    active: Callable[[Any], bool] = _always
    """``active(settings) -> bool``: whether the block turns the model on. A plugin's model is
    on when its block is given and this says so; a built-in's block always exists."""
    description: str = ""
    """One line for the docs."""
    reasons: tuple[str, ...] = ()
    """The drop reasons its ``quality`` may name (its fifth element), e.g. ``("jammed",)``."""

    def settings_of(self, cfg: ChannelBlock) -> Any:
        """The model's validated settings block in ``cfg`` (None when not given)."""
        if self.name in type(cfg).model_fields:
            return getattr(cfg, self.name)
        return cfg.radios.get(self.name)

    def is_on(self, cfg: ChannelBlock) -> bool:
        settings = self.settings_of(cfg)
        if settings is None and self.settings is not None:
            return False
        return bool(self.active(settings))


_REGISTRY: Registry = Registry("radio", "radio model")
"""Name -> spec. The built-ins register when ``ramensim.channels`` is imported (its
``__init__`` imports their modules first), so any import of this module sees them."""


def register_radio(spec: RadioModelSpec) -> RadioModelSpec:
    """Declare ``spec`` under ``spec.name``; a name taken by another declaration (a built-in
    model or a key of the channel block included) is an error."""
    if spec.name not in _REGISTRY and spec.name in _CHANNEL_KEYS:
        raise ValueError(f"radio registry: {spec.name!r} is a key of the channel block (channel.{spec.name}); "
                         f"a radio model needs a name of its own.")
    if spec.role not in ("override", "base", "factor"):
        raise ValueError(f"radio registry: model {spec.name!r} has role {spec.role!r}; expected override, "
                         f"base or factor.")
    return _REGISTRY.declare(spec)


def unregister_radio(name: str) -> None:
    """Remove a model (tests that register a temporary one)."""
    _REGISTRY.withdraw(name)


def radio_names() -> tuple[str, ...]:
    """Every registered radio model, in registration order (the order eq. Q-1 asks them)."""
    return _REGISTRY.names()


def get_radio(name: str) -> RadioModelSpec:
    """The spec of ``name``; ValueError naming the registered models."""
    return _REGISTRY.lookup(name)


def is_radio(name: str) -> bool:
    """True when ``name`` is a registered radio model."""
    return name in _REGISTRY


def active_models(cfg: ChannelBlock) -> list[RadioModelSpec]:
    """The models ``cfg`` turns on, in registration order."""
    return [spec for spec in _REGISTRY.values() if spec.is_on(cfg)]
