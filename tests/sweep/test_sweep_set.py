"""``ramensim sweep FILE --set KEY=V`` (and ``ramensim.sweep.run(..., overrides=)``): a key fixed
for every point after the file's ``set``, in a folder of its own by default so that a shortened
sweep never makes the full sweep's results stale (issue 57)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ramensim.core.errors import InputError
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import validate_dict


def _sweep(tmp_path: Path) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "local", "duration": 60}))
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump({"name": "exp", "base": "base.yaml", "set": {"duration": 30, "agents.count": 2},
                                    "axes": {"seed": [0, 1]}}, sort_keys=False))
    return path


def test_set_applies_to_every_point_after_the_files_set(tmp_path):
    path = _sweep(tmp_path)
    full = plan_sweep(path, validate_fn=validate_dict)
    short = plan_sweep(path, validate_fn=validate_dict, overrides=["duration=5", "channel.success_rate=0.5"])
    assert [p.data["duration"] for p in full.points] == [30, 30]
    assert [p.data["duration"] for p in short.points] == [5, 5]  # the file's 'set' said 30
    assert all(p.data["channel"]["success_rate"] == 0.5 and p.data["agents"]["count"] == 2 for p in short.points)
    assert [p.name for p in short.points] == [p.name for p in full.points]  # the same points...
    assert not {p.fingerprint for p in short.points} & {p.fingerprint for p in full.points}  # ...other runs
    assert short.fixed == {"duration": 5, "agents.count": 2, "channel.success_rate": 0.5}
    assert short.to_json()["overrides"] == {"duration": 5, "channel.success_rate": 0.5}
    assert full.folder_name == "exp" and short.folder_name == "exp__duration=5__channel.success_rate=0.5"
    assert plan_sweep(path, validate_fn=validate_dict, overrides={"duration": 5}).points[0].data["duration"] == 5


def test_set_of_a_swept_key_or_a_bad_form_is_one_paragraph(tmp_path):
    path = _sweep(tmp_path)
    with pytest.raises(InputError, match=r"'seed' is an axis of this sweep \(values 0, 1\).*--only seed=V"):
        plan_sweep(path, validate_fn=validate_dict, overrides=["seed=3"])
    with pytest.raises(InputError, match="expected the form dotted.key=value"):
        plan_sweep(path, validate_fn=validate_dict, overrides=["duration"])


def test_cli_set_reaches_every_point_and_its_own_folder(tmp_path, capsys, monkeypatch):
    from ramensim.cli import main

    path = _sweep(tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", str(path), "--set", "duration=2", "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "runs/sweeps/exp__duration=2" in out.replace("\n", "") and "2 to run" in out
    # a bad value names the key and the --set
    assert main(["sweep", str(path), "--set", "duration=-4", "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert "key 'duration' (--set)" in err and "Traceback" not in err
    assert main(["sweep", str(path), "--set", "seed=4", "--dry-run"]) == 2
    assert "is an axis of this sweep" in capsys.readouterr().err


def test_api_sweep_passes_overrides_to_the_plan_and_the_folder(tmp_path, monkeypatch):
    """ramensim.sweep.run(FILE, overrides=...) plans with them; the runner (replaced here) gets
    points with the key set and the folder named after it."""
    import ramensim.sweep.runner as runner
    from ramensim.api import sweep

    path = _sweep(tmp_path)
    monkeypatch.chdir(tmp_path)
    seen = {}

    def fake_run_sweep(plan, folder, **kwargs):
        seen["plan"], seen["folder"] = plan, Path(folder)
        return runner.SweepOutcome(Path(folder), len(plan.points))

    monkeypatch.setattr(runner, "run_sweep", fake_run_sweep)
    sweep(path, overrides={"duration": 3}, report=False)
    assert [p.data["duration"] for p in seen["plan"].points] == [3, 3]
    assert seen["folder"] == Path("runs/sweeps/exp__duration=3")
    assert json.loads(json.dumps(seen["plan"].to_json()))["overrides"] == {"duration": 3}
