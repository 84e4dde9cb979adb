"""The communication graph G = (V, E) of paper section III: who may talk to whom.

Static families (complete, path, ring, star, grid, explicit) are built once with networkx;
``disk`` is dynamic: at time t, agents i and j are neighbours iff their positions are within
``disk_radius_m`` (metres). Edges are undirected.
"""
from __future__ import annotations

import logging
import math
from typing import Callable

import networkx as nx
import numpy as np

from ramensim.channels.config import TopologyConfig

Position = Callable[[int, float], np.ndarray]
"""``position(agent, t) -> ndarray(3)``: an agent's position in metres at simulated time t (s)."""

log = logging.getLogger(__name__)


def _square_shape(n: int) -> tuple[int, int]:
    """The (rows, cols) with rows*cols = n and rows <= cols as close as possible."""
    rows = int(math.isqrt(n))
    while rows > 1 and n % rows:
        rows -= 1
    return max(rows, 1), n // max(rows, 1)


def build_graph(cfg: TopologyConfig, n_agents: int) -> nx.Graph:
    """The static graph of ``cfg`` on nodes 0..n_agents-1 (for ``disk``: no edges).

    Raises ``ValueError`` naming the key when the config does not fit ``n_agents``.
    """
    if n_agents < 1:
        raise ValueError(f"topology: the number of agents must be >= 1, got {n_agents}.")
    n = n_agents
    kind = cfg.kind
    if kind == "complete":
        g = nx.complete_graph(n)
    elif kind == "path":
        g = nx.path_graph(n)
    elif kind == "ring":
        g = nx.cycle_graph(n) if n >= 3 else nx.path_graph(n)
    elif kind == "star":
        c = cfg.star_centre
        if c >= n:
            raise ValueError(
                f"topology.star_centre = {c}, but the scenario has {n} agents (ids 0..{n - 1}); "
                "the centre must be one of them."
            )
        g = nx.empty_graph(n)
        g.add_edges_from((c, j) for j in range(n) if j != c)
    elif kind == "grid":
        rows, cols = cfg.grid_shape if cfg.grid_shape is not None else _square_shape(n)
        if rows * cols != n:
            raise ValueError(
                f"topology.grid_shape = [{rows}, {cols}] holds {rows * cols} agents, but the "
                f"scenario has {n}; rows * cols must equal the number of agents."
            )
        g = nx.empty_graph(n)
        for r in range(rows):
            for c in range(cols):
                i = r * cols + c
                if c + 1 < cols:
                    g.add_edge(i, i + 1)
                if r + 1 < rows:
                    g.add_edge(i, i + cols)
    elif kind == "explicit":
        g = nx.empty_graph(n)
        for k, (a, b) in enumerate(cfg.edges):
            for agent in (a, b):
                if agent >= n:
                    raise ValueError(
                        f"topology.edges[{k}] = [{a}, {b}] names agent {agent}, but the scenario "
                        f"has {n} agents (ids 0..{n - 1})."
                    )
            g.add_edge(a, b)
    else:  # disk: edges depend on time
        g = nx.empty_graph(n)
    return g


class Topology:
    """Neighbour sets of the communication graph at a given simulated time."""

    def __init__(self, cfg: TopologyConfig, n_agents: int, position: Position | None = None) -> None:
        self.cfg = cfg
        self.n_agents = n_agents
        self.dynamic = cfg.kind == "disk"
        """True when the edges depend on time (disk)."""
        self._graph = build_graph(cfg, n_agents)
        if not self.dynamic and n_agents > 1 and not nx.is_connected(self._graph):
            parts = sorted(sorted(c) for c in nx.connected_components(self._graph))
            log.warning("topology (%s): the communication graph is disconnected, %d groups of agents never "
                        "exchange maps (%s); consensus can only agree within each group", cfg.kind, len(parts),
                        "; ".join(", ".join(map(str, p)) for p in parts[:6]) + ("; ..." if len(parts) > 6 else ""))
        if self.dynamic and position is None:
            raise ValueError(
                "topology.kind is 'disk', which needs agent positions, but no position(agent, t) "
                "callable was given to the Topology."
            )
        self._position = position
        self._r2 = (cfg.disk_radius_m or 0.0) ** 2
        self._adj: list[frozenset[int]] = [frozenset(self._graph.adj[i]) for i in range(n_agents)]
        self._nbr: list[tuple[int, ...]] = [tuple(sorted(s)) for s in self._adj]
        self._pos_t: float | None = None
        self._pos: np.ndarray | None = None

    def _positions(self, t: float) -> np.ndarray:
        """(n, 3) positions in metres at time t, cached for the last t asked."""
        if self._pos_t != t or self._pos is None:
            assert self._position is not None
            self._pos = np.stack(
                [np.asarray(self._position(i, t), dtype=np.float64).reshape(3) for i in range(self.n_agents)]
            )
            self._pos_t = t
        return self._pos

    def _check(self, i: int) -> None:
        if not 0 <= i < self.n_agents:
            raise ValueError(f"agent id {i} is out of range: the scenario has {self.n_agents} agents (ids 0..{self.n_agents - 1}).")

    def neighbours(self, i: int, t: float = 0.0) -> list[int]:
        """Sorted neighbour ids of agent ``i`` at time ``t`` (s)."""
        self._check(i)
        if not self.dynamic:
            return list(self._nbr[i])
        p = self._positions(t)
        d2 = ((p - p[i]) ** 2).sum(axis=1)
        return [j for j in np.flatnonzero(d2 <= self._r2).tolist() if j != i]

    def has_edge(self, i: int, j: int, t: float = 0.0) -> bool:
        """Whether {i, j} is an edge at time ``t`` (s)."""
        if not self.dynamic:
            return j in self._adj[i]
        if i == j:
            return False
        p = self._positions(t)
        d = p[i] - p[j]
        return float(d @ d) <= self._r2

    def edges(self, t: float = 0.0) -> list[tuple[int, int]]:
        """Sorted undirected edges ``(a, b)``, a < b, at time ``t`` (s)."""
        return [(a, b) for a in range(self.n_agents) for b in self.neighbours(a, t) if a < b]

    def graph(self, t: float = 0.0) -> nx.Graph:
        """A networkx copy of the graph at time ``t`` (s)."""
        g = nx.empty_graph(self.n_agents)
        g.add_edges_from(self.edges(t))
        return g

    def candidate_pairs(self) -> list[tuple[int, int]]:
        """Every pair ``(a, b)``, a < b, that can ever be an edge (all pairs for disk)."""
        if self.dynamic:
            return [(a, b) for a in range(self.n_agents) for b in range(a + 1, self.n_agents)]
        return self.edges()
