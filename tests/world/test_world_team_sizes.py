"""Teams of any size from 1 to 100 on every built-in scene either get trajectories or are refused
with the reason and what to do instead (never "collapsed to a point" from a default split)."""
from __future__ import annotations

import pytest

from ramensim.config import load_scenario
from ramensim.core.errors import InputError
from ramensim.core.seeding import Seeds
from ramensim.world import build_world

SCENARIO = "scenarios/office_3agents.yaml"


def _world(scene: str, n: int, split: str):
    sc = load_scenario(SCENARIO, [f"agents.count={n}", f"world.scene.name={scene}", "duration=4",
                                  f"world.trajectory.split={split}"])
    return build_world(sc.world, n, sc.duration, Seeds(0).numpy)


def test_regions_too_narrow_for_the_team_is_refused_with_what_to_do() -> None:
    with pytest.raises(InputError) as err:
        _world("office", 12, "regions")  # the default scenario's split, twelve robots
    text = str(err.value)
    assert text.startswith("world.trajectory.split: 'regions' cuts the scene's free space into 12 slabs")
    assert "split: chunks" in text and "split: none" in text


@pytest.mark.parametrize("scene", ["office", "living_room", "apartment", "house"])
def test_a_hundred_robots_anywhere_in_every_builtin_scene(scene: str) -> None:
    world = _world(scene, 100, "none")
    assert world.n_agents == 100


def test_a_hundred_chunks_of_one_tour_are_refused_with_the_shortest_chunk() -> None:
    with pytest.raises(InputError, match=r"into 100 chunks, the shortest"):
        _world("office", 100, "chunks")
