"""Topology builders give the expected edges; bad configs raise clear errors."""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from ramensim.channels.config import TopologyConfig
from ramensim.channels.topology import Topology


def edges(kind: str, n: int, **kw) -> list[tuple[int, int]]:
    return Topology(TopologyConfig(kind=kind, **kw), n).edges()


def test_complete() -> None:
    assert edges("complete", 4) == [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]


def test_path() -> None:
    assert edges("path", 4) == [(0, 1), (1, 2), (2, 3)]


def test_ring() -> None:
    assert edges("ring", 5) == [(0, 1), (0, 4), (1, 2), (2, 3), (3, 4)]
    assert edges("ring", 2) == [(0, 1)]


def test_star() -> None:
    assert edges("star", 4, star_centre=2) == [(0, 2), (1, 2), (2, 3)]
    assert Topology(TopologyConfig(kind="star"), 4).neighbours(0) == [1, 2, 3]


def test_grid_explicit_and_auto_shape() -> None:
    expected = [(0, 1), (0, 3), (1, 2), (1, 4), (2, 5), (3, 4), (4, 5)]
    assert edges("grid", 6, grid_shape=(2, 3)) == expected
    assert edges("grid", 6) == expected  # most square shape of 6 is 2 x 3


def test_explicit() -> None:
    topo = Topology(TopologyConfig(kind="explicit", edges=[(2, 0), (1, 2)]), 3)
    assert topo.edges() == [(0, 2), (1, 2)]
    assert topo.neighbours(2) == [0, 1]
    assert topo.has_edge(0, 2) and topo.has_edge(2, 0) and not topo.has_edge(0, 1)


def test_disk_is_dynamic() -> None:
    # Agent 1 moves along x at 1 m/s; agents 0 and 2 sit at x = 0 and x = 12.
    def position(agent: int, t: float) -> np.ndarray:
        return np.array([[0.0, 0, 0], [t, 0, 0], [12.0, 0, 0]][agent])

    topo = Topology(TopologyConfig(kind="disk", disk_radius_m=5.0), 3, position)
    assert topo.edges(0.0) == [(0, 1)]
    assert topo.edges(6.0) == []
    assert topo.edges(7.5) == [(1, 2)]
    assert topo.neighbours(1, 4.0) == [0]
    assert topo.candidate_pairs() == [(0, 1), (0, 2), (1, 2)]
    g = topo.graph(7.5)
    assert sorted(g.edges()) == [(1, 2)] and g.number_of_nodes() == 3


def test_explicit_edge_naming_missing_agent_is_clear() -> None:
    with pytest.raises(ValueError, match=r"topology\.edges\[1\] = \[1, 7\] names agent 7.*3 agents"):
        Topology(TopologyConfig(kind="explicit", edges=[(0, 1), (1, 7)]), 3)


def test_bad_configs() -> None:
    with pytest.raises(ValueError, match="grid_shape"):
        Topology(TopologyConfig(kind="grid", grid_shape=(2, 2)), 6)
    with pytest.raises(ValueError, match="star_centre"):
        Topology(TopologyConfig(kind="star", star_centre=5), 3)
    with pytest.raises(ValueError, match="position"):
        Topology(TopologyConfig(kind="disk", disk_radius_m=1.0), 3)
    with pytest.raises(ValidationError, match="disk_radius_m"):
        TopologyConfig(kind="disk")
    with pytest.raises(ValidationError, match="edges is empty"):
        TopologyConfig(kind="explicit")
    with pytest.raises(ValidationError, match="kind: explicit"):
        TopologyConfig(kind="ring", edges=[(0, 1)])
    with pytest.raises(ValidationError, match="itself"):
        TopologyConfig(kind="explicit", edges=[(1, 1)])
    with pytest.raises(ValidationError):
        TopologyConfig(kind="complete", unknown=1)


def test_a_disconnected_graph_is_named_in_a_warning(caplog) -> None:
    with caplog.at_level("WARNING"):
        Topology(TopologyConfig(kind="explicit", edges=[(0, 1), (2, 3)]), 5)
    assert "disconnected, 3 groups" in caplog.text and "0, 1; 2, 3; 4" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING"):
        Topology(TopologyConfig(kind="path"), 5)
    assert "disconnected" not in caplog.text
