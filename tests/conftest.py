"""Session-wide test settings: the runs the tests make do not enter this machine's ledger of
measured run costs (ramensim.costs), which ``ramensim sweep --dry-run`` estimates from, and
their camera frames go to a frame cache of the session's own (ramensim.world.frame_cache),
not the user's."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


def pytest_configure(config) -> None:
    # subprocesses (CLI runs, sweep workers) inherit it
    os.environ.setdefault("RAMENSIM_RUN_COSTS", str(Path(tempfile.mkdtemp(prefix="ramensim-costs-")) / "run_costs.jsonl"))
    os.environ.setdefault("RAMENSIM_FRAME_CACHE", tempfile.mkdtemp(prefix="ramensim-frames-"))


def pytest_unconfigure(config) -> None:
    import shutil

    path = Path(os.environ.get("RAMENSIM_RUN_COSTS", ""))
    if path.parent.name.startswith("ramensim-costs-"):
        shutil.rmtree(path.parent, ignore_errors=True)
    frames = Path(os.environ.get("RAMENSIM_FRAME_CACHE", ""))
    if frames.name.startswith("ramensim-frames-"):
        shutil.rmtree(frames, ignore_errors=True)
