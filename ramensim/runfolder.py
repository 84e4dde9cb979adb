"""The run folder: its name, atomic writes, and the per-run log file."""
from __future__ import annotations

import json
import logging
import math
import re
import time
from pathlib import Path
from typing import Any

import yaml


def new_run_dir(parent: str | Path, name: str, seed: int) -> Path:
    """``parent/<name>_seed<seed>_<YYYYmmdd-HHMMSS>`` (suffixed if it exists)."""
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "-", name).strip("-") or "run"
    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = Path(parent) / f"{safe}_seed{seed}_{stamp}"
    path, k = base, 1
    while path.exists():
        k += 1
        path = base.with_name(f"{base.name}-{k}")
    return path


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "item") and callable(value.item) and getattr(value, "ndim", 1) == 0:
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` (never half-written: see ``ramensim.sweep.store``)."""
    from ramensim.sweep.store import atomic_write_text

    atomic_write_text(path, text)


def write_json(path: Path, data: Any) -> None:
    """Atomic, deterministic JSON (sorted keys; NaN written as null)."""
    write_atomic(path, json.dumps(_jsonable(data), indent=2, sort_keys=True) + "\n")


def write_yaml(path: Path, data: Any) -> None:
    write_atomic(path, yaml.safe_dump(_jsonable(data), sort_keys=False))


class RunLog:
    """Attach a file handler writing ``run.log`` in the run folder for the run's duration."""

    def __init__(self, path: Path) -> None:
        self.handler = logging.FileHandler(path, encoding="utf-8")
        self.handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        self.handler.setLevel(logging.INFO)

    def __enter__(self) -> "RunLog":
        root = logging.getLogger()
        root.addHandler(self.handler)
        if root.level > logging.INFO or root.level == logging.NOTSET:
            self._old = root.level
            root.setLevel(logging.INFO)
        else:
            self._old = None
        return self

    def __exit__(self, *exc: object) -> None:
        root = logging.getLogger()
        root.removeHandler(self.handler)
        self.handler.close()
        if self._old is not None:
            root.setLevel(self._old)
