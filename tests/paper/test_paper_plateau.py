"""``ramensim paper plateau`` (``ramensim.paper.plateau``; docs/results/table1.md, where RAMEN's
consensus error levels off): peak, last probe, ratio and the late window's mean and std, against
hand-computed values; bad input is one paragraph and exit 2."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from ramensim.commands.paper import main


@pytest.fixture
def plateau_tool():
    from ramensim.paper import plateau
    return plateau


def _run(folder: Path, probes: list[tuple[float, float, float | None]], **final: float) -> Path:
    folder.mkdir(parents=True)
    timeline = [{"t": t, "consensus_error": a, "consensus_error_weighted": b} for t, a, b in probes]
    (folder / "metrics.json").write_text(json.dumps({"consensus_timeline": timeline} | final))
    return folder


def test_peak_end_ratio_and_late_window(tmp_path, plateau_tool, capsys):
    # the run's final weighted value (at its end, after the last probe) is the "end"; the
    # unweighted one is missing, so its last probe stands in
    run = _run(tmp_path / "method=ramen", [(2.0, 0.10, 0.12), (4.0, 0.05, 0.06), (6.0, 0.02, None),
                                           (8.0, 0.04, 0.03), (10.0, 0.02, 0.02)],
               consensus_error_weighted=0.024)
    _, probes, ends = plateau_tool.read_probes(run)
    ce1 = plateau_tool.plateau(probes, 6.0, "consensus_error", ends["consensus_error"])
    assert (ce1["peak"], ce1["end"], ce1["n"]) == (0.10, 0.02, 3)
    assert ce1["ratio"] == pytest.approx(5.0)
    assert ce1["mean"] == pytest.approx(0.08 / 3) and ce1["std"] == pytest.approx(0.0094280904)
    ce2 = plateau_tool.plateau(probes, 6.0, "consensus_error_weighted", ends["consensus_error_weighted"])
    assert ce2["n"] == 2 and ce2["mean"] == pytest.approx(0.025)  # the missing probe is skipped
    assert ce2["end"] == 0.024 and ce2["ratio"] == pytest.approx(5.0)
    out = tmp_path / "out"
    assert main(["plateau", str(run / "metrics.json"), "--from", "6", "--out", str(out)]) == 0
    res = json.loads((out / "consensus_plateau.json").read_text())
    assert res["from_s"] == 6.0 and res["runs"][0]["run"] == "method=ramen"
    assert "| method=ramen | 0.1000 → 0.0200 (5.0x) | 0.0267 ± 0.0094 | 0.1200 → 0.0240 (5.0x) | 0.0250 ± 0.0050 | 3 |" \
        in (out / "consensus_plateau.md").read_text()


def test_bad_input_is_one_paragraph_and_exit_2(tmp_path, plateau_tool, caplog):
    assert main(["plateau", str(tmp_path / "missing")]) == 2
    assert "no such file" in caplog.text
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "metrics.json").write_text("{not json")
    assert main(["plateau", str(tmp_path / "bad")]) == 2
    assert "not readable as JSON" in caplog.text
    _run(tmp_path / "local", [])
    assert main(["plateau", str(tmp_path / "local")]) == 2
    assert "'consensus_timeline' is missing or empty" in caplog.text
