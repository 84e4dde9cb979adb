"""build_world on a built-in scene: schedule, positions, determinism, file trajectories."""
import numpy as np
import pytest

from ramensim.core.errors import InputError
from ramensim.core.seeding import Seeds
from ramensim.world import build_world
from ramensim.world.config import WorldConfig


def _cfg(**sensor):
    return WorldConfig.model_validate({"scene": {"name": "living_room"}, "camera": {
        "fps": 2.0, "sensor": {"depth_noise_a": 0.005, "missing_fraction": 0.1, **sensor}}})


def test_schedule_and_determinism():
    a = build_world(_cfg(), 2, 5.0, Seeds(4).numpy)
    b = build_world(_cfg(), 2, 5.0, Seeds(4).numpy)
    c = build_world(_cfg(), 2, 5.0, Seeds(5).numpy)
    times = [t for t, _ in a.frames_for(0)]
    assert times == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5]
    assert np.allclose(a.position(1, 2.0), a.frames_for(1)[4][1][:3, 3])
    fa, fb = a.render(1, 3), b.render(1, 3)
    assert np.array_equal(fa.depth, fb.depth) and np.array_equal(fa.rgb, fb.rgb)
    assert not np.array_equal(a.frames_for(0)[0][1], c.frames_for(0)[0][1])
    assert np.array_equal(a.render(1, 3).depth, fa.depth)  # lazy and order-independent
    assert a.is_keyframe(0) and not a.is_keyframe(1)


def test_file_trajectories(tmp_path):
    p = tmp_path / "t.txt"
    p.write_text("0 2 2 1.4 0 0 0 1\n10 3 2 1.4 0 0 0 1\n")
    cfg = WorldConfig.model_validate({"scene": {"name": "office"},
                                      "trajectory": {"kind": "file", "paths": ["t.txt"]}})
    w = build_world(cfg, 1, 4.0, base_dir=tmp_path)
    assert np.allclose(w.position(0, 5.0), [2.5, 2, 1.4])
    with pytest.raises(InputError, match="one trajectory file per agent"):
        build_world(cfg, 2, 4.0, base_dir=tmp_path)
