"""docs/API.md's examples, executed: one tiny run through ramensim.run (its typed result, the
paths of its artifacts, reading it back, comparing), and the sweep example (slow)."""
from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "API.md").read_text(), flags=re.S)


@pytest.fixture
def in_tmp(tmp_path: Path):
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        yield tmp_path
    finally:
        os.chdir(old)


def _run_blocks(blocks: list[str]) -> dict:
    ns: dict = {"__name__": "__main__"}
    for code in blocks:
        exec(compile(code, str(ROOT / "docs" / "API.md"), "exec"), ns)
    return ns


def test_api_examples_run(in_tmp: Path) -> None:
    blocks = [b for b in _blocks() if "ramensim.sweep.run(" not in b]
    assert len(blocks) >= 3
    ns = _run_blocks(blocks)
    result = ns["result"]
    import ramensim
    from ramensim.core.results import RunResult

    assert isinstance(result, RunResult) and isinstance(result, ramensim.RunOutput)
    assert result.run_dir == Path("runs/api_quick") and result.success_rate == 0.5
    assert {"scenario", "log", "metrics", "messages", "mesh:agent_0", "mesh:agent_1"} <= set(result.paths)
    assert "recording" not in result.paths  # recording.mode off
    assert set(result.per_agent) == {"agent_0", "agent_1"}
    # metrics.json is what RunResult writes: run_dir is not part of it
    assert "run_dir" not in result.to_dict()


def test_api_bad_input_is_one_paragraph(in_tmp: Path) -> None:
    import ramensim
    from ramensim.core.errors import InputError

    with pytest.raises(InputError, match="channel.success_rate"):
        ramensim.run("scenarios/office_3agents.yaml", overrides={"channel.success_rate": 7})
    with pytest.raises(InputError, match="not one string"):
        ramensim.run("scenarios/office_3agents.yaml", overrides="channel.success_rate=0.5")
    with pytest.raises(InputError, match="no metrics.json"):
        ramensim.RunOutput.load(in_tmp)
    full = in_tmp / "full"
    full.mkdir()
    (full / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match=r"out .*full: the folder is not empty \(notes.txt\).*overwrite=True"):
        ramensim.run("scenarios/office_3agents.yaml", out=full)
    assert (full / "notes.txt").read_text() == "mine"  # nothing of the user's was touched
    (full / "metrics.json").write_text('{"n_agents": "three"}')
    with pytest.raises(InputError, match=r"not a run's metrics.json \(key '\w+': Field required; .* and \d+ more\)") as err:
        ramensim.RunOutput.load(full)
    assert "\n" not in str(err.value)


@pytest.mark.slow
def test_api_sweep_example(in_tmp: Path) -> None:
    ns = _run_blocks([b for b in _blocks()])
    sw = ns["sw"]
    assert sorted(sw.ok) == sorted(sw.runs) and len(sw.runs) == 2
    assert all(p.is_file() for p in sw.tables)


@pytest.mark.slow
def test_api_sweep_example_runs_as_a_pasted_script_twice(in_tmp: Path) -> None:
    """The sweep block saved as a file and run as a user would, twice (resumed the second time)."""
    import subprocess
    import sys

    script = in_tmp / "sweep_example.py"
    script.write_text(next(b for b in _blocks() if "ramensim.sweep.run(" in b))
    for _ in range(2):
        res = subprocess.run([sys.executable, str(script)], cwd=in_tmp, capture_output=True, text=True, timeout=900)
        assert res.returncode == 0, res.stderr[-2000:]
        assert "Traceback" not in res.stderr


def test_api_run_example_runs_twice(in_tmp: Path) -> None:
    """The first block pasted twice: the second run replaces the first (overwrite=True)."""
    first = _blocks()[0]
    for _ in range(2):
        ns = _run_blocks([first])
        assert ns["result"].status == "ok"


def test_sweep_is_a_plain_package_with_run_and_the_old_call_warns(monkeypatch) -> None:
    import ramensim
    from ramensim import api

    seen = []
    monkeypatch.setattr(api, "sweep", lambda *a, **k: seen.append((a, k)) or "out")
    assert ramensim.sweep.run("f.yaml", workers=1) == "out"
    with pytest.warns(DeprecationWarning, match=r"ramensim.sweep.run"):
        assert ramensim.sweep("f.yaml", workers=1) == "out"
    assert seen == [(("f.yaml", None), {"workers": 1}), (("f.yaml",), {"workers": 1})]
