"""Opening one run's own ``rerun.RecordingStream`` (never the global one) on the sink the
configuration asks for, with wall-clock timelines disabled so that a recording depends
only on the simulation."""
from __future__ import annotations

import datetime
import hashlib
import json
import logging
import os
import socket
import sys
import time
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import rerun as rr
import rerun.blueprint as rrb

from ramensim.recording.config import RecordingConfig
from ramensim.recording.viewer import start_viewer, wait_for_port

log = logging.getLogger(__name__)

_NAMESPACE = uuid.UUID("1b6a0c5e-5f9e-4f43-9a51-7a2c1f0e3d88")


def canonical_json(data: Any) -> str:
    """``data`` as canonical JSON: keys sorted, no spaces, UTF-8 kept; the same settings give
    the same text whatever order the scenario file wrote them in."""
    return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)


def scenario_digest(scenario: Mapping[str, Any]) -> str:
    """sha256 (hex) of the canonical JSON of a resolved scenario (a validated config dumped
    to JSON-able values, e.g. ``Scenario.model_dump(mode="json")``)."""
    return hashlib.sha256(canonical_json(scenario).encode("utf-8")).hexdigest()


def recording_id(application_id: str, recording_name: str, seed: int,
                 scenario: Mapping[str, Any] | None = None) -> str:
    """A deterministic recording id (a UUID5 string) of the application, run name, seed and,
    when given, the whole resolved scenario (its canonical JSON's sha256): reruns of the same
    scenario and seed get the same id (and identical recordings), runs that differ in any
    setting get different ids, so the viewer never merges them."""
    key = f"{application_id}/{recording_name}/seed={int(seed)}"
    if scenario is not None:
        key += f"/scenario={scenario_digest(scenario)}"
    return str(uuid.uuid5(_NAMESPACE, key))


def read_resolved_scenario(run_dir: Path, file_name: str = "scenario.yaml") -> dict[str, Any] | None:
    """The resolved scenario a run wrote into its folder before starting (``scenario.yaml``),
    as a dict, or None when the folder has none (or it is not a YAML mapping)."""
    path = Path(run_dir) / file_name
    if not path.is_file():
        return None
    from ramensim.yamlsafe import safe_load_bounded

    try:
        data = safe_load_bounded(path.read_text(encoding="utf-8"))
    except Exception as exc:  # noqa: BLE001 - an unreadable file only weakens the id
        log.warning("%s: not read for the recording id (%s); using the run name and seed only", path, exc)
        return None
    return data if isinstance(data, dict) else None


def _live_failure(what: str, why: str, rrd_path: Path | None) -> str:
    """One paragraph: what failed, the viewer's or rerun's own words, and where the recording goes."""
    saved = f"the recording is still saved to {rrd_path}" if rrd_path is not None else "nothing is recorded"
    return (f"recording.mode {what}: {' '.join(why.split())}; the run goes on without a live viewer and "
            f"{saved} (open it later with 'rerun {rrd_path or 'run.rrd'}').")


def _reachable(url: str, timeout_s: float) -> str | None:
    """None when something accepts TCP connections at ``url``'s host and port, else why not."""
    parsed = urlparse(url.replace("rerun+", "", 1).replace("rerun://", "http://", 1))
    host, port = parsed.hostname or "127.0.0.1", parsed.port or 9876
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return None
    except OSError as exc:
        return f"nothing accepts connections at {host}:{port} ({exc.strerror or exc})"


def _display_missing() -> str | None:
    """Why a viewer window cannot open here (Linux without X11 or Wayland), else None."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display: neither DISPLAY nor WAYLAND_DISPLAY is set, so the viewer cannot open a window"
    return None


def _spawn(cfg: RecordingConfig, rrd_path: Path | None) -> str | None:
    """Start a detached viewer on 127.0.0.1:serve_port; None when it listens, else why not
    (its own last words from ``viewer.log`` beside the recording)."""
    problem = _display_missing()
    if problem is not None:
        return problem
    log_file = rrd_path.parent / "viewer.log" if rrd_path is not None else None
    proc = start_viewer(cfg.serve_port, detach=True, log_file=log_file)
    try:
        wait_for_port(cfg.serve_port, cfg.live_timeout_s, proc)
        time.sleep(0.5)  # a viewer that cannot open its window exits right after binding its port
        if proc.poll() is None:
            return None
        why = f"the rerun viewer exited with code {proc.returncode}"
    except (TimeoutError, RuntimeError) as exc:
        why = str(exc)
    if log_file is not None and log_file.is_file():
        tail = log_file.read_text(errors="replace").strip().splitlines()[-3:]
        if tail:
            why += "; it said: " + " / ".join(line.strip() for line in tail)
    return why


def open_stream(cfg: RecordingConfig, rrd_path: Path | None, rec_id: str, recording_name: str,
                blueprint: rrb.Blueprint) -> rr.RecordingStream:
    """A new RecordingStream for ``cfg.mode`` (save, spawn, connect or serve).

    save writes ``rrd_path``; spawn starts a detached viewer on 127.0.0.1:serve_port and
    streams to it; connect streams to ``cfg.url``; serve hosts a gRPC server bound to
    127.0.0.1:serve_port that viewers connect to (``rerun --connect rerun+http://127.0.0.1:PORT/proxy``).
    The live modes also write ``rrd_path`` (when given), and a viewer that cannot start
    (no display, it exits) or a URL where nothing listens is one warning paragraph, after
    which the run goes on recording to the file alone: live viewing never stops a run.
    """
    # In save mode chunks are cut by size and row count only, never by the wall-clock tick, so two
    # runs of the same scenario produce the same chunks (``rerun rrd compare --unordered`` equal).
    # Live modes keep the default low-latency batching.
    batcher = (rr.ChunkBatcherConfig(flush_tick=datetime.timedelta(days=365), flush_num_bytes=2 * 2**20,
                                     flush_num_rows=4096) if cfg.mode == "save" else None)
    rec = rr.RecordingStream(cfg.application_id, recording_id=rec_id, send_properties=False,
                             batcher_config=batcher)
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    if cfg.mode not in ("save", "spawn", "connect", "serve"):
        raise ValueError(f"open_stream: recording mode {cfg.mode!r} has no stream; expected save, spawn, "
                         f"connect or serve.")
    if rrd_path is not None:
        rrd_path.parent.mkdir(parents=True, exist_ok=True)
    if cfg.mode == "save":
        if rrd_path is None:
            raise ValueError("open_stream: save mode needs the path of the .rrd file to write.")
        rec.save(str(rrd_path), default_blueprint=blueprint)
        rec.send_recording_name(recording_name)
        return rec
    sinks: list[Any] = [rr.FileSink(str(rrd_path))] if rrd_path is not None else []
    if cfg.mode == "serve":
        sinks.append(rr.GrpcServerSink(bind_ip="127.0.0.1", port=cfg.serve_port,
                                       server_memory_limit=cfg.server_memory_limit))
        log.info("serving the recording on rerun+http://127.0.0.1:%d/proxy", cfg.serve_port)
    else:
        url = cfg.url if cfg.mode == "connect" else f"rerun+http://127.0.0.1:{cfg.serve_port}/proxy"
        problem = _spawn(cfg, rrd_path) if cfg.mode == "spawn" else _reachable(url, cfg.live_timeout_s)
        if problem is None:
            sinks.append(rr.GrpcSink(url))
        else:
            log.warning("%s", _live_failure(cfg.mode, problem, rrd_path))
    if sinks:
        rec.set_sinks(*sinks, default_blueprint=blueprint)
    rec.send_recording_name(recording_name)
    return rec
