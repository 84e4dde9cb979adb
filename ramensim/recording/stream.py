"""Opening one run's own ``rerun.RecordingStream`` (never the global one) on the sink the
configuration asks for, with wall-clock timelines disabled so that a recording depends
only on the simulation."""
from __future__ import annotations

import datetime
import hashlib
import json
import logging
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any

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


def open_stream(cfg: RecordingConfig, rrd_path: Path | None, rec_id: str, recording_name: str,
                blueprint: rrb.Blueprint) -> rr.RecordingStream:
    """A new RecordingStream for ``cfg.mode`` (save, spawn, connect or serve).

    save writes ``rrd_path``; spawn starts a detached viewer on 127.0.0.1:serve_port and
    streams to it; connect streams to ``cfg.url``; serve hosts a gRPC server bound to
    127.0.0.1:serve_port that viewers connect to (``rerun --connect rerun+http://127.0.0.1:PORT/proxy``).
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
    if cfg.mode == "save":
        if rrd_path is None:
            raise ValueError("open_stream: save mode needs the path of the .rrd file to write.")
        rrd_path.parent.mkdir(parents=True, exist_ok=True)
        rec.save(str(rrd_path), default_blueprint=blueprint)
    elif cfg.mode == "spawn":
        proc = start_viewer(cfg.serve_port, detach=True)
        wait_for_port(cfg.serve_port, 60.0, proc)
        rec.connect_grpc(f"rerun+http://127.0.0.1:{cfg.serve_port}/proxy", default_blueprint=blueprint)
    elif cfg.mode == "connect":
        rec.connect_grpc(cfg.url, default_blueprint=blueprint)
    elif cfg.mode == "serve":
        rec.set_sinks(rr.GrpcServerSink(bind_ip="127.0.0.1", port=cfg.serve_port,
                                        server_memory_limit=cfg.server_memory_limit),
                      default_blueprint=blueprint)
        log.info("serving the recording on rerun+http://127.0.0.1:%d/proxy", cfg.serve_port)
    else:
        raise ValueError(f"open_stream: recording mode {cfg.mode!r} has no stream; expected save, spawn, "
                         f"connect or serve.")
    rec.send_recording_name(recording_name)
    return rec
