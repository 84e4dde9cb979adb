"""Per-message link quality from the radio models: burst loss, path loss, trace replay and
any model a plugin registers (:mod:`ramensim.channels.radios`).

For a message sent on ``src -> dst`` at time t, ``LinkModels.at`` gives the probability that
it arrives (before windows, queues and packets, which the channel applies) and, with a
trace, the latency to use:

    success = s_base(t) * prod_k f_k(t)                                        (Q-1)

where s_base is ``success_rate`` (i.i.d.) or the ``base`` model's success (the burst chain:
1 - h_state(t) of the link's Gilbert-Elliott chain), and f_k are the ``factor`` models on, in
registration order (path loss: eq. PL-2 of ``pathloss``; a plugin's, e.g. a distance
loss). With the built-ins this is s_burst(t) * s_path(t), computed as before. A link an
``override`` model answers (the trace) takes its delivery (success 1 or 0) and latency from
it instead. Each change of (success, state, walls) on a link is emitted as a ``LinkQuality``
event.
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ramensim.channels.config import ChannelConfig
from ramensim.channels.pathloss import FirstHit, Position
from ramensim.channels.radios import RadioContext, active_models
from ramensim.core.events import EventSink, LinkQuality, reason_code


def models_active(cfg: ChannelConfig) -> bool:
    """True when any radio model beyond i.i.d. loss is configured."""
    return bool(active_models(cfg))


class LinkModels:
    """The radio models that ``cfg`` turns on, for every directed link (see the module docstring)."""

    def __init__(self, cfg: ChannelConfig, n_agents: int, rng: np.random.Generator, position: Position | None,
                 first_hit: FirstHit | None, emit: EventSink | None, base_dir: Path | None = None) -> None:
        self.cfg = cfg
        self.n = n_agents
        self._emit = emit
        ctx = RadioContext(cfg, n_agents, rng.bit_generator.seed_seq, position, first_hit, base_dir)
        self.models: dict[str, Any] = {}
        """Model name -> the built model, in registration order."""
        overrides, bases, factors = [], [], []
        names_reasons = False
        for spec in active_models(cfg):
            names_reasons = names_reasons or bool(spec.reasons)
            model = spec.build(spec.settings_of(cfg), replace(ctx, name=spec.name))
            if model is None:
                continue
            if not callable(getattr(model, "quality", None)):
                raise ValueError(f"radio model {spec.name!r}: its builder returned a {type(model).__name__} "
                                 f"without quality(src, dst, t); see ramensim.channels.radios.")
            self.models[spec.name] = model
            {"override": overrides, "base": bases, "factor": factors}[spec.role].append((spec.name, model.quality))
        if len(bases) > 1:
            raise ValueError(f"channel: the radio models {', '.join(n for n, _ in bases)} each replace the "
                             f"i.i.d. success rate (role 'base'); turn on at most one of them.")
        self._overrides = tuple(overrides)
        self._base = bases[0][1] if bases else None
        self._factors = tuple(q for _, q in factors)
        self._wants = frozenset(q for _, q in (*overrides, *bases, *factors) if _takes_state(q))
        """The models' ``quality`` callables that take the channel's state (looked up once)."""
        self.wants_state = bool(self._wants)
        """Some model's ``quality`` takes the channel's state (``ChannelState``)."""
        self.extended = self.wants_state or names_reasons
        """The channel asks :meth:`at_full` (state, named reasons) instead of :meth:`at`."""
        self._p = cfg.success_rate
        self._last: dict[tuple[int, int], tuple[float, str, int]] = {}
        if emit is None and not overrides and self._base is None and len(factors) == 1 and not self.extended:
            self._factor0 = factors[0][1]
            self.at = self._at_one_factor  # type: ignore[method-assign] # the common case, without branches

    @property
    def path(self) -> Any:
        """The path-loss model (``channels.pathloss.PathLoss``), or None when it is off."""
        return self.models.get("path_loss")

    @property
    def trace(self) -> Any:
        """The trace replay (``channels.trace.TraceReplay``), or None when it is off."""
        return self.models.get("trace")

    def chain(self, src: int, dst: int) -> Any:
        """The Gilbert-Elliott state path of ``src -> dst`` (``channel.burst`` on)."""
        return self.models["burst"].chain(src, dst)

    def at(self, src: int, dst: int, t: float) -> tuple[float, float | None, bool]:
        """(success probability, trace latency s or None, out of range) of a message sent on
        ``src -> dst`` at ``t`` (s); out of range when a factor model leaves it no chance at all."""
        p, lat, oor, _ = self.at_full(src, dst, t)
        return p, lat, oor

    def at_full(self, src: int, dst: int, t: float, state: Any = None
                ) -> tuple[float, float | None, bool, tuple[tuple[int, float], ...]]:
        """:meth:`at`, and ``named``: the (reason code, factor) of each factor model that named
        its own drop reason; ``state`` (a ``ChannelState``) goes to the models that read it."""
        lat = None
        walls, dist = -1, math.nan
        oor = False
        named: list[tuple[int, float]] = []
        wants = self._wants

        def ask(q: Any) -> Any:
            return q(src, dst, t, state=state) if state is not None and q in wants else q(src, dst, t)

        for name, quality in self._overrides:
            row = ask(quality)
            if row is not None:
                p, lat = row[0], row[1]
                kind = name
                break
        else:
            if self._base is not None:
                p, kind = ask(self._base)
            else:
                p, kind = self._p, "iid"
            for quality in self._factors:
                q = ask(quality)
                sp, walls, dist = q[0], q[1], q[2]
                p *= sp
                if sp <= 0.0:
                    oor = True
                if len(q) > 3 and q[3] is not None:  # a latency model: this propagation delay (s)
                    lat = q[3]
                if len(q) > 4 and q[4]:
                    named.append((reason_code(str(q[4])), float(sp)))
        if self._emit is not None:
            key = (src, dst)
            cur = (p, kind, walls)
            if self._last.get(key) != cur:
                self._last[key] = cur
                self._emit(LinkQuality(t, src, dst, p, kind, walls, dist))
        return p, lat, oor, tuple(named)

    def _at_one_factor(self, src: int, dst: int, t: float) -> tuple[float, float | None, bool]:
        """``at`` for i.i.d. loss times one factor model, no events (same result, fewer steps)."""
        q = self._factor0(src, dst, t)
        sp = q[0]
        return self._p * sp, (q[3] if len(q) > 3 else None), sp <= 0.0


def _takes_state(quality: Any) -> bool:
    """Whether a model's ``quality`` accepts the keyword ``state`` (a ``ChannelState``)."""
    import inspect

    try:
        params = inspect.signature(quality).parameters
    except (TypeError, ValueError):
        return False
    return "state" in params

