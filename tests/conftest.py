"""Session-wide test settings: the runs the tests make do not enter this machine's ledger of
measured run costs (ramensim.costs), which ``ramensim sweep --dry-run`` estimates from."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


def pytest_configure(config) -> None:
    # subprocesses (CLI runs, sweep workers) inherit it
    os.environ.setdefault("RAMENSIM_RUN_COSTS", str(Path(tempfile.mkdtemp(prefix="ramensim-costs-")) / "run_costs.jsonl"))


def pytest_unconfigure(config) -> None:
    import shutil

    path = Path(os.environ.get("RAMENSIM_RUN_COSTS", ""))
    if path.parent.name.startswith("ramensim-costs-"):
        shutil.rmtree(path.parent, ignore_errors=True)
