"""The Rerun recorder: an event sink (``recorder(event)``) that streams a run to Rerun.

The simulation loop calls it with every event of ``ramensim.core.events``; agents and channels
never import it. It only reads the events (arrays are copied or strided, never written),
so recording cannot change a run's results. Each run gets its own RecordingStream with a
recording id derived from the whole resolved scenario and its seed, and no wall-clock
timelines, so two recorders fed the same events write recordings with the same content,
and runs that differ in any setting never merge in the viewer.

Timelines: ``sim_time`` (duration, simulated seconds) and ``event`` (sequence number of
the event, 1-based) so that simultaneous events can be stepped through one by one.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import rerun as rr

from ramensim.core.events import (
    Diverged,
    Event,
    FrameCaptured,
    LinkChange,
    LinkQuality,
    MapSnapshot,
    MessageDelivered,
    MessageDropped,
    MessageSent,
    MetricsEvaluated,
    Notice,
    RadioState,
    RoundCompleted,
    UncertaintySnapshot,
)
from ramensim.recording import paths, style
from ramensim.recording.blueprint import default_blueprint
from ramensim.recording.config import RecordingConfig
from ramensim.recording.cutaway import MeshPart, cut_height, cutaway, up_vector
from ramensim.recording.geometry import (
    TrajectoryTrail,
    depth_to_mm,
    rgb_to_uint8,
    stride_image,
    strided_intrinsics,
    vertex_normals,
)
from ramensim.recording.lines import MessageLineBuffer
from ramensim.recording.scalars import EVENT, SIM_TIME, ScalarBuffer
from ramensim.recording.stream import open_stream, read_resolved_scenario, recording_id

log = logging.getLogger(__name__)

_LEVELS = {"info": rr.TextLogLevel.INFO, "warning": rr.TextLogLevel.WARN, "warn": rr.TextLogLevel.WARN,
           "error": rr.TextLogLevel.ERROR, "debug": rr.TextLogLevel.DEBUG}
_RUN = "all"
"""Series name of run-wide numbers (MetricsEvaluated with agent -1, drop reasons, links)."""


def _fmt(x: float) -> str:
    """A number for labels and log lines: 4 significant digits, deterministic."""
    return f"{x:.4g}"


class Recorder:
    """Streams one run's events to Rerun (see the module docstring and docs/RECORDING.md).

    Parameters: ``cfg`` the recording settings; ``run_dir`` the run folder (``run.rrd``
    goes there in save mode); ``n_agents``; the ground-truth scene mesh (``scene_vertices``
    (V, 3) m, ``scene_faces`` (F, 3), ``scene_colors`` (V, 3|4) uint8 or float in [0, 1],
    any of them None to skip); ``bounds`` (2, 3) m, min and max corners, or None;
    ``agent_names`` (default ``agent_0`` ...); ``seed`` the run's root seed; ``scenario``
    the resolved scenario as JSON-able values (default: the ``scenario.yaml`` the run wrote
    into ``run_dir``, if any). Seed, ``recording_name`` (default the run folder's name) and
    the scenario's canonical JSON fix the recording id.
    """

    def __init__(self, cfg: RecordingConfig, run_dir: Path, n_agents: int, scene_vertices: Any = None,
                 scene_faces: Any = None, scene_colors: Any = None, bounds: Any = None,
                 agent_names: Sequence[str] | None = None, seed: int = 0,
                 recording_name: str | None = None, scenario: Mapping[str, Any] | None = None) -> None:
        if cfg.mode == "off":
            raise ValueError("Recorder: recording.mode is 'off'; use make_recorder(), which returns None "
                             "for mode off, instead of building a Recorder.")
        if n_agents < 1:
            raise ValueError(f"Recorder: n_agents={n_agents}, expected at least 1 agent.")
        names = [f"agent_{i}" for i in range(n_agents)] if agent_names is None else [str(n) for n in agent_names]
        if len(names) != n_agents or len(set(names)) != n_agents:
            raise ValueError(f"Recorder: agent_names={list(names)!r} must hold {n_agents} distinct names, "
                             f"one per agent.")
        self.cfg = cfg
        self.run_dir = Path(run_dir)
        self.names = names
        self.rrd_path: Path | None = self.run_dir / cfg.file_name  # every mode writes it (live ones too)
        name = recording_name if recording_name is not None else (self.run_dir.name or "run")
        if scenario is None:
            scenario = read_resolved_scenario(self.run_dir)
        self.recording_id = recording_id(cfg.application_id, name, seed, scenario)
        self._bounds = None if bounds is None else np.asarray(bounds, dtype=np.float64).reshape(2, 3)
        self._up = up_vector(cfg.world_coordinates)
        self._cut = self._cut_height(scene_vertices)
        # the name shown in the viewer's list of recordings: runs of one scenario file with
        # different settings are told apart by the id's first digits
        shown = f"{name} seed={int(seed)} {self.recording_id[:8]}"
        self._rec = open_stream(cfg, self.rrd_path, self.recording_id, shown, self._blueprint(()))
        self._closed = False
        self._seq = 0
        self._t = 0.0
        self._wall = 0.0
        self._scalars = ScalarBuffer()
        self._groups_sent: frozenset[str] = frozenset()
        self._last_flush_t = 0.0
        self._pos: dict[int, np.ndarray] = {}
        self._last_image_t: dict[int, float] = {}
        self._pinhole_key: dict[int, tuple] = {}
        self._trails = [TrajectoryTrail(cfg.trajectory_min_step_m) for _ in range(n_agents)]
        self._mesh_prev: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._lines = MessageLineBuffer(cfg.message_display_s)
        self._faces = {"front": "Front", "back": "Back", "double_sided": "DoubleSided"}[cfg.mesh_faces]
        self._bytes_sent = [0] * n_agents
        self._sent = [0] * n_agents
        self._delivered = [0] * n_agents
        self._dropped = [0] * n_agents
        self._dropped_by_reason: dict[str, int] = {}
        self._keyframes = [0] * n_agents
        self._links_up: set[tuple[int, int]] = set()
        self._handlers = {
            FrameCaptured: self._on_frame, RoundCompleted: self._on_round, MessageSent: self._on_sent,
            MessageDelivered: self._on_delivered, MessageDropped: self._on_dropped, LinkChange: self._on_link,
            MapSnapshot: self._on_map, UncertaintySnapshot: self._on_uncertainty,
            MetricsEvaluated: self._on_metrics, Diverged: self._on_diverged, Notice: self._on_notice,
            LinkQuality: self._on_link_quality, RadioState: self._on_radio_state,
        }
        started = time.perf_counter()
        self._log_static(scene_vertices, scene_faces, scene_colors, bounds)
        self._wall += time.perf_counter() - started

    # --- public ---------------------------------------------------------------------------

    @property
    def overhead_s(self) -> float:
        """Wall-clock seconds spent inside the recorder so far (for overhead reports)."""
        return self._wall

    @property
    def events_seen(self) -> int:
        """Number of events received (the last value of the ``event`` timeline)."""
        return self._seq

    def __call__(self, event: Event) -> None:
        """Record one event at its simulated time ``event.t`` (s)."""
        if self._closed:
            raise RuntimeError("Recorder: an event arrived after close(); the simulation must close the "
                               "recorder only after its last event.")
        started = time.perf_counter()
        self._seq += 1
        t = float(event.t)
        self._t = t
        self._lines.expire(t, self._seq)
        self._set_time(t, self._seq)
        handler = self._handlers.get(type(event))
        if handler is None:
            for cls, h in self._handlers.items():
                if isinstance(event, cls):
                    handler = h
                    break
        if handler is None:
            log.debug("recorder: no handler for %s", type(event).__name__)
        else:
            handler(event)
        if (len(self._scalars) + len(self._lines) >= self.cfg.scalar_flush_rows
                or t - self._last_flush_t >= self.cfg.scalar_flush_period_s):
            self._flush_scalars()
            self._last_flush_t = t
        self._wall += time.perf_counter() - started

    def close(self) -> None:
        """Send what is buffered and the final layout; in save mode finish ``run.rrd``.
        Idempotent. In serve mode the server keeps serving until the process exits."""
        if self._closed:
            return
        started = time.perf_counter()
        self._lines.expire(math.inf, self._seq)
        self._flush_scalars()
        try:  # a live viewer that went away must not hold the run (the file sink has everything)
            self._rec.flush(timeout_sec=self.cfg.live_timeout_s if self.cfg.mode != "save" else 1e38)
        except RuntimeError as exc:
            log.warning("recording.mode %s: the live viewer did not take the end of the recording within %.0f s "
                        "(rerun says: %s); the recording is saved to %s.", self.cfg.mode, self.cfg.live_timeout_s,
                        " ".join(str(exc).split()), self.rrd_path)
        if self.cfg.mode != "serve":
            self._rec.disconnect()
        self._closed = True
        self._wall += time.perf_counter() - started
        log.info("recording closed: %d events, %.2f s in the recorder%s", self._seq, self._wall,
                 f", written to {self.rrd_path}" if self.rrd_path is not None else "")

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # --- helpers --------------------------------------------------------------------------

    def _set_time(self, t: float, seq: int) -> None:
        self._rec.set_time(SIM_TIME, duration=t)
        self._rec.set_time(EVENT, sequence=seq)

    def _scalar(self, category: str, name: str, series: str, value: float, color: tuple[int, int, int] | None = None,
                ) -> None:
        if not math.isfinite(value):
            return  # nothing to draw; NaN would also make equal recordings compare unequal
        entity = paths.plot(category, name, series)
        if self._scalars.add(entity, self._t, self._seq, value):
            kwargs: dict[str, Any] = {"names": [series]}
            if color is not None:
                kwargs["colors"] = [color]
            self._rec.log(entity, rr.SeriesLines(**kwargs), static=True)

    def _agent_scalar(self, category: str, name: str, agent: int, value: float) -> None:
        self._scalar(category, name, self._name(agent), value, self._color(agent))

    def _name(self, agent: int) -> str:
        return self.names[agent] if 0 <= agent < len(self.names) else f"agent_{agent}"

    @staticmethod
    def _color(agent: int) -> tuple[int, int, int]:
        return style.agent_color(agent)

    def _flush_scalars(self) -> None:
        self._scalars.flush(self._rec)
        self._lines.flush(self._rec)
        groups = frozenset(paths.plot_group(e) for e in self._scalars.known)
        if groups != self._groups_sent:
            self._rec.send_blueprint(self._blueprint(groups), make_active=True, make_default=True)
            self._groups_sent = groups

    def _blueprint(self, groups: Any) -> Any:
        return default_blueprint(self.names, groups, self._bounds, self.cfg.world_coordinates)

    def _cut_height(self, scene_vertices: Any) -> float | None:
        """Height (m along up) of the cut-away plane, from the scene mesh's extent along up,
        else the bounds'; None when the cut is off or there is nothing to measure."""
        frac = self.cfg.cutaway_fraction
        if frac is None:
            return None
        if scene_vertices is not None and len(scene_vertices):
            h = np.asarray(scene_vertices, dtype=np.float64).reshape(-1, 3) @ self._up
            return cut_height(float(h.min()), float(h.max()), frac)
        if self._bounds is not None:
            h = np.sort(self._bounds @ self._up)   # a y-down world turns the corners over
            return cut_height(float(h[0]), float(h[1]), frac)
        return None

    def _log_mesh(self, entity: str, part: MeshPart, color: tuple[int, int, int] | None, alpha: int,
                  static: bool = False) -> None:
        """One Mesh3D: vertex colours when ``color`` is None (else one albedo colour) and
        ``alpha`` (0-255) as the albedo's opacity; an empty part clears the entity."""
        if len(part) == 0:
            self._rec.log(entity, rr.Clear(recursive=False), static=static)
            return
        kwargs: dict[str, Any] = {"vertex_positions": part.vertices, "triangle_indices": part.faces,
                                  "vertex_normals": vertex_normals(part.vertices, part.faces),
                                  "face_rendering": self._faces}
        if color is None and part.colors is not None and len(part.colors) == len(part.vertices):
            kwargs["vertex_colors"] = part.colors
            if alpha < 255:
                kwargs["albedo_factor"] = (255, 255, 255, alpha)
        else:
            kwargs["albedo_factor"] = (*(color if color is not None else style.SCENE_GREY[:3]), alpha)
        self._rec.log(entity, rr.Mesh3D(**kwargs), static=static)

    def _split(self, v: np.ndarray, f: np.ndarray, c: np.ndarray | None) -> tuple[MeshPart, MeshPart | None]:
        """(lower, upper walls) of a mesh at the cut, or (whole, None) without a cut."""
        if self._cut is None:
            return MeshPart(np.asarray(v, np.float32), np.asarray(f, np.uint32), c), None
        return cutaway(v, f, c, self._up, self._cut)

    def _text(self, text: str, level: str) -> None:
        self._rec.log(paths.EVENTS_LOG, rr.TextLog(text, level=level))

    # --- static content -------------------------------------------------------------------

    def _log_static(self, vertices: Any, faces: Any, colors: Any, bounds: Any) -> None:
        rec = self._rec
        rec.log(paths.WORLD, getattr(rr.ViewCoordinates, self.cfg.world_coordinates), static=True)
        if self.cfg.log_scene and vertices is not None and faces is not None and len(vertices) and len(faces):
            v = np.asarray(vertices, dtype=np.float32).reshape(-1, 3)
            f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
            c = None
            if colors is not None and len(colors) == len(v):
                c = np.asarray(colors)
                c = c if c.dtype == np.uint8 else rgb_to_uint8(c)
            lower, upper = self._split(v, f, c)
            # vertex colours when the scene has them, else a plain grey (color=None -> colours)
            grey = None if c is not None else style.SCENE_GREY[:3]
            if self.cfg.scene_opacity > 0:
                self._log_mesh(paths.SCENE, lower, grey, int(round(255 * self.cfg.scene_opacity)), static=True)
            if upper is not None and len(upper) and self.cfg.wall_opacity > 0:
                self._log_mesh(paths.upper_walls(paths.SCENE), upper, grey,
                               int(round(255 * self.cfg.wall_opacity)), static=True)
        if bounds is not None:
            b = np.asarray(bounds, dtype=np.float64).reshape(2, 3)
            rec.log(paths.BOUNDS, rr.Boxes3D(mins=[b[0]], sizes=[b[1] - b[0]], colors=[(120, 120, 120)],
                                             labels=["bounds"], show_labels=False), static=True)
        for i, n in enumerate(self.names):
            rec.log(paths.agent_marker(n), rr.Points3D([[0.0, 0.0, 0.0]], colors=[self._color(i)], radii=[0.05],
                                                       labels=[n], show_labels=True), static=True)

    # --- agents ---------------------------------------------------------------------------

    def _on_frame(self, ev: FrameCaptured) -> None:
        a, n, cfg = ev.agent, self._name(ev.agent), self.cfg
        c2w = np.asarray(ev.c2w, dtype=np.float64)
        pos = c2w[:3, 3].copy()
        self._pos[a] = pos
        self._rec.log(paths.agent(n), rr.Transform3D(translation=pos, mat3x3=c2w[:3, :3]))
        if 0 <= a < len(self._trails):
            seg = self._trails[a].add(pos)
            if seg is not None:
                entity = paths.trajectory_segment(n, seg[0])
                if len(seg[1]) == 2:
                    # a new segment: its style is static, so each update carries only points
                    self._rec.log(entity, rr.LineStrips3D.from_fields(colors=[self._color(a)], radii=[0.01]),
                                  static=True)
                self._rec.log(entity, rr.LineStrips3D.from_fields(strips=[seg[1]]))
        if ev.keyframe and 0 <= a < len(self._keyframes):
            self._keyframes[a] += 1
            self._agent_scalar("round", "keyframes", a, self._keyframes[a])
        last = self._last_image_t.get(a)
        if last is not None and ev.t - last < 1.0 / cfg.max_image_rate_hz - 1e-9:
            return
        self._last_image_t[a] = ev.t
        k = cfg.image_downsample
        key = (tuple(float(x) for x in ev.K), k)
        if self._pinhole_key.get(a) != key:
            mat, (w, h) = strided_intrinsics(ev.K, k)
            self._rec.log(paths.camera(n), rr.Pinhole(image_from_camera=mat, resolution=[w, h],
                                                      camera_xyz=rr.ViewCoordinates.RDF,
                                                      image_plane_distance=cfg.image_plane_distance_m,
                                                      color=self._color(a)))
            self._pinhole_key[a] = key
        if cfg.log_rgb and ev.rgb is not None:
            image = rr.Image(rgb_to_uint8(stride_image(np.asarray(ev.rgb), k)))
            self._rec.log(paths.rgb(n), image.compress(jpeg_quality=cfg.jpeg_quality) if cfg.jpeg_quality else image)
        if cfg.log_depth and ev.depth is not None:
            self._rec.log(paths.depth(n), rr.DepthImage(depth_to_mm(stride_image(np.asarray(ev.depth), k)),
                                                        meter=1000.0))

    def _on_round(self, ev: RoundCompleted) -> None:
        a = ev.agent
        for key in sorted(ev.scalars):
            self._agent_scalar("round", key, a, float(ev.scalars[key]))
        self._agent_scalar("round", "duration_s", a, float(ev.duration))
        name = self._name(a)
        used = 0
        for nb in sorted(ev.copy_ages):
            age = ev.copy_ages[nb]
            if age is None:
                continue  # left out this round: no point (NaN would break `rrd compare` equality)
            used += 1
            self._scalar("copy_age", name, self._name(nb), float(age), self._color(nb))
        if ev.copy_ages:
            self._agent_scalar("round", "neighbours_used", a, used)

    def _on_diverged(self, ev: Diverged) -> None:
        self._text(f"{self._name(ev.agent)} diverged in round {ev.round}: {ev.reason}", rr.TextLogLevel.ERROR)

    def _on_map(self, ev: MapSnapshot) -> None:
        """A map snapshot in the agent's colour (``map_colors: agent``, default) or in the
        colours the map predicts, cut away like the scene."""
        a, n = ev.agent, self._name(ev.agent)
        entity = paths.map_mesh(n)
        v = np.asarray(ev.vertices, dtype=np.float32).reshape(-1, 3)
        f = np.asarray(ev.faces, dtype=np.uint32).reshape(-1, 3)
        if len(v) == 0 or len(f) == 0:
            self._rec.log(entity, rr.Clear(recursive=True))
            self._mesh_prev.pop(a, None)
            return
        predicted = self.cfg.map_colors == "predicted"
        c = np.asarray(ev.colors)
        colors = (c if c.dtype == np.uint8 else rgb_to_uint8(c)) if predicted and c.size else None
        if colors is not None and len(colors) != len(v):
            colors = None
        prev = self._mesh_prev.get(a)
        same = (prev is not None and prev[0].shape == v.shape and prev[1].shape == f.shape
                and np.array_equal(prev[0], v) and np.array_equal(prev[1], f))
        if same and colors is None:
            return  # nothing new to draw
        lower, upper = self._split(v, f, colors)
        alpha = int(round(255 * self.cfg.wall_opacity))
        if same:
            # Same geometry: a partial update of the colours only (Mesh3D.from_fields).
            self._rec.log(entity, rr.Mesh3D.from_fields(vertex_colors=lower.colors))
            if upper is not None and len(upper) and alpha > 0:
                self._rec.log(paths.upper_walls(entity), rr.Mesh3D.from_fields(vertex_colors=upper.colors))
            return
        color = None if colors is not None else self._color(a)
        self._log_mesh(entity, lower, color, 255)
        if upper is not None and alpha > 0:
            self._log_mesh(paths.upper_walls(entity), upper, color, alpha)
        self._mesh_prev[a] = (v.copy(), f.copy())

    def _on_uncertainty(self, ev: UncertaintySnapshot) -> None:
        pts = np.asarray(ev.points, dtype=np.float32).reshape(-1, 3)
        counts = np.asarray(ev.counts, dtype=np.float64).reshape(-1)
        if len(pts) != len(counts):
            raise ValueError(f"UncertaintySnapshot of agent {ev.agent} at t={ev.t}: {len(pts)} points but "
                             f"{len(counts)} counts; expected one count per point.")
        top = float(np.log1p(counts.max())) if len(counts) else 0.0
        norm = np.log1p(np.maximum(counts, 0.0)) / top if top > 0 else np.zeros_like(counts)
        self._rec.log(paths.uncertainty(self._name(ev.agent)),
                      rr.Points3D(pts, colors=style.viridis(norm), radii=self.cfg.uncertainty_point_radius_m))

    def _on_metrics(self, ev: MetricsEvaluated) -> None:
        for key in sorted(ev.metrics):
            value = float(ev.metrics[key])
            if ev.agent < 0:
                self._scalar("metrics", key, _RUN, value, (230, 230, 230))
            else:
                self._agent_scalar("metrics", key, ev.agent, value)

    def _on_notice(self, ev: Notice) -> None:
        who = f"{self._name(ev.agent)}: " if ev.agent is not None else ""
        self._text(who + ev.text, _LEVELS.get(ev.level.lower(), rr.TextLogLevel.INFO))

    # --- channel --------------------------------------------------------------------------

    def _on_sent(self, ev: MessageSent) -> None:
        s = ev.src
        if 0 <= s < len(self._bytes_sent):
            self._bytes_sent[s] += int(ev.nbytes)
            self._sent[s] += 1
            self._agent_scalar("comm", "bytes_sent", s, self._bytes_sent[s])
            self._agent_scalar("comm", "messages_sent", s, self._sent[s])

    def _on_delivered(self, ev: MessageDelivered) -> None:
        s = ev.src
        if 0 <= s < len(self._delivered):
            self._delivered[s] += 1
            self._agent_scalar("comm", "messages_delivered", s, self._delivered[s])
        self._agent_scalar("comm", "latency_s", ev.dst, float(ev.latency))
        self._agent_scalar("comm", "age_on_arrival_s", ev.dst, float(ev.age))
        self._message_line(ev.src, ev.dst, style.DELIVERED,
                           f"{self._name(ev.src)}→{self._name(ev.dst)} delivered, {_fmt(ev.nbytes / 1e3)} kB, "
                           f"age {_fmt(ev.age)} s")

    def _on_dropped(self, ev: MessageDropped) -> None:
        s = ev.src
        if 0 <= s < len(self._dropped):
            self._dropped[s] += 1
            self._agent_scalar("comm", "messages_lost", s, self._dropped[s])
        self._dropped_by_reason[ev.reason] = self._dropped_by_reason.get(ev.reason, 0) + 1
        self._scalar("comm", "lost_by_reason", ev.reason, self._dropped_by_reason[ev.reason],
                     style.lost_color(ev.reason))
        self._message_line(ev.src, ev.dst, style.lost_color(ev.reason),
                           f"{self._name(ev.src)}→{self._name(ev.dst)} lost: {ev.reason}")

    def _message_line(self, src: int, dst: int, color: tuple[int, int, int], label: str) -> None:
        if not self.cfg.log_messages:
            return
        p, q = self._pos.get(src), self._pos.get(dst)
        if p is None or q is None:
            return  # an agent without a pose yet has no place to draw from
        entity = paths.message(self._name(src), self._name(dst))
        if self._lines.add(entity, self._t, self._seq, p, q, color, label):
            self._rec.log(entity, rr.LineStrips3D.from_fields(radii=[0.015], show_labels=False), static=True)

    def _on_link(self, ev: LinkChange) -> None:
        key = (min(ev.a, ev.b), max(ev.a, ev.b))
        if ev.up:
            self._links_up.add(key)
        else:
            self._links_up.discard(key)
        self._scalar("comm", "links_up", _RUN, len(self._links_up), (230, 230, 230))
        self._text(f"link {self._name(key[0])}–{self._name(key[1])} {'up' if ev.up else 'down'} ({ev.cause})",
                   rr.TextLogLevel.INFO)


    def _on_radio_state(self, ev: RadioState) -> None:
        """Shared medium: per robot, its radio idle (0), deferring (1), transmitting (2) or just
        collided (3), a step on the ``comm/radio_state`` plot to scrub with the timeline."""
        self._agent_scalar("comm", "radio_state", ev.agent, RADIO_STATES.get(ev.state, math.nan))

    def _on_link_quality(self, ev: LinkQuality) -> None:
        """Radio models (channel.burst / path_loss / trace): per directed link its success
        probability, Gilbert-Elliott state (1 = bad) and walls crossed, at each change."""
        series, color = f"{self._name(ev.src)}_to_{self._name(ev.dst)}", self._color(ev.src)
        self._scalar("comm", "link_success", series, float(ev.success), color)
        if ev.state in ("good", "bad"):
            self._scalar("comm", "link_bad_state", series, 1.0 if ev.state == "bad" else 0.0, color)
        if ev.walls >= 0:
            self._scalar("comm", "link_walls", series, float(ev.walls), color)


RADIO_STATES = {"idle": 0.0, "deferring": 1.0, "transmitting": 2.0, "collided": 3.0}
"""The value a radio's state takes on the ``comm/radio_state`` timeline (shared medium)."""


def make_recorder(cfg: RecordingConfig, run_dir: Path, n_agents: int, scene_vertices: Any = None,
                  scene_faces: Any = None, scene_colors: Any = None, bounds: Any = None,
                  agent_names: Sequence[str] | None = None, seed: int = 0,
                  recording_name: str | None = None, scenario: Mapping[str, Any] | None = None,
                  ) -> Recorder | None:
    """A :class:`Recorder` for ``cfg``, or None when ``cfg.mode`` is ``off``."""
    if cfg.mode == "off":
        return None
    return Recorder(cfg, run_dir, n_agents, scene_vertices, scene_faces, scene_colors, bounds,
                    agent_names=agent_names, seed=seed, recording_name=recording_name, scenario=scenario)
