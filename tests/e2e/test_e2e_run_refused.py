"""A run refused before it starts leaves nothing behind and the same command works again; a
finished run folder carries no lock file (issue 29, item 4)."""
from __future__ import annotations

from pathlib import Path

import pytest

from ramensim import memory
from ramensim.cli import main
from ramensim.runfolder import LOCK, RunLock

ROOT = Path(__file__).resolve().parents[2]
SMALL = ["--set", "agents.count=2", "--set", "duration=1", "--set", "world.camera.width=40", "--set",
         "world.camera.height=30", "--set", "world.camera.fx=30", "--set", "world.camera.fy=30", "--set",
         "world.camera.cx=19.5", "--set", "world.camera.cy=14.5", "--set", "evaluation.voxel_m=0.1", "--set",
         "evaluation.n_samples=2000", "--set", "evaluation.cull=frustum", "--set", "map.n_rays=64",
         "--set", "recording.mode=off", "-q"]


def test_refused_run_leaves_nothing_and_can_be_rerun(tmp_path, monkeypatch, capsys):
    out = tmp_path / "run"
    monkeypatch.setattr(memory, "available_bytes", lambda: 1 << 20)  # 1 MiB: every run is refused
    rc = main(["run", str(ROOT / "scenarios" / "office_3agents.yaml"), "--out", str(out), *SMALL])
    assert rc != 0 and "needs about" in capsys.readouterr().err
    assert not out.exists()
    # into an existing folder of the user's: only the run's own files go
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    rc = main(["run", str(ROOT / "scenarios" / "office_3agents.yaml"), "--out", str(out), *SMALL])
    assert rc != 0 and sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    monkeypatch.undo()
    (out / "notes.txt").unlink()
    rc = main(["run", str(ROOT / "scenarios" / "office_3agents.yaml"), "--out", str(out), *SMALL])
    assert rc == 0 and (out / "metrics.json").is_file() and not (out / LOCK).exists()


def test_lock_file_is_removed_and_a_held_lock_still_refuses(tmp_path):
    from ramensim.core.errors import InputError

    with RunLock(tmp_path):
        assert (tmp_path / LOCK).is_file()
        with pytest.raises(InputError, match="another run"):
            with RunLock(tmp_path):
                pass
    assert not (tmp_path / LOCK).exists()
    with RunLock(tmp_path):  # and it can be taken again
        pass
