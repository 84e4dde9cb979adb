"""A failure logged with its exception (a run failing inside the event loop) shows one line on
the terminal naming the exception and where the traceback is; ``--debug`` shows the traceback.
The run's run.log keeps the traceback either way."""
from __future__ import annotations

import logging
from pathlib import Path

import pytest

from ramensim.cli import _setup_logging
from ramensim.runfolder import RunLog


@pytest.fixture
def restore_logging():
    root = logging.getLogger()
    saved = root.handlers[:], root.level
    yield
    root.handlers[:], _ = saved[0], root.setLevel(saved[1])


def _fail(log: logging.Logger) -> None:
    try:
        raise RuntimeError("the map went to NaN\nin round 7")
    except RuntimeError:
        log.exception("the run failed at t=%.2f s; evaluating what was mapped so far", 12.5)


@pytest.mark.parametrize("debug", [False, True])
def test_terminal_shows_one_line_unless_debug(tmp_path: Path, capsys, restore_logging, debug):
    _setup_logging(0, False, debug)
    with RunLog(tmp_path / "run.log"):
        _fail(logging.getLogger("ramensim.sim"))
    err = " ".join(capsys.readouterr().err.split())  # the terminal wraps long lines
    assert "the run failed at t=12.50 s" in err
    assert ("Traceback" in err) is debug
    if not debug:
        assert "RuntimeError: the map went to NaN in round 7" in err and "run.log" in err and "--debug" in err
    assert "Traceback" in (tmp_path / "run.log").read_text()  # the file keeps it
