"""Burst loss: a two-state Gilbert-Elliott channel per directed link (times in seconds).

Each directed link is a continuous-time Markov chain with a good state G and a bad state B.
It stays in G for an exponential time of mean ``T_G`` and in B for one of mean ``T_B``
(seconds), then switches. A message sent while the link is in state X is lost with
probability ``h_X`` (``good_loss``, ``bad_loss``). In the long run the link is bad a share

    pi_B = T_B / (T_G + T_B)                                                    (GE-1)

of the time, so the long-run success probability is

    s = (1 - pi_B) (1 - h_G) + pi_B (1 - h_B).                                   (GE-2)

The knob is ``s`` itself (``channel.success_rate``, as for i.i.d. loss): given ``s``, h_G,
h_B (h_G < h_B) and the mean bad sojourn T_B, solving (GE-2) and (GE-1) gives

    pi_B = (1 - h_G - s) / (h_B - h_G),     T_G = T_B (1 - pi_B) / pi_B,          (GE-3)

which needs ``1 - h_B <= s <= 1 - h_G``. So an i.i.d. channel and a bursty one at the same
``success_rate`` lose the same share of messages in the long run; only the clustering
differs. Messages sent Delta seconds apart on a link see the same state with probability

    P(B at t + Delta | B at t) = pi_B + (1 - pi_B) exp(-(1/T_G + 1/T_B) Delta),    (GE-4)

so with h_G = 0, h_B = 1 a run of consecutive losses has geometric length of mean
1 / (1 - P(B | B)) messages (``mean_loss_run``).

The state path of a link is sampled exactly (alternating exponential sojourns) from the
link's own generator and does not depend on the traffic: the state at time t is a function
of the seed, the link and t only. The chain starts in its stationary distribution at t = 0.
"""
from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ramensim.channels.draws import keyed_child
from ramensim.channels.radios import RadioModelSpec, register_radio

GOOD = 0
BAD = 1


