"""A team's evaluation extracts ``at_once`` meshes at a time (the team engine's workers), scores
them in order and lets them go before the next ones: its memory holds ``at_once`` meshes, not one
per robot, with the same results in the same order (ramensim/scoring.py, Evaluator.score_all)."""
from __future__ import annotations

import weakref
from types import SimpleNamespace

import pytest

from ramensim.scoring import Evaluator


class _Mesh:
    def __init__(self, k: int) -> None:
        self.k = k


def _evaluator(live: weakref.WeakSet, most: list[int]) -> Evaluator:
    ev = object.__new__(Evaluator)
    ev.cfg = SimpleNamespace(mask_unobserved=False, export_mesh=True)

    def extract(neural_map, poses, fed_by, times=None, colours=True):
        most[0] = max(most[0], len(live) + 1)  # the meshes alive while this one is made
        mesh = _Mesh(neural_map)
        live.add(mesh)
        return mesh

    ev.extract = extract
    ev.score = lambda _m, poses, fed_by, mesh_path=None, on_mesh=None, mesh=None, times=None: {"k": mesh.k, "fed": fed_by}
    return ev


@pytest.mark.parametrize("at_once", [None, 1, 2, 5])
def test_meshes_alive_at_once_are_bounded_and_results_in_order(at_once):
    live, most = weakref.WeakSet(), [0]
    ev = _evaluator(live, most)
    items = [(k, [k], None) for k in range(7)]
    out = ev.score_all(items, [], at_once=at_once)
    assert out == [{"k": k, "fed": [k]} for k in range(7)]
    assert most[0] == (7 if at_once is None else at_once)
    assert len(live) == 0
