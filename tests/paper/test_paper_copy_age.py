"""``ramensim paper copy-age`` (``ramensim.paper.copy_age``; docs/results/causes.md, the copies' age
on a queueing link): windows by arrival time over the delivered messages of a messages.csv, against
hand-computed ages; bad input is one paragraph and exit 2."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from ramensim.commands.paper import main
COLUMNS = ["id", "src", "dst", "nbytes", "wire_bytes", "t_sent", "t_start", "t_done", "stamp", "status",
           "reason", "latency", "age", "packets", "retries"]


@pytest.fixture
def copy_age():
    from ramensim.paper import copy_age
    return copy_age


def _write(path: Path, rows: list[tuple[float, float, str]]) -> Path:
    """rows: (t_done, age, status); the other columns as a run writes them."""
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(COLUMNS)
        for i, (t_done, age, status) in enumerate(rows):
            w.writerow([i, 0, 1, 100, 164, t_done - age, t_done - age, t_done if status == "delivered" else "",
                        t_done - age, status, "" if status == "delivered" else "loss", age, age, 1, 0])
    return path


def test_windows_by_arrival_skip_lost_messages_and_grow_with_a_queue(tmp_path, copy_age):
    # a queue that grows: 0.5 s old in the first window, 1.5 s in the third; lost messages ignored
    msgs = _write(tmp_path / "messages.csv", [(1.0, 0.4, "delivered"), (5.0, 0.6, "delivered"),
                                              (7.0, 9.9, "dropped"), (25.0, 1.0, "delivered"),
                                              (26.0, 2.0, "delivered"), (28.0, 1.5, "delivered")])
    arrival, age = copy_age.read_delivered(tmp_path)  # a run folder works as well as the file
    assert list(arrival) == [1.0, 5.0, 25.0, 26.0, 28.0]
    rows = copy_age.age_by_window(arrival, age, 10.0)
    assert [(r["from_s"], r["to_s"], r["delivered"]) for r in rows] == [(0.0, 10.0, 2), (20.0, 30.0, 3)]
    assert rows[0]["mean_s"] == pytest.approx(0.5) and rows[1]["mean_s"] == pytest.approx(1.5)
    assert rows[1]["p95_s"] == pytest.approx(1.95)  # numpy's linear interpolation of [1.0, 1.5, 2.0]
    out = tmp_path / "out"
    assert main(["copy-age", str(msgs), "--every", "10", "--out", str(out)]) == 0
    res = json.loads((out / "copy_age.json").read_text())
    assert res["delivered"] == 5 and res["mean_s"] == pytest.approx(1.1) and len(res["windows"]) == 2
    assert "| 20-30 | 3 | 1.500 | 1.950 |" in (out / "copy_age.md").read_text()


def test_bad_input_is_one_paragraph_and_exit_2(tmp_path, copy_age, caplog):
    assert main(["copy-age", str(tmp_path / "missing")]) == 2
    assert "no such file" in caplog.text and "messages.csv" in caplog.text
    (tmp_path / "bad.csv").write_text("id,status\n0,delivered\n")
    assert main(["copy-age", str(tmp_path / "bad.csv")]) == 2
    assert "'age', 't_done'" in caplog.text
    bad = _write(tmp_path / "nan.csv", [(1.0, float("nan"), "delivered")])
    assert main(["copy-age", str(bad)]) == 2
    assert "non-finite" in caplog.text
    assert main(["copy-age", str(_write(tmp_path / "ok.csv", [(1.0, 0.5, "delivered")])), "--every", "0"]) == 2
    assert "--every 0.0" in caplog.text
    assert "Traceback" not in caplog.text
