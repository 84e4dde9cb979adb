"""Unit tests of the recorder's helpers and settings (no .rrd written)."""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from ramensim.recording import RecordingConfig, make_recorder
from ramensim.recording import paths, style
from ramensim.recording.blueprint import default_blueprint
from ramensim.recording.geometry import TrajectoryTrail, rgb_to_uint8, stride_image, strided_intrinsics, vertex_normals
from ramensim.recording.stream import recording_id


def test_config_defaults_and_docstrings():
    cfg = RecordingConfig()
    assert cfg.mode == "save" and cfg.file_name == "run.rrd"
    assert cfg.image_downsample >= 1 and cfg.max_image_rate_hz > 0
    for name, field in RecordingConfig.model_fields.items():
        assert field.description, f"field {name} has no docstring"
        assert not field.is_required(), f"field {name} has no default"


@pytest.mark.parametrize("bad", [{"mode": "live"}, {"image_downsample": 0}, {"max_image_rate_hz": 0.0},
                                 {"file_name": "a/b.rrd"}, {"url": "http://x"}, {"serve_port": 70000},
                                 {"world_coordinates": "UP"}, {"unknown_key": 1}])
def test_config_rejects_bad_values(bad):
    with pytest.raises(ValidationError):
        RecordingConfig(**bad)


def test_make_recorder_off_returns_none(tmp_path):
    assert make_recorder(RecordingConfig(mode="off"), tmp_path, 2) is None
    assert not any(tmp_path.iterdir())


def test_recording_id_is_deterministic_and_distinct():
    a = recording_id("ramensim", "run_x", 0)
    assert a == recording_id("ramensim", "run_x", 0)
    assert a != recording_id("ramensim", "run_x", 1)
    assert a != recording_id("ramensim", "run_y", 0)


def test_trail_keeps_points_beyond_min_step_and_bounds_segments():
    trail = TrajectoryTrail(min_step_m=0.1, segment_points=4)
    kept = []
    for i in range(20):
        o = trail.add(np.array([0.05 * i, 0.0, 0.0]))
        if o is not None:
            kept.append((o[0], o[1].copy()))
    # points every 0.15 m (0.05 steps, kept when > 0.1 m from the last kept): x = 0, .15, .3, ...
    first_seg = [o for o in kept if o[0] == 0][-1][1]
    assert first_seg.shape == (4, 3)
    np.testing.assert_allclose(first_seg[:, 0], [0.0, 0.15, 0.3, 0.45], atol=1e-6)
    second = [o for o in kept if o[0] == 1][0][1]
    np.testing.assert_allclose(second[0], first_seg[-1])  # segments join up
    assert max(len(o[1]) for o in kept) <= 4


def test_strided_intrinsics_match_strided_pixels():
    K = (500.0, 400.0, 319.5, 239.5, 640, 480)
    mat, (w, h) = strided_intrinsics(K, 4)
    img = np.zeros((480, 640, 3), np.float32)
    assert stride_image(img, 4).shape == (h, w, 3) == (120, 160, 3)
    # a 3-D point projecting onto old pixel (8, 4) lands on new pixel (2, 1)
    X = np.array([(8 - 319.5) / 500.0, (4 - 239.5) / 400.0, 1.0])
    uv = mat @ X
    np.testing.assert_allclose(uv[:2] / uv[2], [2.0, 1.0], atol=1e-9)
    assert strided_intrinsics((1, 1, 0, 0, 641, 481), 4)[1] == (161, 121)


def test_rgb_to_uint8_rounds_and_clips():
    out = rgb_to_uint8(np.array([[[0.0, 0.5, 1.2]]], np.float32))
    assert out.dtype == np.uint8 and out.tolist() == [[[0, 128, 255]]]


def test_vertex_normals_of_a_flat_square_point_up():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 5]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    n = vertex_normals(v, f)
    np.testing.assert_allclose(n[:4], [[0, 0, 1]] * 4, atol=1e-6)
    np.testing.assert_allclose(n[4], [0, 0, 0])  # unused vertex


def test_viridis_endpoints_and_colors():
    c = style.viridis(np.array([0.0, 1.0, 2.0, np.nan]))
    assert c.tolist() == [[68, 1, 84], [253, 231, 37], [253, 231, 37], [68, 1, 84]]
    assert style.agent_color(0) != style.agent_color(1)
    assert style.lost_color("out_of_range") != style.DELIVERED


def test_paths_escape_names():
    assert paths.agent("robot 1") == "world/agents/robot\\ 1"
    assert paths.plot_group(paths.plot("round", "loss", "a0")) == "plots/round/loss"


def test_blueprint_builds_with_plot_groups():
    bp = default_blueprint(["a0", "a1"], ["plots/round/loss", "plots/metrics/f1", "plots/zzz/x"])
    assert bp is not None
