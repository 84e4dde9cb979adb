"""Several runs side by side in one viewer (``ramensim view RUN RUN...``).

The Rerun viewer lays out the entities of one recording at a time, so the runs' recordings
are combined into one: every chunk of run *i* is moved below the entity path ``/<label_i>``
(its ``world``, ``plots`` and ``log`` trees keep their layout underneath, see
:mod:`.paths`), and the combined file carries a layout with one column per run
(:func:`ramensim.recording.blueprint.comparison_blueprint`). All runs share the
``sim_time`` timeline, so one time cursor scrubs them together. The runs' own files are
only read. The recording id is derived from the input recordings' ids and labels, so
combining the same files again gives the same id (the viewer replaces, not duplicates).
"""
from __future__ import annotations

import logging
import re
import uuid
from pathlib import Path
from typing import Sequence

import numpy as np

from ramensim.core.errors import InputError
from ramensim.recording import paths
from ramensim.recording.blueprint import RunLayout, comparison_blueprint

log = logging.getLogger(__name__)

APPLICATION_ID = "ramensim_compare"
"""Application id of combined recordings (its own, so the viewer keeps their layout apart
from single runs')."""


def labels_for(names: Sequence[str]) -> list[str]:
    """Short, distinct labels for runs named ``names`` (folder names): characters other than
    letters, digits, ``.``, ``-`` and ``_`` become ``_``; repeats get ``_2``, ``_3``..."""
    out: list[str] = []
    for name in names:
        base = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_.") or "run"
        label, k = base, 2
        while label in out:
            label, k = f"{base}_{k}", k + 1
        out.append(label)
    return out


def _bounds_of(chunk) -> np.ndarray | None:
    """(2, 3) m corners of the ``world/bounds`` box (centre +- half size), or None."""
    batch = chunk.to_record_batch()
    names = batch.schema.names
    if "Boxes3D:centers" not in names or "Boxes3D:half_sizes" not in names:
        return None
    try:
        c = np.asarray(batch.column("Boxes3D:centers").to_pylist()[0][0], dtype=np.float64)
        h = np.asarray(batch.column("Boxes3D:half_sizes").to_pylist()[0][0], dtype=np.float64)
    except (IndexError, TypeError, ValueError):
        return None
    if c.shape != (3,) or h.shape != (3,) or not (np.isfinite(c).all() and np.isfinite(h).all()):
        return None
    return np.stack([c - h, c + h])


def _read(rrd: Path, label: str, world_coordinates: str) -> tuple[list, RunLayout, str]:
    """The chunks of ``rrd``'s recording moved below ``/<label>``, the run's layout and its
    recording id. Raises InputError for a file that is not a single-recording .rrd."""
    from rerun.chunk import RrdReader

    try:
        reader = RrdReader(rrd)
        stores = reader.recordings()
        if len(stores) != 1:
            raise InputError(f"RUN '{rrd}': holds {len(stores)} recordings; expected the one recording "
                             f"of a ramensim run.")
        chunks = reader.stream(store=stores[0]).to_chunks()
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one clear error
        raise InputError(f"RUN '{rrd}': cannot be read as a Rerun recording ({exc}); expected the run.rrd "
                         f"that 'ramensim run' wrote with recording.mode save.") from None
    root = paths.escape(label)
    layout = RunLayout(label=label, root=root, world_coordinates=world_coordinates)
    moved = []
    groups: set[str] = set()
    agents: list[str] = []
    for ch in chunks:
        ep = ch.entity_path
        if ep.startswith("/__"):  # recording properties (its name): the combined file has its own
            continue
        parts = ep.strip("/").split("/")
        if parts[0] == paths.PLOTS and len(parts) >= 3:
            groups.add("/".join(parts[:3]))
        elif parts[:2] == ["world", "agents"] and len(parts) >= 3 and parts[2] not in agents:
            agents.append(parts[2])
        elif ep == f"/{paths.BOUNDS}" and layout.bounds is None:
            layout.bounds = _bounds_of(ch)
        moved.append(ch.with_entity_path(f"/{root}{ep}" if ep != "/" else f"/{root}"))
    layout.plot_groups = sorted(groups)
    layout.agent_names = agents
    return moved, layout, stores[0].recording_id


def combine(rrds: Sequence[Path], labels: Sequence[str], out: Path,
            world_coordinates: Sequence[str] | None = None) -> Path:
    """Write ``out``: the recordings ``rrds`` side by side, run *i* below ``/<labels[i]>``,
    with the side-by-side layout. ``world_coordinates`` per run (default RIGHT_HAND_Z_UP)
    aims each column's 3-D camera. Returns ``out``."""
    import rerun as rr

    if len(rrds) != len(labels) or len(set(labels)) != len(labels):
        raise ValueError("combine: one distinct label per recording expected")
    axes = list(world_coordinates or ["RIGHT_HAND_Z_UP"] * len(rrds))
    all_chunks, layouts, ids = [], [], []
    for rrd, label, wc in zip(rrds, labels, axes):
        chunks, layout, rid = _read(Path(rrd), label, wc)
        all_chunks.extend(chunks)
        layouts.append(layout)
        ids.append(f"{label}={rid}")
    rec_id = str(uuid.uuid5(uuid.NAMESPACE_URL, "ramensim-compare:" + "|".join(ids)))
    out.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=rec_id, send_properties=False)
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    rec.save(str(out), default_blueprint=comparison_blueprint(layouts))
    rec.send_recording_name(" | ".join(labels))
    rec.send_chunks(all_chunks)
    rec.flush()
    rec.disconnect()
    log.info("combined %d recordings side by side into %s", len(rrds), out)
    return out
