"""How old the copies are when they arrive, window by window of a run (a cause analysis,
docs/RESULTS.md, "Why RAMEN's consensus error levels off": a link whose messages take longer
than a round to send builds a queue, and the copies get older as the run goes on).

metrics.json's ``communication.age_s`` averages over the whole run; this reads the run's
per-message log (``messages.csv``: one row per message, ``t_done`` the arrival time in
simulated s, ``age`` the copy's age on arrival: arrival minus the state's stamp, s) and gives,
for each window of ``--every`` simulated seconds by arrival time, the delivered messages'
count and their mean and 95th-percentile age.

    python tools/copy_age.py RUN_FOLDER_OR_MESSAGES_CSV [--every 60] [--out DIR]

Writes ``copy_age.json`` and ``copy_age.md`` into ``--out`` (default: print only).
"""
from __future__ import annotations

import argparse
import csv
import logging
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from _cause import write_outputs

log = logging.getLogger("copy_age")


class InputProblem(Exception):
    """A missing or malformed messages.csv (reported as one paragraph, exit 2)."""


def read_delivered(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(arrival time s, age on arrival s) of every delivered message in ``messages.csv``."""
    if path.is_dir():
        path = path / "messages.csv"
    if not path.is_file():
        raise InputProblem(f"{path}: no such file; expected a run folder with the per-message log "
                           f"messages.csv (written when output.message_log is on, the default) or the file itself.")
    arrival, age = [], []
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        missing = {"status", "t_done", "age"} - set(reader.fieldnames or ())
        if missing:
            raise InputProblem(f"{path}: the columns {sorted(missing)} are missing; expected a ramensim "
                               f"messages.csv (status, t_done, age, ...).")
        for row_no, row in enumerate(reader, start=2):
            if row["status"] != "delivered":
                continue
            try:
                t, a = float(row["t_done"]), float(row["age"])
            except ValueError:
                raise InputProblem(f"{path}, line {row_no}: t_done {row['t_done']!r} / age {row['age']!r} "
                                   f"of a delivered message are not numbers.") from None
            if not (math.isfinite(t) and math.isfinite(a)):
                raise InputProblem(f"{path}, line {row_no}: a delivered message with a non-finite "
                                   f"t_done or age ({t}, {a}).")
            arrival.append(t)
            age.append(a)
    return np.asarray(arrival, dtype=float), np.asarray(age, dtype=float)


def age_by_window(arrival: np.ndarray, age: np.ndarray, every: float) -> list[dict[str, Any]]:
    """One entry per window ``[k * every, (k + 1) * every)`` of arrival time that holds a
    delivered message: ``{"from_s", "to_s", "delivered", "mean_s", "p95_s"}``."""
    if every <= 0 or not math.isfinite(every):
        raise InputProblem(f"--every {every}: expected a positive number of simulated seconds.")
    rows = []
    window = np.floor(arrival / every).astype(np.int64)
    for k in np.unique(window):
        sel = age[window == k]
        rows.append({"from_s": float(k * every), "to_s": float((k + 1) * every), "delivered": int(sel.size),
                     "mean_s": float(sel.mean()), "p95_s": float(np.percentile(sel, 95))})
    return rows


def render(source: Path, rows: list[dict[str, Any]], total: tuple[int, float]) -> str:
    lines = [f"Copy age on arrival, {source}: {total[0]} delivered, mean {total[1]:.3f} s", "",
             "| arrival (s) | delivered | mean age (s) | 95th percentile (s) |", "|---|---:|---:|---:|"]
    lines += [f"| {r['from_s']:g}-{r['to_s']:g} | {r['delivered']} | {r['mean_s']:.3f} | {r['p95_s']:.3f} |"
              for r in rows]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="a run folder holding messages.csv, or the file itself")
    ap.add_argument("--every", type=float, default=60.0, help="window length, simulated s (default 60)")
    ap.add_argument("--out", type=Path, default=None, help="write copy_age.json / .md here")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        arrival, age = read_delivered(args.run)
        rows = age_by_window(arrival, age, args.every)
    except InputProblem as exc:
        log.error("copy_age: %s", exc)
        return 2
    mean = float(age.mean()) if age.size else math.nan
    res = {"run": str(args.run), "every_s": args.every, "delivered": int(age.size), "mean_s": mean, "windows": rows}
    write_outputs(args.out, "copy_age", res, render(args.run, rows, (int(age.size), mean)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
