"""Reading a ramensim ``.rrd`` back (``rerun.chunk.RrdReader``): which entities and
timelines it holds, and the rows logged on an entity. Used by tests and by anyone who
wants numbers out of a recording without the viewer."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

_CONTROL = "rerun.controls.RowId"


@dataclass(frozen=True)
class Rows:
    """Rows of one entity and one component, sorted by (sim_time, event): ``sim_time``
    (s, NaN for static rows), ``event`` (sequence, -1 for static rows), ``values`` (one
    Python object per row: the component's list of instances)."""

    sim_time: np.ndarray
    event: np.ndarray
    values: list[Any]


class RecordingReader:
    """All chunks of the (first) recording store of an ``.rrd`` file, in memory."""

    def __init__(self, path: str | Path) -> None:
        from rerun.chunk import RrdReader

        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"{p}: no such recording; expected a .rrd file written by ramensim.")
        reader = RrdReader(p)
        stores = reader.recordings()
        if not stores:
            raise ValueError(f"{p}: holds no recording store; expected a ramensim recording.")
        self.path = p
        self.store = stores[0]
        self.blueprint_count = len(reader.blueprints())
        self._batches: dict[str, list[pa.RecordBatch]] = {}
        self._timelines: set[str] = set()
        for chunk in reader.stream(store=stores[0]):
            self._timelines.update(chunk.timeline_names)
            self._batches.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())

    @property
    def recording_id(self) -> str:
        return str(self.store.recording_id)

    def entities(self) -> list[str]:
        """Entity paths with data, sorted (leading '/')."""
        return sorted(self._batches)

    def timelines(self) -> list[str]:
        """Names of the timelines any chunk is indexed by, sorted."""
        return sorted(self._timelines)

    def components(self, entity: str) -> list[str]:
        """Component columns (e.g. 'Scalars:scalars') logged on ``entity``."""
        names: set[str] = set()
        for b in self._batches.get(_norm(entity), []):
            names.update(n for n in b.schema.names if ":" in n)
        return sorted(names)

    def rows(self, entity: str, component: str) -> Rows:
        """Every row of ``component`` on ``entity`` (nulls skipped), sorted by time."""
        ts: list[float] = []
        seqs: list[int] = []
        vals: list[Any] = []
        for b in self._batches.get(_norm(entity), []):
            if component not in b.schema.names:
                continue
            col = b.column(component).to_pylist()
            n = b.num_rows
            t = _duration_s(b.column("sim_time")) if "sim_time" in b.schema.names else np.full(n, np.nan)
            e = (np.asarray(b.column("event").cast(pa.int64()).to_pylist(), dtype=np.int64)
                 if "event" in b.schema.names else np.full(n, -1, dtype=np.int64))
            for i in range(n):
                if col[i] is None:
                    continue
                ts.append(float(t[i]))
                seqs.append(int(e[i]))
                vals.append(col[i])
        order = sorted(range(len(vals)), key=lambda i: (np.nan_to_num(ts[i], nan=-np.inf), seqs[i]))
        return Rows(np.asarray([ts[i] for i in order], dtype=np.float64),
                    np.asarray([seqs[i] for i in order], dtype=np.int64), [vals[i] for i in order])

    def scalars(self, entity: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A scalar series: (sim_time s, event numbers, values) sorted by time."""
        r = self.rows(entity, "Scalars:scalars")
        vals = np.asarray([v[0] if isinstance(v, list) else v for v in r.values], dtype=np.float64)
        return r.sim_time, r.event, vals


def _norm(entity: str) -> str:
    return entity if entity.startswith("/") else "/" + entity


def _duration_s(col: pa.Array) -> np.ndarray:
    ns = col.cast(pa.int64()).to_numpy(zero_copy_only=False)
    return np.asarray(ns, dtype=np.float64) / 1e9
