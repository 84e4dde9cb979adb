"""The recorder writes .rrd files that say what happened: read them back and compare."""
from __future__ import annotations

import socket
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ramensim.core.events import (
    Diverged,
    FrameCaptured,
    LinkChange,
    MapSnapshot,
    MessageDelivered,
    MessageDropped,
    MessageSent,
    MetricsEvaluated,
    Notice,
    RoundCompleted,
    UncertaintySnapshot,
)
from ramensim.recording import RecordingConfig, make_recorder
from ramensim.recording import style
from ramensim.recording.readback import RecordingReader
from ramensim.recording.synthetic import _look_at, synthetic_events, synthetic_scene
from ramensim.recording.viewer import free_port, rerun_executable

K = (40.0, 40.0, 19.5, 14.5, 40, 30)
LOSSES = [3.0, 2.5, 1.75, 1.5, 1.25, 0.5]


def _rgba(c):
    r, g, b = c[:3]
    return (r << 24) | (g << 16) | (b << 8) | 255


def _frame(t, agent, index, eye):
    rgb = np.full((30, 40, 3), 0.25 * (agent + 1), np.float32)
    depth = np.full((30, 40), 1.5, np.float32)
    return FrameCaptured(t=t, agent=agent, index=index, keyframe=index % 2 == 0, rgb=rgb, depth=depth,
                         c2w=_look_at(np.asarray(eye, float), np.zeros(3)), K=K)


