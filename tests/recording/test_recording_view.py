"""``ramensim view RUN...``: which files it opens, the command line it builds, and what it
does without a display (no viewer window is opened: a stand-in executable records its
arguments)."""
from __future__ import annotations

import os
import stat
import sys
from pathlib import Path

import pytest

from ramensim.cli import main
from ramensim.commands import view
from ramensim.errors import InputError


def _run_dir(root: Path, name: str, file_name: str | None = None) -> Path:
    d = root / name
    d.mkdir(parents=True)
    if file_name is not None:
        (d / "scenario.yaml").write_text(f"name: x\nrecording: {{file_name: {file_name}}}\n")
    (d / (file_name or "run.rrd")).write_bytes(b"RRF2")
    return d


def test_recordings_of_folders_and_files(tmp_path):
    a = _run_dir(tmp_path, "a")
    b = _run_dir(tmp_path, "b", file_name="custom.rrd")
    got = view.recordings_of([a, b / "custom.rrd", a / "run.rrd"])          # a twice: opened once
    assert got == [(a / "run.rrd").resolve(), (b / "custom.rrd").resolve()]
    assert view.recordings_of([b]) == [(b / "custom.rrd").resolve()]         # recording.file_name


@pytest.mark.parametrize("case, words", [
    ("missing", "no such folder or file"),
    ("empty_folder", "holds no recording run.rrd"),
    ("not_rrd", "not a .rrd recording"),
])
def test_bad_runs_are_named(tmp_path, case, words):
    target = tmp_path / case
    if case == "empty_folder":
        target.mkdir()
    elif case == "not_rrd":
        target = tmp_path / "metrics.json"
        target.write_text("{}")
    with pytest.raises(InputError, match=words):
        view.recordings_of([target])


def test_cli_bad_run_is_one_paragraph_exit_2(tmp_path, capsys):
    assert main(["view", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: RUN ") and str(tmp_path / "nope") in err and err.count("\n") == 1


def test_print_command(tmp_path, capsys):
    a, b = _run_dir(tmp_path, "a"), _run_dir(tmp_path, "b")
    assert main(["view", str(a), str(b), "--print-command"]) == 0
    out = capsys.readouterr().out.split()
    assert Path(out[0]).name == "rerun" and Path(out[0]).is_file()
    assert out[1:] == [str((a / "run.rrd").resolve()), str((b / "run.rrd").resolve())]


def test_display_problem():
    assert view.display_problem({}, "linux") is not None
    assert view.display_problem({"DISPLAY": ":0"}, "linux") is None
    assert view.display_problem({"WAYLAND_DISPLAY": "wayland-0"}, "linux") is None
    assert view.display_problem({}, "darwin") is None and view.display_problem({}, "win32") is None


def test_no_display_says_so_and_exits_2(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    a = _run_dir(tmp_path, "a")
    assert main(["view", str(a)]) == 2
    err = capsys.readouterr().err
    assert "no display" in err and str((a / "run.rrd").resolve()) in err and err.count("\n") == 1


@pytest.mark.skipif(os.name != "posix", reason="the stand-in viewer is a shell script")
def test_spawns_the_viewer_with_the_files(tmp_path, monkeypatch):
    record = tmp_path / "argv.txt"
    fake = tmp_path / "rerun"
    fake.write_text(f"#!/bin/sh\nprintf '%s\\n' \"$@\" > {record}\n")
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    import ramensim.recording.viewer as viewer_mod

    monkeypatch.setattr(viewer_mod, "rerun_executable", lambda: fake)
    monkeypatch.setenv("DISPLAY", ":99")
    a, b = _run_dir(tmp_path, "a"), _run_dir(tmp_path, "b")
    assert main(["view", str(a), str(b)]) == 0
    assert record.read_text().split("\n")[:2] == [str((a / "run.rrd").resolve()), str((b / "run.rrd").resolve())]
