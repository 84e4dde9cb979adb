"""``ramensim paper far-part``'s pieces (``ramensim.paper.far_part``): first sight per robot and
window, the earliest sight by a set of robots, links on the graph, the fewest links to a robot that
saw a sample, the bins; a folder that is not a finished run is one clear error."""
from __future__ import annotations

import numpy as np
import pytest

from ramensim.commands.paper import main


@pytest.fixture()
def tool():
    from ramensim.paper import far_part
    return far_part


def test_first_sight_links_and_bins(tool):
    # 3 robots, 4 samples, 2 windows: robot 0 sees sample 0 in window 1; robot 2 sees 1 in 0 and 2 in 1
    w0 = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0]], bool)
    w1 = np.array([[1, 0, 0, 0], [0, 0, 0, 0], [0, 1, 1, 0]], bool)
    first = tool.first_seen([w0, w1])
    assert first.tolist() == [[1, -1, -1, -1], [-1, -1, -1, -1], [-1, 0, 1, -1]]
    assert tool.earliest(first, np.array([True, False, True])).tolist() == [1, 0, 1, -1]
    path = [[1], [0, 2], [1]]                      # 0 - 1 - 2
    dist = tool.hops_from(path, [0])
    assert dist.tolist() == [0, 1, 2]
    assert tool.fewest_hops(first >= 0, dist).tolist() == [0, 2, 2, -1]
    hit = np.array([True, False, True, True])
    rows = tool.binned(tool.fewest_hops(first >= 0, dist), np.array([False, True, True, False]), hit, 3)
    assert rows == [{"n": 0, "hit": 0}, {"n": 0, "hit": 0}, {"n": 2, "hit": 1}]


def test_a_folder_that_is_not_a_run_is_one_clear_error(tmp_path, tool, caplog):
    assert main(["far-part", str(tmp_path)]) == 2
    assert "is not a finished run folder" in caplog.text and str(tmp_path) in caplog.text


def test_compare_pools_the_runs_of_each_robot_count(tmp_path, tool):
    import json

    def res(name, robots, far, hops):
        return {"run": name, "robots": robots, "edges_s": [100.0, 200.0],
                "team": {"far": far, "own": [{"n": 1, "hit": 1}] * 2, "hops": hops}}
    rows = lambda *nh: [{"n": n, "hit": h} for n, h in nh]  # noqa: E731
    files = []
    for i, r in enumerate([res("a", 4, rows((10, 8), (10, 2)), rows((0, 0), (0, 0), (20, 10))),
                           res("b", 4, rows((30, 27), (0, 0)), rows((0, 0), (0, 0), (30, 27))),
                           res("c", 6, rows((4, 1), (0, 0)), rows((0, 0), (0, 0), (4, 1)))]):
        files.append(tmp_path / f"{i}.json")
        files[-1].write_text(json.dumps(r))
    text = tool.compare(files)
    assert ("pooled over the 2 runs with 4 robots: far part's completion 74.0 %; by first sight "
            "0-100 s: 80.0 % of it at 87.5; 100-200 s: 20.0 % of it at 20.0; by links 2: 100.0 % of it at 74.0") in text
    assert "pooled over the 1 run with 6 robots: far part's completion 25.0 %" in text


def test_the_command_and_the_tools_script_name_a_bad_folder_in_one_paragraph(tmp_path, capsys):
    """``ramensim paper far-part`` (through the CLI: "error: ...", exit 2, no traceback) and the old
    command the pages printed, ``python tools/far_part.py``, which calls the same code."""
    import subprocess
    import sys
    from pathlib import Path

    from ramensim.cli import main as cli

    assert cli(["paper", "far-part", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "is not a finished run folder" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    script = Path(__file__).resolve().parents[2] / "tools" / "far_part.py"
    proc = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "is not a finished run folder" in proc.stderr and "Traceback" not in proc.stderr