def scripted_events():
    """A short hand-written run of two agents with known numbers."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    f = np.array([[0, 1, 2], [0, 1, 3]], np.int64)
    c1 = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 9, 9]], np.uint8)
    c2 = c1[::-1].copy()
    ev = [Notice(t=0.0, text="run started", level="info")]
    for i in range(11):                       # 10 fps for 1 s
        t = i / 10
        ev.append(_frame(t, 0, i, [2.0, 0.2 * i, 1.0]))
        ev.append(_frame(t, 1, i, [-2.0, -0.2 * i, 1.0]))
    for r, loss in enumerate(LOSSES):          # rounds of agent 0 at 0.15 s, 0.3 s, ...
        ev.append(RoundCompleted(t=0.15 * (r + 1), agent=0, round=r, duration=0.1,
                                 scalars={"loss": loss}, copy_ages={1: None if r == 0 else 0.05 * r}))
    ev += [
        LinkChange(t=0.2, a=0, b=1, up=True, cause="range"),
        MessageSent(t=0.2, msg_id=1, src=0, dst=1, nbytes=1000, stamp=0.2),
        MessageDelivered(t=0.25, msg_id=1, src=0, dst=1, nbytes=1000, stamp=0.2, latency=0.05, age=0.05),
        MessageSent(t=0.3, msg_id=2, src=1, dst=0, nbytes=1000, stamp=0.3),
        MessageDropped(t=0.35, msg_id=2, src=1, dst=0, nbytes=1000, stamp=0.3, reason="out_of_range"),
        MapSnapshot(t=0.5, agent=0, vertices=v, faces=f, colors=c1),
        MapSnapshot(t=0.8, agent=0, vertices=v.copy(), faces=f.copy(), colors=c2),   # colours only
        UncertaintySnapshot(t=0.5, agent=1, points=v, counts=np.array([0.0, 1.0, 10.0, 100.0])),
        MetricsEvaluated(t=0.9, agent=0, metrics={"completion_ratio_pct": 42.0}),
        MetricsEvaluated(t=0.9, agent=-1, metrics={"consensus_error": 0.125}),
        Diverged(t=0.95, agent=1, round=3, reason="non-finite loss"),
        LinkChange(t=0.96, a=0, b=1, up=False, cause="window"),
    ]
    ev.sort(key=lambda e: e.t)
    return ev, (v, f, c1, c2)


def record(run_dir: Path, events, **cfg_kw) -> Path:
    cfg = RecordingConfig(**{"scalar_flush_period_s": 0.4, "max_image_rate_hz": 5.0, "image_downsample": 2,
                             "message_display_s": 0.5, "jpeg_quality": 0, **cfg_kw})
    scene = synthetic_scene(subdivisions=2)
    rec = make_recorder(cfg, run_dir, 2, scene.vertices, scene.faces, scene.colors, scene.bounds,
                        agent_names=["a0", "a1"], seed=7)
    assert rec is not None
    with rec:
        for e in events:
            rec(e)
    return run_dir / cfg.file_name


@pytest.fixture(scope="module")
def scripted(tmp_path_factory):
    events, mesh = scripted_events()
    path = record(tmp_path_factory.mktemp("rec") / "run_scripted", events, map_colors="predicted")
    return RecordingReader(path), events, mesh


def test_entities_and_timelines_exist(scripted):
    reader, _, _ = scripted
    assert reader.timelines() == ["event", "sim_time"]
    ents = set(reader.entities())
    for e in ["/world", "/world/scene", "/world/bounds", "/world/agents/a0", "/world/agents/a0/camera",
              "/world/agents/a0/camera/rgb", "/world/agents/a1/camera/depth", "/world/agents/a1/marker",
              "/world/trajectories/a0/seg_0000", "/world/maps/a0", "/world/uncertainty/a1",
              "/world/messages/a0_to_a1", "/world/messages/a1_to_a0", "/plots/round/loss/a0",
              "/plots/copy_age/a0/a1", "/plots/comm/bytes_sent/a0", "/plots/metrics/completion_ratio_pct/a0",
              "/plots/metrics/consensus_error/all", "/plots/comm/lost_by_reason/out_of_range", "/log/events"]:
        assert e in ents, e
    assert reader.blueprint_count >= 1


def test_scalar_series_equals_numbers_fed_in(scripted):
    reader, events, _ = scripted
    t, seq, vals = reader.scalars("plots/round/loss/a0")
    np.testing.assert_array_equal(vals, LOSSES)
    np.testing.assert_allclose(t, [0.15 * (r + 1) for r in range(len(LOSSES))])
    # the event timeline is the 1-based position of the event in the stream
    expect = [i + 1 for i, e in enumerate(events) if isinstance(e, RoundCompleted)]
    np.testing.assert_array_equal(seq, expect)
    t_age, _, ages = reader.scalars("plots/copy_age/a0/a1")   # round 0 left a1 out: no point
    np.testing.assert_allclose(ages, [0.05 * r for r in range(1, len(LOSSES))])
    np.testing.assert_allclose(t_age, t[1:])
    assert reader.scalars("plots/round/neighbours_used/a0")[2].tolist() == [0.0] + [1.0] * (len(LOSSES) - 1)
    assert reader.scalars("plots/metrics/consensus_error/all")[2].tolist() == [0.125]
    assert reader.scalars("plots/comm/bytes_sent/a0")[2].tolist() == [1000.0]
    assert reader.scalars("plots/comm/messages_lost/a1")[2].tolist() == [1.0]
    assert reader.scalars("plots/comm/links_up/all")[2].tolist() == [1.0, 0.0]


def test_mesh_snapshots_appear_as_given(scripted):
    reader, _, (v, f, c1, c2) = scripted
    pos = reader.rows("world/maps/a0", "Mesh3D:vertex_positions")
    tri = reader.rows("world/maps/a0", "Mesh3D:triangle_indices")
    col = reader.rows("world/maps/a0", "Mesh3D:vertex_colors")
    assert pos.sim_time.tolist() == [0.5]           # geometry logged once ...
    np.testing.assert_allclose(np.asarray(pos.values[0]), v)
    np.testing.assert_array_equal(np.asarray(tri.values[0]), f)
    assert col.sim_time.tolist() == [0.5, 0.8]      # ... colours updated in place
    assert col.values[0] == [_rgba(c) for c in c1.tolist()]
    assert col.values[1] == [_rgba(c) for c in c2.tolist()]


def test_maps_in_agent_colours_by_default(tmp_path):
    events, (v, f, c1, c2) = scripted_events()
    reader = RecordingReader(record(tmp_path / "run", events))
    comps = reader.components("world/maps/a0")
    assert "Mesh3D:vertex_colors" not in comps                      # not the predicted colours ...
    albedo = reader.rows("world/maps/a0", "Mesh3D:albedo_factor").values
    assert albedo == [[_rgba(style.agent_color(0))]]                # ... its own colour, logged once
    pos = reader.rows("world/maps/a0", "Mesh3D:vertex_positions")
    np.testing.assert_allclose(np.asarray(pos.values[0]), v)        # below the cut: the mesh as given
    # the trajectory has the same colour
    assert reader.rows("world/trajectories/a0/seg_0000", "LineStrips3D:colors").values[0] == \
        [_rgba(style.agent_color(0))]


def _heights(reader, entity):
    return np.asarray(reader.rows(entity, "Mesh3D:vertex_positions").values[0], float).reshape(-1, 3)[:, 2]


def test_scene_cut_away_without_ceiling(tmp_path):
    # the synthetic room is 3 m high: cut at 0.7 x 3 m = 2.1 m
    events, _ = scripted_events()
    reader = RecordingReader(record(tmp_path / "run", events))
    assert _heights(reader, "world/scene").max() <= 2.1 + 1e-5
    upper = _heights(reader, "world/scene/upper_walls")
    assert upper.min() >= 2.1 - 1e-5 and upper.max() == pytest.approx(3.0)
    faces = np.asarray(reader.rows("world/scene/upper_walls", "Mesh3D:triangle_indices").values[0]).reshape(-1, 3)
    verts = np.asarray(reader.rows("world/scene/upper_walls", "Mesh3D:vertex_positions").values[0]).reshape(-1, 3)
    n = np.cross(verts[faces[:, 1]] - verts[faces[:, 0]], verts[faces[:, 2]] - verts[faces[:, 0]])
    assert np.all(np.abs(n[:, 2]) < 0.5 * np.linalg.norm(n, axis=1))     # walls only: no ceiling
    alpha = reader.rows("world/scene/upper_walls", "Mesh3D:albedo_factor").values[0][0] & 0xFF
    assert alpha == round(255 * RecordingConfig().wall_opacity)
    # whole, opaque, with the ceiling, when the cut-away is off
    whole = RecordingReader(record(tmp_path / "whole", events, cutaway_fraction=None, scene_opacity=1.0))
    assert _heights(whole, "world/scene").max() == pytest.approx(3.0)
    assert "/world/scene/upper_walls" not in whole.entities()
    assert "Mesh3D:albedo_factor" not in whole.components("world/scene")


def test_recording_id_follows_the_resolved_scenario(tmp_path):
    events = synthetic_events(1, 1.0, rng=np.random.default_rng(0), image_hw=(12, 16), mesh_period_s=1.0)
    ids = {}
    for label, rate in (("a", 0.5), ("b", 0.5), ("c", 0.2)):
        run_dir = tmp_path / label / "run"
        run_dir.mkdir(parents=True)
        (run_dir / "scenario.yaml").write_text(f"name: office\nseed: 7\nchannel: {{success_rate: {rate}}}\n")
        ids[label] = RecordingReader(record(run_dir, events)).recording_id
    assert ids["a"] == ids["b"] != ids["c"]


def test_lost_messages_are_marked_lost(scripted):
    reader, _, _ = scripted
    lost = reader.rows("world/messages/a1_to_a0", "LineStrips3D:labels")
    ok = reader.rows("world/messages/a0_to_a1", "LineStrips3D:labels")
    assert lost.values[0] == ["a1→a0 lost: out_of_range"] and lost.sim_time[0] == pytest.approx(0.35)
    assert "delivered" in ok.values[0][0] and ok.sim_time[0] == pytest.approx(0.25)
    colors = reader.rows("world/messages/a1_to_a0", "LineStrips3D:colors").values
    assert colors[0] == [_rgba(style.lost_color("out_of_range"))]
    assert reader.rows("world/messages/a0_to_a1", "LineStrips3D:colors").values[0] == [_rgba(style.DELIVERED)]
    # the line disappears after message_display_s (0.5 s): an empty row at t + 0.5
    strips = reader.rows("world/messages/a1_to_a0", "LineStrips3D:strips")
    assert len(strips.values[0]) == 1 and strips.values[-1] == []
    assert strips.sim_time[-1] == pytest.approx(0.85)


def test_text_log_holds_notable_events(scripted):
    reader, _, _ = scripted
    texts = [v[0] for v in reader.rows("log/events", "TextLog:text").values]
    levels = [v[0] for v in reader.rows("log/events", "TextLog:level").values]
    assert "run started" in texts
    assert "a1 diverged in round 3: non-finite loss" in texts
    assert "link a0–a1 up (range)" in texts and "link a0–a1 down (window)" in texts
    assert "ERROR" in levels


def test_images_are_downsampled_and_rate_limited(scripted):
    reader, _, _ = scripted
    rgb = reader.rows("world/agents/a0/camera/rgb", "Image:format")
    # frames every 0.1 s for 1 s, at most 5 images/s -> t = 0, 0.2, ..., 1.0
    np.testing.assert_allclose(rgb.sim_time, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], atol=1e-9)
    fmt = rgb.values[0]
    fmt = fmt[0] if isinstance(fmt, list) else fmt
    assert (fmt["width"], fmt["height"]) == (20, 15)
    pin = reader.rows("world/agents/a0/camera", "Pinhole:resolution")
    assert len(pin.values) == 1 and np.allclose(pin.values[0], [20, 15])
    poses = reader.rows("world/agents/a0", "Transform3D:translation")
    assert len(poses.values) == 11
    np.testing.assert_allclose(np.asarray(poses.values[-1]).reshape(3), [2.0, 2.0, 1.0], atol=1e-6)


def test_depth_in_millimetres_and_jpeg_colour(tmp_path):
    events, _ = scripted_events()
    reader = RecordingReader(record(tmp_path / "run", events, jpeg_quality=80))
    comps = reader.components("world/agents/a0/camera/rgb")
    assert "EncodedImage:blob" in comps and "Image:buffer" not in comps
    media = reader.rows("world/agents/a0/camera/rgb", "EncodedImage:media_type").values[0]
    assert media == ["image/jpeg"]
    buf = reader.rows("world/agents/a1/camera/depth", "DepthImage:buffer").values[0][0]
    mm = np.frombuffer(bytes(buf), dtype=np.uint16)
    assert mm.size == 20 * 15 and np.all(mm == 1500)          # 1.5 m
    assert reader.rows("world/agents/a1/camera/depth", "DepthImage:meter").values[0] == [1000.0]


def test_uncertainty_points_coloured_by_count(scripted):
    reader, _, _ = scripted
    cols = reader.rows("world/uncertainty/a1", "Points3D:colors").values[0]
    expect = style.viridis(np.log1p([0.0, 1.0, 10.0, 100.0]) / np.log1p(100.0))
    assert cols == [_rgba(c) for c in expect.tolist()]


def test_recording_does_not_touch_events(tmp_path):
    events, _ = scripted_events()
    before = [np.array(e.rgb, copy=True) for e in events if isinstance(e, FrameCaptured)]
    record(tmp_path / "run", events)
    after = [e.rgb for e in events if isinstance(e, FrameCaptured)]
    assert all(np.array_equal(a, b) for a, b in zip(before, after))


def _compare(a: Path, b: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(rerun_executable()), "rrd", "compare", "--unordered", str(a), str(b)],
                          capture_output=True, text=True, timeout=120)


def test_two_recorders_same_events_compare_equal(tmp_path):
    events = synthetic_events(2, 3.0, rng=np.random.default_rng(3), image_hw=(24, 32), mesh_period_s=1.0)
    a = record(tmp_path / "run", events)
    b = record(tmp_path / "copy" / "run", events)      # same run name and seed, other folder
    assert RecordingReader(a).recording_id == RecordingReader(b).recording_id
    res = _compare(a, b)
    assert res.returncode == 0, res.stdout + res.stderr
    # and a recording of different events is found different
    changed = list(events)
    i = next(k for k, e in enumerate(changed) if isinstance(e, RoundCompleted))
    e = changed[i]
    changed[i] = RoundCompleted(t=e.t, agent=e.agent, round=e.round, duration=e.duration,
                                scalars={**e.scalars, "loss": e.scalars["loss"] + 1.0}, copy_ages=e.copy_ages)
    c = record(tmp_path / "other" / "run", changed)
    assert _compare(a, c).returncode != 0


def _listening_addresses(port: int) -> set[str]:
    """Local IPv4 addresses with a TCP socket listening on ``port`` (from /proc/net/tcp)."""
    out = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        local, state = line.split()[1], line.split()[3]
        ip_hex, port_hex = local.split(":")
        if int(port_hex, 16) == port and state == "0A":
            out.add(socket.inet_ntoa(bytes.fromhex(ip_hex)[::-1]))
    return out


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="needs Linux /proc/net/tcp")
def test_serve_mode_binds_localhost_only(tmp_path):
    port = free_port()
    rec = make_recorder(RecordingConfig(mode="serve", serve_port=port), tmp_path / "run", 1)
    try:
        rec(Notice(t=0.0, text="hello"))
        assert _listening_addresses(port) == {"127.0.0.1"}
    finally:
        rec.close()
    assert (tmp_path / "run" / "run.rrd").is_file()  # every mode but off also writes the file (issue 29)


def test_radio_states_of_a_shared_medium_are_a_timeline(tmp_path):
    """Issue 66: per robot when its radio transmits, defers and collides, on the sim_time timeline."""
    from ramensim.core.events import RadioState

    events = [RadioState(0.1, 0, "transmitting"), RadioState(0.1, 1, "deferring"), RadioState(0.2, 0, "idle"),
              RadioState(0.2, 1, "transmitting"), RadioState(0.3, 1, "collided"), RadioState(0.4, 1, "idle")]
    reader = RecordingReader(record(tmp_path / "run", events))
    t0, _, v0 = reader.scalars("plots/comm/radio_state/a0")
    t1, _, v1 = reader.scalars("plots/comm/radio_state/a1")
    assert v0.tolist() == [2.0, 0.0] and t0.tolist() == pytest.approx([0.1, 0.2])
    assert v1.tolist() == [1.0, 2.0, 3.0, 0.0] and t1.tolist() == pytest.approx([0.1, 0.2, 0.3, 0.4])
