"""CLI subcommands. Each module exports ``add_parser(subparsers)`` and ``run(args) -> int``."""
from __future__ import annotations

import argparse
import logging
from typing import Callable, Sequence


def script_main(prog: str, doc: str | None, add_arguments: Callable[[argparse.ArgumentParser], None],
                run: Callable[[argparse.Namespace], int], argv: Sequence[str] | None, *,
                level: int = logging.WARNING, prefix: Callable[[argparse.Namespace], str] | None = None) -> int:
    """A command run as a stand-alone script (the thin scripts of tools/): parse ``argv`` with the
    command's own arguments, log at ``level``, and turn bad input into one logged paragraph and
    exit 2 (the CLI prints it instead). ``prefix(args)`` names the command in that paragraph
    (default: the last word of ``prog``)."""
    from ramensim.core.errors import InputError

    import sys

    ap = argparse.ArgumentParser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    args = ap.parse_args(argv)
    root = logging.getLogger()
    handler = logging.StreamHandler(sys.stderr)  # this call's stderr, removed after it (callable repeatedly)
    handler.setFormatter(logging.Formatter("%(message)s"))
    old_level, old_handlers = root.level, list(root.handlers)
    root.handlers[:] = [h for h in old_handlers if not _closed(h)] + [handler]  # a caller's may hold a closed stream
    root.setLevel(level)
    try:
        return run(args)
    except InputError as exc:
        name = prefix(args) if prefix else prog.split()[-1]
        logging.getLogger(f"ramensim.commands.{prog.split()[-1]}").error("%s: %s", name, exc)
        return 2
    finally:
        root.handlers[:] = old_handlers
        root.setLevel(old_level)


def _closed(handler: logging.Handler) -> bool:
    """Whether ``handler`` writes to a stream that is closed (a CLI call's console from before)."""
    stream = getattr(handler, "stream", None)
    if stream is None:
        console = getattr(handler, "console", None)
        stream = getattr(console, "file", None)
    return bool(getattr(stream, "closed", False))
