"""Path loss through the scene: link success from distance and the walls between two robots.

Received power (dBm) of a link of length d metres that crosses W walls:

    P_rx = P_tx - PL0 - 10 n log10(max(d, d0) / d0) - W * L_wall                 (PL-1)

(log-distance path loss with exponent n and reference loss PL0 at distance d0, plus a fixed
attenuation L_wall dB per wall crossed: the multi-wall model). The packet success
probability is a documented curve of P_rx: piecewise linear between the points
``curve = [[P_1, s_1], ..., [P_k, s_k]]`` (dBm, probability), P_i strictly increasing and
s_i non-decreasing, held flat below P_1 and above P_k:

    s(P_rx) = interp(P_rx; P_i, s_i).                                              (PL-2)

A link whose success is 0 is out of range; so range is a consequence of (PL-1, PL-2) and no
separate cut-off is needed.

Walls are counted by ray casting along the segment between the two robots: the channel
does not know the scene; the simulation hands it a ``FirstHit`` callable (the world's
Embree caster) and :func:`count_walls` walks the segment from hit to hit. A wall, or any
closed solid (a box of furniture), is entered and left, so it adds two surface hits:
W = ceil(hits / 2). Results are cached per unordered pair and time step
(``time_step_s``): positions are taken at the start of the step, so a link is ray cast at
most once per step.
"""
from __future__ import annotations

import math
from itertools import repeat

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

# FirstHit and Position (what a radio model is handed) are declared with the registry; the
# channel's modules still import them from here
from ramensim.channels.radios import FirstHit, Position, RadioContext, RadioModelSpec, register_radio