class BurstConfig(BaseModel):
    """Burst loss (``channel.burst``): i.i.d. (one coin per message) or a Gilbert-Elliott
    good/bad chain per directed link whose long-run success equals ``channel.success_rate``
    (``ramensim.channels.burst``, eq. GE-1..GE-3): set the loss in each state and the mean
    time in the bad state; the mean time in the good state follows from success_rate."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    kind: Literal["iid", "gilbert_elliott"] = "iid"
    """Loss process per directed link (iid | gilbert_elliott)."""
    mean_bad_s: float = Field(2.0, gt=0.0, le=1.0e6, allow_inf_nan=False)
    """Mean sojourn in the bad state, i.e. the mean burst duration (seconds; gilbert_elliott)."""
    good_loss: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    """Loss probability of a message sent in the good state (probability; gilbert_elliott)."""
    bad_loss: float = Field(1.0, ge=0.0, le=1.0, allow_inf_nan=False)
    """Loss probability of a message sent in the bad state (probability, > good_loss; gilbert_elliott)."""

    @model_validator(mode="after")
    def _check(self) -> BurstConfig:
        if self.kind == "gilbert_elliott" and not self.bad_loss > self.good_loss:
            raise ValueError(
                f"channel.burst: bad_loss={self.bad_loss} must exceed good_loss={self.good_loss} "
                "(probabilities); the bad state is the one that loses more."
            )
        return self


def stationary_bad(success: float, good_loss: float, bad_loss: float) -> float:
    """pi_B of (GE-3): the long-run share of time in the bad state (probability)."""
    if not bad_loss > good_loss:
        raise ValueError(f"Gilbert-Elliott needs bad_loss > good_loss, got good_loss={good_loss}, bad_loss={bad_loss}.")
    pi_b = (1.0 - good_loss - success) / (bad_loss - good_loss)
    return min(1.0, max(0.0, pi_b))


def mean_good_s(success: float, good_loss: float, bad_loss: float, mean_bad_s: float) -> float:
    """T_G of (GE-3) in seconds (inf when the link is never bad, 0 when it is always bad)."""
    pi_b = stationary_bad(success, good_loss, bad_loss)
    if pi_b <= 0.0:
        return math.inf
    return mean_bad_s * (1.0 - pi_b) / pi_b


def stay_bad_probability(success: float, good_loss: float, bad_loss: float, mean_bad_s: float,
                         delta_s: float) -> float:
    """P(B at t + delta | B at t) of (GE-4) (probability)."""
    pi_b = stationary_bad(success, good_loss, bad_loss)
    t_g = mean_good_s(success, good_loss, bad_loss, mean_bad_s)
    rate = (0.0 if math.isinf(t_g) else 1.0 / t_g) + 1.0 / mean_bad_s
    return pi_b + (1.0 - pi_b) * math.exp(-rate * delta_s)


def mean_loss_run(success: float, good_loss: float, bad_loss: float, mean_bad_s: float, delta_s: float) -> float:
    """Mean length (messages) of a run of consecutive losses for messages delta_s apart,
    with good_loss = 0 and bad_loss = 1: 1 / (1 - P(B | B)) (GE-4)."""
    return 1.0 / (1.0 - stay_bad_probability(success, good_loss, bad_loss, mean_bad_s, delta_s))


class GilbertElliottLink:
    """The good/bad state path of one directed link, advanced lazily to non-decreasing times.

    ``state(t)`` returns GOOD or BAD at time t (s); times must not decrease between calls
    (the channel asks at send times, which never decrease). ``switches`` lists the times (s)
    at which the state changed so far, for tests and reports.
    """

    __slots__ = ("_rng", "_mean", "_state", "_next", "_t", "switches")

    def __init__(self, rng: np.random.Generator, mean_good_s: float, mean_bad_s: float, pi_bad: float) -> None:
        self._rng = rng
        self._mean = (mean_good_s, mean_bad_s)
        # Stationary start: one uniform picks the state, then a fresh exponential sojourn
        # (memoryless, so this is the stationary residual time).
        u = float(rng.random())
        self._state = BAD if u < pi_bad else GOOD
        self._next = self._draw(self._state)
        self._t = 0.0
        self.switches: list[float] = []

    def _draw(self, state: int) -> float:
        m = self._mean[state]
        if math.isinf(m):
            return math.inf
        return float(self._rng.exponential(m)) if m > 0.0 else 0.0

    def state(self, t: float) -> int:
        """GOOD or BAD at time ``t`` (s), t >= the time of the previous call."""
        if t < self._t:
            raise ValueError(f"GilbertElliottLink.state: time went back from {self._t} s to {t} s.")
        self._t = t
        nxt = self._next
        if t < nxt:  # the common case: no switch since the last call
            return self._state
        while nxt <= t:
            self._state ^= 1
            self.switches.append(nxt)
            d = self._draw(self._state)
            if d == 0.0 and self._mean[self._state] == 0.0:
                # A state of zero mean sojourn is never occupied: switch straight back.
                self._state ^= 1
                d = self._draw(self._state)
            nxt = nxt + d
        self._next = nxt
        return self._state


def link_rng(parent: np.random.SeedSequence, src: int, dst: int) -> np.random.Generator:
    """The generator of link ``src -> dst``: a child of ``parent`` keyed by the link, so it does
    not depend on which links carried traffic first."""
    return np.random.Generator(np.random.PCG64(keyed_child(parent, 1_000_003, src, dst)))


_STATES = ("good", "bad")


class BurstModel:
    """The Gilbert-Elliott chains of every directed link as a ``base`` radio model
    (:mod:`ramensim.channels.radios`): ``quality(src, dst, t) -> (1 - h_state(t), state)``."""

    def __init__(self, cfg: BurstConfig, success_rate: float, n_agents: int,
                 seed_seq: np.random.SeedSequence) -> None:
        self.cfg = cfg
        self.n = n_agents
        self._seed_seq = seed_seq
        self._pi_bad = stationary_bad(success_rate, cfg.good_loss, cfg.bad_loss)
        self._t_good = mean_good_s(success_rate, cfg.good_loss, cfg.bad_loss, cfg.mean_bad_s)
        self._success_by_state = (1.0 - cfg.good_loss, 1.0 - cfg.bad_loss)
        self._chain_list: list[GilbertElliottLink | None] = [None] * (n_agents * n_agents)

    def chain(self, src: int, dst: int) -> GilbertElliottLink:
        """The Gilbert-Elliott state path of ``src -> dst`` (built on first use from its own seed)."""
        ch = self._chain_list[src * self.n + dst]
        if ch is None:
            ch = self._chain_list[src * self.n + dst] = GilbertElliottLink(
                link_rng(self._seed_seq, src, dst), self._t_good, self.cfg.mean_bad_s, self._pi_bad)
        return ch

    def quality(self, src: int, dst: int, t: float) -> tuple[float, str]:
        """(success probability 1 - h_state, state name) of ``src -> dst`` at ``t`` (s)."""
        s = (self._chain_list[src * self.n + dst] or self.chain(src, dst)).state(t)
        return self._success_by_state[s], _STATES[s]


register_radio(RadioModelSpec(
    name="burst", settings=BurstConfig, role="base", active=lambda s: s.kind != "iid",
    build=lambda s, ctx: BurstModel(s, ctx.channel.success_rate, ctx.n_agents, ctx.seed_seq),
    description="Gilbert-Elliott good/bad chain per directed link at the long-run success_rate (eq. GE-1..GE-4)"))
