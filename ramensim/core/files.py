"""Files that are never half-written: temp file in the same folder, fsync, ``os.replace``.

Every JSON/YAML a run or a sweep writes goes through here, so a reader (a resumed sweep,
``ramensim report``, a user's script) sees either the old file or the new one, whatever
moment the writer is killed.
"""
from __future__ import annotations

import json
import math
import os
import uuid
from pathlib import Path
from typing import Any

import yaml


def fsync_dir(path: Path) -> None:
    """Flush a folder's entries (a rename inside it) to disk; silently skipped where unsupported."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temp file in the same folder, fsync, then ``os.replace``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    fsync_dir(path.parent)


def jsonable(value: Any) -> Any:
    """``value`` with dict keys as strings, tuples as lists, numpy/torch scalars and arrays as
    Python numbers and lists, paths as strings, and non-finite floats as ``None`` (NaN) or
    ``"inf"``/``"-inf"`` (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set)):
        return [jsonable(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    tolist = getattr(value, "tolist", None)
    if callable(tolist) and not isinstance(value, (str, bytes)):
        return jsonable(tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def atomic_write_json(path: Path, data: Any, sort_keys: bool = False) -> None:
    """Indented JSON (see :func:`jsonable`) written atomically; ``sort_keys`` for files compared
    byte for byte across runs."""
    atomic_write_text(path, json.dumps(jsonable(data), indent=2, sort_keys=sort_keys) + "\n")


def atomic_write_yaml(path: Path, data: Any) -> None:
    """YAML in the data's own key order, written atomically."""
    atomic_write_text(path, yaml.safe_dump(jsonable(data), sort_keys=False))


def read_json(path: Path) -> Any | None:
    """Parse a JSON file; None if it is missing or unreadable (callers treat it as 'no result')."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
