"""Unit tests of the recorder's helpers and settings (no .rrd written)."""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from ramensim.recording import RecordingConfig, make_recorder
from ramensim.recording import paths, style
from ramensim.recording.blueprint import default_blueprint
from ramensim.recording.geometry import TrajectoryTrail, rgb_to_uint8, stride_image, strided_intrinsics, vertex_normals
from ramensim.recording.cutaway import clip_below, cut_height, cutaway, steep_faces, up_vector
from ramensim.recording.stream import canonical_json, read_resolved_scenario, recording_id
from ramensim.recording.synthetic import grid_box


def test_config_defaults_and_docstrings():
    cfg = RecordingConfig()
    assert cfg.mode == "save" and cfg.file_name == "run.rrd"
    assert cfg.image_downsample == 1 and cfg.max_image_rate_hz > 0      # images at the render's size
    assert cfg.map_colors == "agent" and cfg.cutaway_fraction == 0.7 and 0 < cfg.wall_opacity < 1
    for name, field in RecordingConfig.model_fields.items():
        assert field.description, f"field {name} has no docstring"
        assert not field.is_required(), f"field {name} has no default"


@pytest.mark.parametrize("bad", [{"mode": "live"}, {"image_downsample": 0}, {"max_image_rate_hz": 0.0},
                                 {"file_name": "a/b.rrd"}, {"url": "http://x"}, {"serve_port": 70000},
                                 {"world_coordinates": "UP"}, {"unknown_key": 1}, {"map_colors": "rainbow"},
                                 {"cutaway_fraction": 0.0}, {"cutaway_fraction": 1.5}, {"wall_opacity": -0.1},
                                 {"scene_opacity": 2.0}])
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


def test_recording_id_covers_the_whole_resolved_scenario():
    sc = {"name": "office", "seed": 0, "channel": {"success_rate": 0.5, "bandwidth_bps": 1e8}}
    same_other_order = {"channel": {"bandwidth_bps": 1e8, "success_rate": 0.5}, "seed": 0, "name": "office"}
    other = {"name": "office", "seed": 0, "channel": {"success_rate": 0.2, "bandwidth_bps": 1e8}}
    base = recording_id("ramensim", "office", 0, sc)
    assert base == recording_id("ramensim", "office", 0, same_other_order)     # canonical JSON
    assert canonical_json(sc) == canonical_json(same_other_order)
    assert base != recording_id("ramensim", "office", 0, other)                # any setting -> apart
    assert base != recording_id("ramensim", "office", 1, sc)
    assert base != recording_id("ramensim", "office", 0)                       # name and seed only


def test_read_resolved_scenario(tmp_path):
    assert read_resolved_scenario(tmp_path) is None
    (tmp_path / "scenario.yaml").write_text("name: x\nchannel: {success_rate: 0.5}\n")
    assert read_resolved_scenario(tmp_path) == {"name": "x", "channel": {"success_rate": 0.5}}
    (tmp_path / "scenario.yaml").write_text("- a list\n")
    assert read_resolved_scenario(tmp_path) is None


def _area(v, f):
    v = np.asarray(v, float)
    f = np.asarray(f, int)
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()


def _normals(v, f):
    v = np.asarray(v, float)
    f = np.asarray(f, int)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


@pytest.mark.parametrize("h", [0.5, 1.3, 2.0, 2.9])
def test_cutaway_of_a_closed_box_clips_exactly(h):
    # a 2 x 1 x 3 m box, each face a 3 x 3 grid: bottom 2 m^2, walls 6 m of perimeter, top 2 m^2
    v, f = grid_box(np.array([0.0, 0.0, 0.0]), np.array([2.0, 1.0, 3.0]), 3)
    lower, upper = cutaway(v, f, None, up_vector("RIGHT_HAND_Z_UP"), h)
    assert _area(lower.vertices, lower.faces) == pytest.approx(2.0 + 6.0 * h, rel=1e-6)
    assert _area(upper.vertices, upper.faces) == pytest.approx(6.0 * (3.0 - h), rel=1e-6)   # no ceiling
    assert lower.vertices[:, 2].max() <= h + 1e-6 and upper.vertices[:, 2].min() >= h - 1e-6
    assert len(upper) > 0
    assert steep_faces(upper.vertices, upper.faces, np.array([0.0, 0.0, 1.0])).all()   # walls only
    # the winding is kept: every clipped face points where the face it came from pointed
    orig = _normals(v, f)
    for part in (lower, upper):
        n = _normals(part.vertices, part.faces)
        centre = part.vertices[part.faces].mean(axis=1)
        for k in range(len(n)):
            # the original faces that lie in the same plane as this piece
            same_plane = np.abs(np.einsum("ij,j->i", orig, centre[k]) - np.einsum("ij,ij->i", orig,
                                v[f[:, 0]])) < 1e-6
            assert np.any(same_plane & (np.einsum("ij,j->i", orig, n[k]) > 0.999))


def test_clip_interpolates_colours_and_keeps_whole_faces():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 2], [5, 5, 0], [6, 5, 0], [5, 6, 0]], float)
    f = np.array([[0, 1, 2], [3, 4, 5]])
    c = np.array([[0, 0, 0], [0, 0, 0], [200, 100, 50], [1, 2, 3], [4, 5, 6], [7, 8, 9]], np.uint8)
    part = clip_below(v, f, c, np.array([0.0, 0.0, 1.0]), 1.0)
    assert len(part.faces) == 3                       # the flat triangle whole, the other cut to a quad
    top = np.isclose(part.vertices[:, 2], 1.0)
    assert top.sum() == 2
    np.testing.assert_array_equal(part.colors[top], [[100, 50, 25], [100, 50, 25]])   # halfway up
    assert {tuple(x) for x in part.colors.tolist()} >= {(1, 2, 3), (4, 5, 6), (7, 8, 9)}
    assert cut_height(-0.2, 3.0, 0.5) == pytest.approx(1.4)
    empty = clip_below(v, f, c, np.array([0.0, 0.0, 1.0]), -1.0)
    assert len(empty) == 0 and empty.colors.shape == (0, 3)


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
    bp = default_blueprint(["a0"], [], np.array([[0.0, 0.0, 0.0], [6.0, 4.0, 3.0]]), "RIGHT_HAND_Z_UP")
    assert bp is not None


def test_plot_titles_fit_small_views():
    """View titles read as words with units (they were cut to 'completion_' and 'own_covera')."""
    from ramensim.recording.blueprint import view_title

    assert view_title("completion_ratio_pct") == "completion %"
    assert view_title("own_coverage_pct") == "own coverage %"
    assert view_title("artifacts_cm") == "artifacts cm" and view_title("latency_s") == "latency s"
    assert view_title("bytes_sent") == "bytes sent" and view_title("s") == "s"
    assert all(len(view_title(n)) <= 20 for n in ("completion_ratio_pct", "completion_unseen_pct",
                                                   "consensus_error_weighted", "team_coverage_pct"))
