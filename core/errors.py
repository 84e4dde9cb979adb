"""Errors a user can fix: the CLI prints their message as one paragraph and exits 2."""
from __future__ import annotations


class InputError(ValueError):
    """Bad input (scenario, dataset, mesh, ...). The message names the file, the key or
    line, the bad value and what was expected; no traceback is shown to the user."""
