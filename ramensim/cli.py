"""The ``ramensim`` command line.

Bad input (an :class:`~ramensim.core.errors.InputError`) is printed as one paragraph on
stderr with exit code 2 and no traceback; ``--debug`` shows tracebacks.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import sys
from typing import NoReturn, Sequence

from ramensim import __version__
from ramensim.core.errors import InputError

log = logging.getLogger("ramensim")

# Subcommand modules, in the order `ramensim --help` lists them.
COMMANDS = ("run", "validate", "schema", "world", "pretrain", "eval", "sweep", "report", "compare", "view",
            "medium", "breadth", "claims", "sensitivity", "paper", "archive", "structure", "doctor")


class _Parser(argparse.ArgumentParser):
    """argparse with a 'did you mean' for a mistyped command, choice or option (``ramensim rnu``,
    ``--seet``); subcommands' parsers are of this class too (argparse makes them of the parent's)."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        super().error(message + _suggestion(self, message))

    def format_help(self) -> str:
        """The help with the docstrings' reST markup (``code``, :mod:`x`) as plain text."""
        import re

        return re.sub(r":[a-z]+:`~?([^`]+)`", r"\1", super().format_help()).replace("``", "")


def _suggestion(parser: argparse.ArgumentParser, message: str) -> str:
    import difflib
    import re

    m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if m:
        choices = re.findall(r"'([^']*)'", m.group(2)) or [c.strip() for c in m.group(2).split(",")]
        close = difflib.get_close_matches(m.group(1), choices, n=1, cutoff=0.5)
        return f"; did you mean '{close[0]}'?" if close else ""
    m = re.search(r"unrecognized arguments: (.*)", message)
    if m:
        options = [o for a in parser._actions for o in a.option_strings]
        for sub in parser._actions:  # a subcommand's options, when the top level reports them
            if isinstance(sub, argparse._SubParsersAction):
                options += [o for p in sub.choices.values() for a in p._actions for o in a.option_strings]
        hints = []
        for word in m.group(1).split():
            if word.startswith("-"):
                close = difflib.get_close_matches(word.split("=")[0], sorted(set(options)), n=1, cutoff=0.6)
                if close:
                    hints.append(f"'{close[0]}' for '{word}'")
        return f"; did you mean {', '.join(hints)}?" if hints else ""
    return ""


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="ramensim",
        description="Discrete-event simulator of multi-robot neural implicit mapping under lossy, "
                    "delayed communication (RAMEN, DiNNO, DSGD, DSGT).")
    parser.add_argument("--version", action="version", version=f"ramensim {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv: debug)")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    parser.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module(f"ramensim.commands.{name}")
        module.add_parser(sub)
    _add_log_flags(sub)
    return parser


def _add_log_flags(sub: argparse._SubParsersAction) -> None:
    """Accept -v/-q after the subcommand too (``ramensim run X -q``), at every nesting level;
    SUPPRESS defaults leave the values given before the subcommand alone."""
    for p in sub.choices.values():
        for flags, kw in ((("-v", "--verbose"), {"action": "count", "help": "more log output (-vv: debug)"}),
                          (("-q", "--quiet"), {"action": "store_true", "help": "only warnings and errors"})):
            try:
                p.add_argument(*flags, default=argparse.SUPPRESS, **kw)
            except argparse.ArgumentError:  # the subcommand uses the flag for something else
                pass
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                _add_log_flags(action)


class _TerminalFormatter(logging.Formatter):
    """The terminal's log format: a record carrying an exception shows one line saying where
    its traceback is (the run's run.log keeps it in full) unless ``--debug``."""

    def __init__(self, fmt: str, tracebacks: bool, datefmt: str | None = None) -> None:
        super().__init__(fmt, datefmt)
        self.tracebacks = tracebacks

    def format(self, record: logging.LogRecord) -> str:
        if self.tracebacks or not record.exc_info:
            return super().format(record)
        saved = record.exc_info, record.exc_text
        record.exc_info, record.exc_text = None, None
        try:
            exc = saved[0][1] if saved[0] else None
            what = f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}" if exc is not None else "an error"
            return (f"{super().format(record)} ({what}; the traceback is in the run folder's run.log, "
                    f"or rerun with --debug)")
        finally:
            record.exc_info, record.exc_text = saved


def _setup_logging(verbose: int, quiet: bool, debug: bool = False) -> None:
    """Logs go to stderr, so that stdout carries only results (e.g. 'ramensim eval --json'). On a
    terminal, rich draws them through the console the progress bars use (a record lands above
    a live bar, not on its line); elsewhere (a pipe, a file, CI) each record is one plain,
    unwrapped line with its time and level."""
    from ramensim.terminal import is_terminal, stderr_console

    level = logging.WARNING if quiet else (logging.DEBUG if verbose > 1 else logging.INFO)
    handler: logging.Handler
    if is_terminal(sys.stderr):
        from rich.logging import RichHandler

        handler = RichHandler(console=stderr_console(), show_path=False, rich_tracebacks=False, markup=False)
        fmt, datefmt = "%(message)s", None
    else:
        handler = logging.StreamHandler(sys.stderr)
        fmt, datefmt = "%(asctime)s %(levelname)s %(message)s", "%H:%M:%S"
    handler.setFormatter(_TerminalFormatter(fmt, tracebacks=debug, datefmt=datefmt))
    handler.setLevel(level)
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(min(level, logging.INFO))  # run.log always gets INFO
    if verbose < 2:
        for noisy in ("trimesh", "matplotlib", "PIL"):
            logging.getLogger(noisy).setLevel(logging.WARNING)


def main(argv: Sequence[str] | None = None) -> int:
    from ramensim.core.native import prefer_passive_openmp

    prefer_passive_openmp()  # before any command module imports torch
    parser = build_parser()
    args = parser.parse_args(argv)
    _setup_logging(args.verbose, args.quiet, getattr(args, "debug", False))
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader of stdout went away (`ramensim schema | head`): stop quietly, as `cat` does
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 141  # 128 + SIGPIPE, what a shell reports for a command killed by a closed pipe
    except (InputError, ValueError, OSError) as exc:
        # InputError: our own one-paragraph message; ValueError with a full sentence from the
        # leaf packages; OSError: a file or folder that cannot be read or written
        if args.debug:
            raise
        print(f"error: {_paragraph(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (RecursionError, MemoryError) as exc:
        if args.debug:
            raise
        print(f"error: the input is too large or too deeply nested to process ({type(exc).__name__}); "
              f"expected smaller files or arguments.", file=sys.stderr)
        return 2


MAX_MESSAGE = 2000
"""Longest error paragraph printed (characters)."""


def _paragraph(exc: BaseException) -> str:
    """One paragraph for ``exc``: its message on one line, capped at :data:`MAX_MESSAGE`."""
    from ramensim.core.files import WriteFailed

    if isinstance(exc, WriteFailed):
        text = " ".join(str(exc.strerror or exc).split())
    elif isinstance(exc, OSError) and not isinstance(exc, InputError):
        where = f"{exc.filename}: " if exc.filename else ""
        text = f"{where}{exc.strerror or exc}; expected a readable file or a writable folder."
    else:
        text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE - 3] + "..."


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
