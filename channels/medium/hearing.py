"""Who hears whom on the shared medium, from the positions over time (and the walls).

Radios i and j hear each other at time t (eq. M-3) iff

    |p_i(t_k) - p_j(t_k)| <= sense_range_m                         (or sense_range_m is None)
    and, with channel.path_loss enabled, P_rx(d, walls) >= cs_threshold_dbm   (eq. PL-1)

where t_k = k * update_s is the start of the step holding t: the relation is recomputed once a
step from the positions then (walls counted by the scene's ray caster), so it follows the
robots as they move. Hearing is symmetric (one range, one path loss both ways) and decides
three things at once: carrier sense, decoding and collisions.
"""
from __future__ import annotations

from typing import Callable

import networkx as nx
import numpy as np

from ramensim.channels.medium.clock import NS
from ramensim.channels.medium.config import MediumConfig
from ramensim.channels.pathloss import FirstHit, PathLossConfig, count_walls, received_power_dbm

Position = Callable[[int, float], np.ndarray]


class Hearing:
    """The hearing relation of eq. M-3 for ``n`` radios, one boolean matrix per step."""

    def __init__(self, cfg: MediumConfig, n: int, position: Position | None,
                 path_loss: PathLossConfig | None = None, first_hit: FirstHit | None = None) -> None:
        self.n = n
        self.cfg = cfg
        self.path_loss = path_loss if path_loss is not None and path_loss.enabled else None
        self.first_hit = first_hit
        self.position = position
        self.static = cfg.sense_range_m is None and self.path_loss is None
        if not self.static and position is None:
            raise ValueError("channel.medium.sense_range_m (or channel.path_loss) needs the robots' positions, "
                             "but the channel was built without a position(agent, t) callable.")
        self._step_ns = max(1, int(round(cfg.update_s * NS)))
        full = np.ones((n, n), dtype=bool)
        np.fill_diagonal(full, False)
        self._all = (full, [tuple(j for j in range(n) if j != i) for i in range(n)])
        self._cache: dict[int, tuple[np.ndarray, list[tuple[int, ...]]]] = {}
        """The relation of the last two steps asked for (a fluid share reads the step it leaves)."""
        self.recomputes = 0

    def next_change_ns(self, t_ns: int) -> int | None:
        """Start of the step after the one holding ``t_ns`` (None when hearing never changes)."""
        return None if self.static else (t_ns // self._step_ns + 1) * self._step_ns

    def matrix(self, t_ns: int) -> np.ndarray:
        """``H[i, j]``: i and j hear each other at ``t_ns`` (diagonal False)."""
        return self._at(t_ns)[0]

    def listeners(self, i: int, t_ns: int) -> tuple[int, ...]:
        """The radios that hear ``i`` at ``t_ns``."""
        return self._at(t_ns)[1][i]

    def _at(self, t_ns: int) -> tuple[np.ndarray, list[tuple[int, ...]]]:
        if self.static:
            return self._all
        k = t_ns // self._step_ns
        got = self._cache.get(k)
        if got is None:
            if len(self._cache) >= 2:
                del self._cache[min(self._cache)]
            got = self._cache[k] = self._compute(k * self._step_ns / NS)
        return got

    def _compute(self, t: float) -> tuple[np.ndarray, list[tuple[int, ...]]]:
        n = self.n
        assert self.position is not None
        pos = np.stack([np.asarray(self.position(i, t), dtype=np.float64) for i in range(n)])
        d = np.sqrt(((pos[:, None, :] - pos[None, :, :]) ** 2).sum(-1))
        r = self.cfg.sense_range_m
        h = np.ones((n, n), dtype=bool) if r is None else d <= r
        pl = self.path_loss
        if pl is not None:
            iu, ju = np.triu_indices(n, 1)
            walls = np.zeros(iu.size, dtype=np.int64)
            if self.first_hit is not None and pl.wall_loss_db > 0.0 and iu.size:
                walls = np.minimum(count_walls(self.first_hit, pos[iu], pos[ju], 2 * pl.max_walls), pl.max_walls)
            ok = np.array([received_power_dbm(pl, float(d[a, b]), int(w)) >= self.cfg.cs_threshold_dbm
                           for a, b, w in zip(iu, ju, walls)], dtype=bool)
            hp = np.zeros((n, n), dtype=bool)
            hp[iu, ju] = ok
            hp |= hp.T
            h &= hp
        np.fill_diagonal(h, False)
        self.recomputes += 1
        return h, [tuple(np.flatnonzero(h[i]).tolist()) for i in range(n)]

    def domains(self, t_ns: int) -> list[tuple[int, ...]]:
        """The collision domains at ``t_ns``: connected components of the hearing graph, sorted."""
        g = nx.from_numpy_array(self.matrix(t_ns).astype(np.int8))
        return sorted(tuple(sorted(c)) for c in nx.connected_components(g))
