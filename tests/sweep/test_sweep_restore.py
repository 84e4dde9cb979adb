"""``ramensim archive --restore`` (``ramensim.sweep.archive.restore``): the archived runs go back into
the sweep folders, so that a sweep on a fresh machine counts them done and runs only the rest; a run
already in the sweep folder is never touched."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ramensim.sweep.runner import run_sweep
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import fake_run, validate_dict


class _Archive:
    """``main(argv)`` is ``ramensim archive ARGV`` as a script (``tools/archive_sweep.py``)."""

    @staticmethod
    def main(argv: list[str]) -> int:
        from ramensim.commands.archive import main

        return main(argv)


class _Restore:
    """``main(argv)`` is ``ramensim archive --restore ARGV`` as a script (``tools/restore_archives.py``);
    ``restore`` is the package's."""

    @staticmethod
    def main(argv: list[str]) -> int:
        from ramensim.commands.archive import main

        return main(["--restore", *argv])

    @staticmethod
    def restore(archives: Path, sweeps: Path) -> dict[str, int]:
        from ramensim.sweep.archive import restore

        return restore(archives, sweeps)


@pytest.fixture()
def tools():
    return _Archive, _Restore


def _plan(tmp_path: Path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen", "agents": {"count": 2}}))
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump({"name": "paper_x", "base": "base.yaml",
                                    "axes": {"method": ["ramen", "dinno"], "seed": [0, 1]}}, sort_keys=False))
    return plan_sweep(path, validate_fn=validate_dict)


def test_archived_runs_resume_a_sweep_on_a_fresh_machine(tmp_path, tools):
    archive_sweep, restore_archives = tools
    plan = _plan(tmp_path)
    first = tmp_path / "machine1" / "runs" / "sweeps" / "paper_x"
    run_sweep(plan, first, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    archives = tmp_path / "repo" / "docs" / "results"
    assert archive_sweep.main([str(first), str(archives / "paper" / "paper_x")]) == 0

    sweeps = tmp_path / "machine2" / "runs" / "sweeps"
    assert restore_archives.main([str(archives), str(sweeps)]) == 0
    restored = sorted(p.name for p in (sweeps / "paper_x" / "runs").iterdir())
    assert restored == sorted(p.name for p in plan.points)
    assert not any(n.startswith(".") for n in restored)  # no temporary folder left behind
    calls: list[str] = []

    def counting(scenario, out_dir):
        calls.append(str(out_dir))
        return fake_run(scenario, out_dir)

    run_sweep(plan, sweeps / "paper_x", workers=1, run_fn=counting, validate_fn=validate_dict, progress=False)
    assert calls == []  # every point counted done


def test_a_run_already_in_the_sweep_folder_is_never_touched(tmp_path, tools):
    archive_sweep, restore_archives = tools
    plan = _plan(tmp_path)
    first = tmp_path / "m1"
    run_sweep(plan, first, workers=1, run_fn=fake_run, validate_fn=validate_dict, progress=False)
    archives = tmp_path / "results"
    archive_sweep.main([str(first), str(archives / "paper" / "paper_x")])
    sweeps = tmp_path / "sweeps"
    mine = sweeps / "paper_x" / "runs" / plan.points[0].name
    mine.mkdir(parents=True)
    (mine / "metrics.json").write_text(json.dumps({"local": True}))
    assert restore_archives.restore(archives, sweeps) == {"paper_x": len(plan.points) - 1}
    assert json.loads((mine / "metrics.json").read_text()) == {"local": True}
    assert restore_archives.restore(archives, sweeps) == {}  # again: nothing left to restore


def test_a_missing_archives_folder_is_one_clear_error(tmp_path, tools, caplog):
    _, restore_archives = tools
    assert restore_archives.main([str(tmp_path / "nope"), str(tmp_path / "s")]) == 2
    assert "is not a folder" in caplog.text


@pytest.mark.parametrize("script, argv, said", [
    ("archive_sweep.py", ["{tmp}/nope", "{tmp}/dest"], "has no runs/ folder"),
    ("restore_archives.py", ["{tmp}/nope", "{tmp}/sweeps"], "is not a folder"),
    ("adopt_runs.py", ["{tmp}/nope", "--plan", "{tmp}/plan.yaml", "--into", "{tmp}/into"], "plan.yaml"),
])
def test_the_command_and_the_tools_scripts_name_bad_input_in_one_paragraph(tmp_path, capsys, script, argv, said):
    """``ramensim archive`` (through the CLI: "error: ...", exit 2, no traceback) and the old commands
    the pages and tools/paper_queue.sh print, ``python tools/<script>``, which call the same code."""
    import subprocess
    import sys

    from ramensim.cli import main as cli

    args = [a.format(tmp=tmp_path) for a in argv]
    mode = {"restore_archives.py": ["--restore"], "adopt_runs.py": ["--adopt"]}.get(script, [])
    assert cli(["archive", *mode, *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and said in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve().parents[2] / "tools" / script), *args],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and said in proc.stderr and "Traceback" not in proc.stderr