class PathLossConfig(BaseModel):
    """Path loss through the scene (``channel.path_loss``, ``ramensim.channels.pathloss``):
    received power P_rx = tx_power_dbm - ref_loss_db - 10 exponent log10(d / ref_distance_m)
    - walls * wall_loss_db (eq. PL-1), mapped to packet success by the piecewise-linear
    ``curve`` (eq. PL-2). A message's success probability is success_rate (or the burst
    chain's) times this; a link of success 0 is out of range."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    enabled: bool = False
    """Apply path loss (true | false)."""
    tx_power_dbm: float = Field(0.0, ge=-100.0, le=60.0, allow_inf_nan=False)
    """Transmit power in dBm (0 dBm = 1 mW, a low-power radio)."""
    ref_loss_db: float = Field(40.0, ge=0.0, le=200.0, allow_inf_nan=False)
    """Path loss at the reference distance in dB (free space at 2.4 GHz and 1 m: 40 dB)."""
    ref_distance_m: float = Field(1.0, gt=0.0, le=1000.0, allow_inf_nan=False)
    """Reference distance d0 in metres; closer links count as d0."""
    exponent: float = Field(3.0, ge=1.0, le=8.0, allow_inf_nan=False)
    """Log-distance path loss exponent n (2 free space, 3-4 indoors)."""
    wall_loss_db: float = Field(8.0, ge=0.0, le=100.0, allow_inf_nan=False)
    """Attenuation per wall crossed in dB (drywall about 3-5, brick or concrete 8-15); 0 = no ray casting."""
    max_walls: int = Field(16, ge=1, le=1000)
    """Walls counted at most along one link (count; bounds the ray casts per pair)."""
    curve: list[tuple[float, float]] = Field(default_factory=lambda: [(-92.0, 0.0), (-82.0, 1.0)])
    """Packet success as a function of received power: points [[P_rx dBm, success], ...], P_rx strictly
    increasing, success non-decreasing in [0, 1]; linear between points, flat beyond the ends."""
    time_step_s: float = Field(0.1, ge=0.0, le=3600.0, allow_inf_nan=False)
    """Link quality is computed once per pair and time step from the positions at the step's start (seconds; 0 = every send)."""

    @field_validator("curve")
    @classmethod
    def _monotone(cls, v: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if not 1 <= len(v) <= 1000:
            raise ValueError(f"channel.path_loss.curve has {len(v)} points; expected 1 to 1000 [P_rx dBm, success] pairs.")
        for i, (x, y) in enumerate(v):
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError(f"channel.path_loss.curve[{i}] = [{x}, {y}] is not finite; expected [dBm, probability].")
            if not 0.0 <= y <= 1.0:
                raise ValueError(f"channel.path_loss.curve[{i}] = [{x}, {y}]: success {y} is not a probability in [0, 1].")
            if i and not x > v[i - 1][0]:
                raise ValueError(
                    f"channel.path_loss.curve[{i}] = [{x}, {y}]: received power {x} dBm does not exceed the previous "
                    f"point's {v[i - 1][0]} dBm; the curve's powers must strictly increase."
                )
            if i and y < v[i - 1][1]:
                raise ValueError(
                    f"channel.path_loss.curve[{i}] = [{x}, {y}]: success {y} is below the previous point's "
                    f"{v[i - 1][1]}; the curve must be monotone (more power never loses more)."
                )
        return v


_STEP_PAST_M = 1e-4
"""After a hit, the next ray starts this far (m) past it (walls are centimetres thick)."""


def count_walls(first_hit: FirstHit, p: np.ndarray, q: np.ndarray, max_hits: int = 64) -> np.ndarray:
    """Walls crossed by each segment p[i] -> q[i] (m, (m, 3) arrays): ceil(surface hits / 2).

    All segments are advanced together, one batched ray cast per hit, at most ``max_hits``
    casts (a segment with more hits counts ``max_hits``).
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(q, dtype=np.float64).reshape(-1, 3)
    v = q - p
    length = np.sqrt((v * v).sum(axis=1))
    hits = np.zeros(len(p), dtype=np.int64)
    live = np.flatnonzero(length > _STEP_PAST_M)
    if live.size == 0:
        return hits
    d = v[live] / length[live, None]
    travelled = np.zeros(live.size)
    for _ in range(max_hits):
        s = np.asarray(first_hit(p[live] + d * travelled[:, None], d), dtype=np.float64)
        reached = travelled + s
        more = np.isfinite(s) & (reached < length[live])
        if not more.any():
            break
        hits[live[more]] += 1
        live, d, travelled = live[more], d[more], reached[more] + _STEP_PAST_M
    return (hits + 1) // 2


def received_power_dbm(cfg: PathLossConfig, distance_m: float, walls: int) -> float:
    """P_rx of (PL-1) in dBm."""
    d = max(distance_m, cfg.ref_distance_m)
    return (cfg.tx_power_dbm - cfg.ref_loss_db - 10.0 * cfg.exponent * math.log10(d / cfg.ref_distance_m)
            - walls * cfg.wall_loss_db)


def success_of_power(cfg: PathLossConfig, p_rx_dbm: float) -> float:
    """s(P_rx) of (PL-2): packet success probability for a received power in dBm."""
    xs = [c[0] for c in cfg.curve]
    ys = [c[1] for c in cfg.curve]
    return float(np.interp(p_rx_dbm, xs, ys))


class PathLoss:
    """Success probability of every link from positions and walls, cached per pair and step.

    ``quality(a, b, t) -> (success, walls, distance_m)``. ``first_hit`` is None when wall
    attenuation is not used (``wall_loss_db == 0``); then no ray is cast and walls are 0.
    The first query of a new time step recomputes every pair seen so far in one batch (one
    position call per agent, one batched ray cast per hit), so steady traffic costs a few
    array operations per step instead of ray casts per message.
    """

    def __init__(self, cfg: PathLossConfig, position: Position, first_hit: FirstHit | None) -> None:
        if cfg.wall_loss_db > 0.0 and first_hit is None:
            raise ValueError(
                f"channel.path_loss.wall_loss_db = {cfg.wall_loss_db} dB needs the scene's geometry to count "
                "walls, but this world has no scene mesh; set wall_loss_db: 0 or use a scene with a mesh."
            )
        self.cfg = cfg
        self._position = position
        self._first_hit = first_hit if cfg.wall_loss_db > 0.0 else None
        self._step = cfg.time_step_s
        self._xs = np.array([c[0] for c in cfg.curve], dtype=np.float64)
        self._ys = np.array([c[1] for c in cfg.curve], dtype=np.float64)
        self._cache: dict[tuple[int, int], tuple[float, tuple[float, int, float]]] = {}
        self._batch_k: float | None = None
        self._pos: dict[int, np.ndarray] = {}
        self.batches = 0
        """Time steps recomputed so far (count)."""

    def quality(self, a: int, b: int, t: float) -> tuple[float, int, float]:
        """(success probability, walls crossed, distance m) of link {a, b} at time ``t`` (s)."""
        key = (a, b) if a < b else (b, a)
        step = self._step
        k = t // step if step > 0.0 else t  # the step's key: floor(t / step)
        hit = self._cache.get(key)
        if hit is not None and hit[0] == k:
            return hit[1]
        ts = k * step if step > 0.0 else t
        if k != self._batch_k:
            self._batch_k = k
            self._pos = {}
            self.batches += 1
            pairs = list(self._cache)
            if hit is None:
                pairs.append(key)
        else:
            pairs = [key]
        self._compute(pairs, k, ts)
        return self._cache[key][1]

    def _compute(self, pairs: list[tuple[int, int]], k: float, ts: float) -> None:
        """(PL-1, PL-2) for ``pairs`` at the step's start ``ts`` (s), vectorised."""
        cfg = self.cfg
        pos, position = self._pos, self._position
        for a in {x for pair in pairs for x in pair}.difference(pos):
            pos[a] = np.asarray(position(a, ts), dtype=np.float64).reshape(3)
        pa = np.stack([pos[a] for a, _ in pairs])
        pb = np.stack([pos[b] for _, b in pairs])
        dist = np.sqrt(((pa - pb) ** 2).sum(axis=1))
        if self._first_hit is not None:
            walls = count_walls(self._first_hit, pa, pb, cfg.max_walls * 2)
        else:
            walls = np.zeros(len(pairs), dtype=np.int64)
        d = np.maximum(dist, cfg.ref_distance_m)
        p_rx = (cfg.tx_power_dbm - cfg.ref_loss_db - 10.0 * cfg.exponent * np.log10(d / cfg.ref_distance_m)
                - walls * cfg.wall_loss_db)
        succ = np.interp(p_rx, self._xs, self._ys)
        self._cache.update(zip(pairs, zip(repeat(k), zip(succ.tolist(), walls.tolist(), dist.tolist()))))


def _build(cfg: PathLossConfig, ctx: RadioContext) -> PathLoss:
    if ctx.position is None:
        raise ValueError("channel.path_loss is enabled, which needs agent positions, but no "
                         "position(agent, t) callable was given to the Channel.")
    return PathLoss(cfg, ctx.position, ctx.first_hit)


register_radio(RadioModelSpec(
    name="path_loss", settings=PathLossConfig, role="factor", active=lambda s: s.enabled, build=_build,
    description="log-distance path loss + per-wall attenuation, mapped to success by a curve (eq. PL-1, PL-2)"))
