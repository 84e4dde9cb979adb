"""docs/EXTENDING.md runs as written, from a temporary folder outside the package: its file
blocks are written there (and must equal examples/), its scenario is shortened to a tiny run
(tests/e2e/tiny_runs.py's settings, 4 simulated seconds), then every `$ ramensim ...` command
and the Python block run unchanged: the plugin method, radio model and scene through
`ramensim run`, `ramensim sweep --workers 2` and the Python API."""
from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import yaml

from tests.e2e.tiny_runs import TINY

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "EXTENDING.md"
_BLOCK = re.compile(r"<!-- (file: (?P<file>[\w.]+)|test: (?P<test>run|python)) -->\n```\w*\n(?P<body>.*?)```", re.S)


def _blocks() -> tuple[dict[str, str], list[str], list[str]]:
    files, commands, scripts = {}, [], []
    for m in _BLOCK.finditer(DOC.read_text()):
        if m["file"]:
            files[m["file"]] = m["body"]
        elif m["test"] == "run":
            commands += [line[2:] for line in m["body"].splitlines() if line.startswith("$ ")]
        else:
            scripts.append(m["body"])
    return files, commands, scripts


def test_doc_blocks_are_the_shipped_examples():
    files, commands, scripts = _blocks()
    assert set(files) == {"gossip_avg.py", "distance_loss_radio.py", "my_scene.py", "gossip_two_rooms.yaml",
                          "gossip_vs_ramen.yaml", "stale_gossip.py"}
    for name, body in files.items():
        assert body == (REPO / "examples" / name).read_text(), f"docs/EXTENDING.md's {name} differs from examples/"
    assert any(c.startswith("ramensim sweep ") and "--workers 2" in c for c in commands)
    assert any(c.startswith("ramensim run ") for c in commands) and len(scripts) == 1
    assert "EXTENDING.md" in (REPO / "README.md").read_text()


def _shorten(path: Path) -> None:
    from ramensim.config import apply_overrides

    data = yaml.safe_load(path.read_text())
    tiny = dict(t.split("=", 1) for t in TINY)
    tiny.pop("agents.count")  # the tutorial's own team (2)
    data = apply_overrides(data, {**{k: yaml.safe_load(v) for k, v in tiny.items()}, "duration": 4})
    path.write_text(yaml.safe_dump(dict(data), sort_keys=False))


def test_the_tutorial_runs_as_written(tmp_path):
    files, commands, scripts = _blocks()
    folder = tmp_path / "my_study"
    folder.mkdir()
    for name, body in files.items():
        (folder / name).write_text(body)
    _shorten(folder / "gossip_two_rooms.yaml")
    for command in commands:
        argv = shlex.split(command)
        assert argv[0] == "ramensim"
        proc = subprocess.run([sys.executable, "-m", "ramensim", *argv[1:]], cwd=folder, capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, f"$ {command}\n{proc.stdout}\n{proc.stderr[-3000:]}"
        assert "Traceback" not in proc.stderr
    gossip = json.loads((folder / "gossip_run" / "metrics.json").read_text())
    assert gossip["status"] == "ok" and gossip["method"] == "gossip_avg"
    for agent in gossip["per_agent"].values():
        assert agent["rounds"] > 0 and agent["completion_ratio_pct"] > 0
    comm = gossip["communication"]
    assert comm["delivered"] > 0
    # success_rate is 1.0: every message lost was lost to the plugin's distance loss
    assert comm["dropped_by_reason"]["loss"] > 0
    used = yaml.safe_load((folder / "gossip_run" / "scenario.yaml").read_text())
    assert used["world"]["scene"]["name"] == "two_rooms"
    assert used["plugins"] == [str(folder / n) for n in ("gossip_avg.py", "distance_loss_radio.py", "my_scene.py")]
    assert json.loads((folder / "ramen_run" / "metrics.json").read_text())["method"] == "ramen"
    runs = sorted(p.name for p in (folder / "gossip_sweep" / "runs").iterdir())
    assert len(runs) == 4, runs
    for name in runs:
        status = json.loads((folder / "gossip_sweep" / "runs" / name / "status.json").read_text())
        assert status["status"] == "ok", status
    (script,) = scripts
    (folder / "tutorial.py").write_text(script)
    proc = subprocess.run([sys.executable, "tutorial.py"], cwd=folder, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.strip().splitlines()
    assert lines[0].startswith("gossip_avg ")
    assert lines[-1] == f"4 {sorted(runs)}"


def test_the_staleness_example_runs_as_written(tmp_path):
    """examples/stale_gossip.py (docs/EXTENDING.md, "Time and the age of copies") as a plugin of a
    tiny run: it reads ctx.ages, its first round's NaN diagnostic does not stop it."""
    files, _, _ = _blocks()
    (tmp_path / "stale_gossip.py").write_text(files["stale_gossip.py"])
    sets = [x for kv in [*TINY, "duration=4", "method=stale_gossip", "evaluation.every_s=null"] for x in ("--set", kv)]
    proc = subprocess.run([sys.executable, "-m", "ramensim", "run", str(REPO / "scenarios" / "office_3agents.yaml"),
                           "--plugin", "stale_gossip.py", "--out", "run", *sets], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr[-3000:]
    m = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert m["status"] == "ok" and m["method"] == "stale_gossip"
    assert all(a["rounds"] > 1 and not a["diverged"] for a in m["per_agent"].values())
    assert "oldest_copy_s" in proc.stderr  # the one warning about the diagnostic
