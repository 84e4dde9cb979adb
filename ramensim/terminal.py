"""The terminal: one console for logs and live bars (stderr), one for results (stdout).

Log records and progress bars share one stderr console, so rich draws a record *above* a
live bar instead of onto its line. A stream that is not a terminal (a pipe, a file, CI) gets
plain, unwrapped lines: no styling, no hard wrap at 80 columns, so a path or a table row
survives ``grep`` and copy-paste whole.
"""
from __future__ import annotations

import sys
from typing import Any

WIDE = 200
"""Width (columns) given to tables when stdout is not a terminal: whole column titles."""

NARROW = 100
"""Below this many columns, bars and tables use their short forms (80-column terminals)."""

_stderr_console: Any = None


def is_terminal(stream: Any) -> bool:
    """Whether ``stream`` is an interactive terminal (False for pipes, files, closed streams)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def stderr_console() -> Any:
    """The process's one rich console on stderr, shared by the log handler and every progress
    bar (it looks ``sys.stderr`` up at each write, so a redirected stderr is followed)."""
    global _stderr_console
    if _stderr_console is None:
        from rich.console import Console

        _stderr_console = Console(stderr=True)
    return _stderr_console


def stdout_console() -> Any:
    """A console for results on stdout: the terminal's width on a terminal (text lines wrap
    softly, as the terminal does, never mid-path by us); elsewhere :data:`WIDE` columns, no
    colour and no wrapping."""
    from rich.console import Console

    if is_terminal(sys.stdout):
        return Console(soft_wrap=True)
    return Console(soft_wrap=True, width=WIDE, no_color=True, highlight=False)


def print_prose(console: Any, text: str) -> None:
    """A sentence of prose (a footnote, a hint) on ``console``: on a terminal wrapped at word
    boundaries to its width (a soft-wrapped line would be cut mid-word by the terminal at 80
    columns); elsewhere one unwrapped line, like every other line of a pipe."""
    console.print(text, highlight=False, soft_wrap=not console.is_terminal)


def narrow(console: Any) -> bool:
    """Whether ``console`` is narrower than :data:`NARROW` columns."""
    return int(console.width) < NARROW


def fit(text: str, width: int) -> str:
    """``text`` in at most ``width`` characters, keeping its end: ``…scene.seed=1``."""
    return text if len(text) <= width else "…" + text[len(text) - width + 1:]


def fit_point(name: str, width: int) -> str:
    """A sweep point's name (``seed=0__world.scene.seed=1__method=dinno``) in at most ``width``
    characters, every axis kept as long as possible: whole, then each key by its last part
    (``seed=0 seed=1 method=dinno``), then the values alone (``0 / 1 / dinno``), then cut."""
    if len(name) <= width:
        return name
    pairs = [part.partition("=") for part in name.split("__")]
    if not all(eq for _, eq, _ in pairs):  # not an axis=value name
        return fit(name, width)
    for text in (" ".join(f"{k.rsplit('.', 1)[-1]}={v}" for k, _, v in pairs), " / ".join(v for _, _, v in pairs)):
        if len(text) <= width:
            return text
    return fit(text, width)
