"""The run folder: its name and the per-run log file (atomic writes: :mod:`ramensim.core.files`)."""
from __future__ import annotations

import logging
import re
import time
from pathlib import Path


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
