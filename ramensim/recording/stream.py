"""Opening one run's own ``rerun.RecordingStream`` (never the global one) on the sink the
configuration asks for, with wall-clock timelines disabled so that a recording depends
only on the simulation."""
from __future__ import annotations

import datetime

import logging
import uuid
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from ramensim.recording.config import RecordingConfig
from ramensim.recording.viewer import start_viewer, wait_for_port

log = logging.getLogger(__name__)

_NAMESPACE = uuid.UUID("1b6a0c5e-5f9e-4f43-9a51-7a2c1f0e3d88")


def recording_id(application_id: str, recording_name: str, seed: int) -> str:
    """A deterministic recording id (a UUID5 string) for a run name and seed, so that the
    same run gives the same id and different runs opened together stay apart."""
    return str(uuid.uuid5(_NAMESPACE, f"{application_id}/{recording_name}/seed={int(seed)}"))


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
