"""Per-message link quality from the radio models: burst loss, path loss and trace replay.

For a message sent on ``src -> dst`` at time t, ``LinkModels.at`` gives the probability that
it arrives (before windows, queues and packets, which the channel applies) and, with a
trace, the latency to use:

    success = s_burst(t) * s_path(t)                                           (Q-1)

where s_burst is ``success_rate`` (i.i.d.) or 1 - h_state(t) of the link's Gilbert-Elliott
chain (``burst``), and s_path is 1 without path loss, else eq. PL-2 of ``pathloss``. A link
the trace lists takes its delivery (success 1 or 0) and latency from the trace instead.
Each change of (success, state, walls) on a link is emitted as a ``LinkQuality`` event.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ramensim.channels.burst import GilbertElliottLink, link_rng, mean_good_s, stationary_bad
from ramensim.channels.config import ChannelConfig
from ramensim.channels.pathloss import FirstHit, PathLoss, Position
from ramensim.channels.trace import TraceReplay
from ramensim.core.events import EventSink, LinkQuality

_STATES = ("good", "bad")


def models_active(cfg: ChannelConfig) -> bool:
    """True when any radio model beyond i.i.d. loss is configured."""
    return cfg.burst.kind != "iid" or cfg.path_loss.enabled or cfg.trace.path is not None


class LinkModels:
    """Burst chains, path loss and trace of every directed link (see the module docstring)."""

    def __init__(self, cfg: ChannelConfig, n_agents: int, rng: np.random.Generator, position: Position | None,
                 first_hit: FirstHit | None, emit: EventSink | None, base_dir: Path | None = None) -> None:
        self.cfg = cfg
        self.n = n_agents
        self._emit = emit
        b = cfg.burst
        self._ge = b.kind == "gilbert_elliott"
        self._seed_seq = rng.bit_generator.seed_seq
        if self._ge:
            self._pi_bad = stationary_bad(cfg.success_rate, b.good_loss, b.bad_loss)
            self._t_good = mean_good_s(cfg.success_rate, b.good_loss, b.bad_loss, b.mean_bad_s)
            self._success_by_state = (1.0 - b.good_loss, 1.0 - b.bad_loss)
        self.path: PathLoss | None = None
        if cfg.path_loss.enabled:
            if position is None:
                raise ValueError("channel.path_loss is enabled, which needs agent positions, but no "
                                 "position(agent, t) callable was given to the Channel.")
            self.path = PathLoss(cfg.path_loss, position, first_hit)
        self.trace: TraceReplay | None = None
        if cfg.trace.path is not None:
            self.trace = TraceReplay(cfg.trace, n_agents, base_dir)
        self._last: dict[tuple[int, int], tuple[float, str, int]] = {}
        self._chain_list: list[GilbertElliottLink | None] = [None] * (n_agents * n_agents)
        self._p = cfg.success_rate
        if emit is None and self.trace is None and self.path is not None and not self._ge:
            self.at = self._at_path  # type: ignore[method-assign] # the common case, without branches

    def chain(self, src: int, dst: int) -> GilbertElliottLink:
        """The Gilbert-Elliott state path of ``src -> dst`` (built on first use from its own seed)."""
        ch = self._chain_list[src * self.n + dst]
        if ch is None:
            ch = self._chain_list[src * self.n + dst] = GilbertElliottLink(
                link_rng(self._seed_seq, src, dst), self._t_good, self.cfg.burst.mean_bad_s, self._pi_bad)
        return ch

    def at(self, src: int, dst: int, t: float) -> tuple[float, float | None, bool]:
        """(success probability, trace latency s or None, out of range) of a message sent on
        ``src -> dst`` at ``t`` (s); out of range when path loss leaves it no chance at all."""
        lat = None
        walls, dist = -1, math.nan
        oor = False
        trace = self.trace
        if trace is not None and (row := trace.lookup(src, dst, t)) is not None:
            ok, row_lat = row
            p, state = (1.0, "trace") if ok else (0.0, "trace")
            if ok:
                lat = row_lat
        else:
            if self._ge:
                ch = self._chain_list[src * self.n + dst] or self.chain(src, dst)
                s = ch.state(t)
                p, state = self._success_by_state[s], _STATES[s]
            else:
                p, state = self._p, "iid"
            if self.path is not None:
                sp, walls, dist = self.path.quality(src, dst, t)
                p *= sp
                oor = sp <= 0.0
        if self._emit is not None:
            key = (src, dst)
            cur = (p, state, walls)
            if self._last.get(key) != cur:
                self._last[key] = cur
                self._emit(LinkQuality(t, src, dst, p, state, walls, dist))
        return p, lat, oor

    def _at_path(self, src: int, dst: int, t: float) -> tuple[float, float | None, bool]:
        """``at`` for i.i.d. loss times path loss, no trace, no events (same result, fewer steps)."""
        sp = self.path.quality(src, dst, t)[0]  # type: ignore[union-attr]
        return self._p * sp, None, sp <= 0.0
