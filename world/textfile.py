"""Reading the small text files of trajectories and datasets, line by line."""
from __future__ import annotations

from pathlib import Path
from typing import Iterator

from ramensim.core.errors import InputError


def content_lines(path: Path, what: str) -> Iterator[tuple[int, str]]:
    """``(1-based line number, stripped text)`` of every line that is neither blank nor a
    ``#`` comment; an unreadable file is an InputError saying it should hold ``what``."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot be read ({exc}); expected {what}.") from None
    for no, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if s and not s.startswith("#"):
            yield no, s
