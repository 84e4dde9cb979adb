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
from ramensim.core.errors import InputError


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
    ("garbage_rrd", "is not a Rerun recording"),
])
def test_bad_runs_are_named(tmp_path, case, words):
    target = tmp_path / case
    if case == "empty_folder":
        target.mkdir()
    elif case == "not_rrd":
        target = tmp_path / "metrics.json"
        target.write_text("{}")
    elif case == "garbage_rrd":
        target = tmp_path / "x.rrd"
        target.write_text("hello")
    with pytest.raises(InputError, match=words):
        view.recordings_of([target])


def test_cli_bad_run_is_one_paragraph_exit_2(tmp_path, capsys):
    assert main(["view", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: RUN ") and str(tmp_path / "nope") in err and err.count("\n") == 1


def test_print_command(tmp_path, capsys):
    a, b = _run_dir(tmp_path, "a"), _run_dir(tmp_path, "b")
    assert main(["view", str(a), str(b), "--separate", "--print-command"]) == 0
    out = capsys.readouterr().out.split()
    assert Path(out[0]).name == "rerun" and Path(out[0]).is_file()
    assert out[1:] == [str((a / "run.rrd").resolve()), str((b / "run.rrd").resolve())]


def test_print_command_side_by_side_needs_out_and_leaves_no_temporary_file(tmp_path, capsys, monkeypatch):
    """--print-command used to leave the combined recording (21 MB for two default runs) in a
    temporary folder nothing removed; a failed combine left the folder behind (issue 29)."""
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    a, b = _run_dir(tmp_path, "a"), _run_dir(tmp_path, "b")  # run.rrd files that are magic bytes only
    assert main(["view", str(a), str(b), "--print-command"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --print-command") and "--out FILE.rrd" in err and err.count("\n") == 1
    monkeypatch.setattr(view, "display_problem", lambda: None)
    assert main(["view", str(a), str(b)]) == 2  # combining fails: one paragraph, and the temporary folder goes
    assert list((tmp_path / "tmp").iterdir()) == []


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


def _fake_viewer(tmp_path: Path, monkeypatch, extra: str = "") -> Path:
    """A stand-in ``rerun`` (a shell script that writes its arguments to the returned file,
    then runs ``extra``) and a display, so ``view`` starts it instead of the real viewer."""
    record = tmp_path / "argv.txt"
    fake = tmp_path / "rerun"
    fake.write_text(f"#!/bin/sh\nprintf '%s\\n' \"$@\" > {record}\n{extra}")
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    import ramensim.recording.viewer as viewer_mod

    monkeypatch.setattr(viewer_mod, "rerun_executable", lambda: fake)
    monkeypatch.setenv("DISPLAY", ":99")
    return record


@pytest.mark.skipif(os.name != "posix", reason="the stand-in viewer is a shell script")
def test_spawns_the_viewer_with_the_files(tmp_path, monkeypatch):
    record = _fake_viewer(tmp_path, monkeypatch)
    a, b = _run_dir(tmp_path, "a"), _run_dir(tmp_path, "b")
    assert main(["view", str(a), str(b), "--separate"]) == 0
    assert record.read_text().split("\n")[:2] == [str((a / "run.rrd").resolve()), str((b / "run.rrd").resolve())]


def _real_run(root: Path, name: str, seed: int) -> Path:
    """A run folder holding a real (small, synthetic) recording of 2 agents over 4 s."""
    import numpy as np

    from ramensim.recording import RecordingConfig, make_recorder
    from ramensim.recording.synthetic import synthetic_events, synthetic_scene

    scene = synthetic_scene(subdivisions=3)
    d = root / name
    rec = make_recorder(RecordingConfig(), d, 2, scene.vertices, scene.faces, scene.colors, scene.bounds, seed=seed)
    with rec:
        for e in synthetic_events(2, 4.0, rng=np.random.default_rng(seed), image_hw=(12, 16), mesh_period_s=2.0,
                                  scene=scene):
            rec(e)
    return d


def _entities(rrd: Path) -> tuple[list[str], int, str]:
    from rerun.chunk import RrdReader

    reader = RrdReader(rrd)
    (store,) = reader.recordings()
    paths = [c.entity_path for c in reader.stream(store=store).to_chunks()]
    return paths, len(reader.blueprints()), store.recording_id


@pytest.mark.skipif(os.name != "posix", reason="the stand-in viewer is a shell script")
def test_several_runs_open_side_by_side_in_one_recording(tmp_path, monkeypatch, capsys):
    record = _fake_viewer(tmp_path, monkeypatch, extra=f"cp \"$1\" {tmp_path}/seen.rrd\n")
    a, b = _real_run(tmp_path, "success 0.5", 1), _real_run(tmp_path, "success_0.2", 2)
    assert main(["view", str(a), str(b)]) == 0
    assert "2 runs side by side" in capsys.readouterr().out
    opened = record.read_text().split("\n")
    assert len([x for x in opened if x]) == 1 and opened[0].endswith("side_by_side.rrd")
    assert not Path(opened[0]).exists()                       # the temporary file is removed afterwards
    paths, n_blueprints, _ = _entities(tmp_path / "seen.rrd")
    own_a, own_b = _entities(a / "run.rrd")[0], _entities(b / "run.rrd")[0]
    assert n_blueprints == 1                                   # the side-by-side layout travels in the file
    assert sorted(p for p in paths if not p.startswith("/__")) == sorted([f"/success_0.5{p}" for p in own_a if not p.startswith("/__")]
                                   + [f"/success_0.2{p}" for p in own_b if not p.startswith("/__")])
    assert any(p.startswith("/success_0.5/world/maps/") for p in paths)


def test_side_by_side_file_is_kept_with_out_and_deterministic(tmp_path, capsys):
    a, b = _real_run(tmp_path, "a", 1), _real_run(tmp_path, "a2", 2)
    out = tmp_path / "cmp" / "both.rrd"
    assert main(["view", str(a), str(b), "--out", str(out), "--print-command"]) == 0
    assert capsys.readouterr().out.split()[1:] == [str(out)]
    first = _entities(out)
    assert main(["view", str(a), str(b), "--out", str(out), "--print-command"]) == 0
    assert _entities(out)[2] == first[2]                       # same inputs: same recording id
    assert main(["view", str(b), str(a), "--out", str(out), "--print-command"]) == 0
    assert _entities(out)[2] != first[2]
    assert main(["view", str(a), str(b), "--out", str(tmp_path / "x.png"), "--print-command"]) == 2
    assert main(["view", str(a), "--out", str(out), "--print-command"]) == 2
    assert "--out" in capsys.readouterr().err


def test_side_by_side_of_a_file_that_is_no_recording_is_one_paragraph(tmp_path, capsys):
    a, b = _real_run(tmp_path, "a", 1), _run_dir(tmp_path, "b")  # b's run.rrd is the magic bytes only
    assert main(["view", str(a), str(b), "--out", str(tmp_path / "both.rrd"), "--print-command"]) == 2
    err = capsys.readouterr().err
    err = err[err.index("error: "):]                           # after the recorder's log of making run a
    assert err.startswith("error: RUN ") and "cannot be read as a Rerun recording" in err and err.count("\n") == 1


def test_labels_are_distinct_and_path_safe():
    from ramensim.recording.combine import labels_for

    assert labels_for(["run a", "run a", "x/y", "", "ok-1_2", "s 0.5"]) == [
        "run_a", "run_a_2", "x_y", "run", "ok-1_2", "s_0.5"]
