"""How old the copies are when they arrive, window by window of a run (a cause study,
docs/results/causes.md, "Why RAMEN's consensus error levels off": a link whose messages take longer
than a round to send builds a queue, and the copies get older as the run goes on;
``ramensim paper copy-age``).

metrics.json's ``communication.age_s`` averages over the whole run; this reads the run's
per-message log (``messages.csv``: one row per message, ``t_done`` the arrival time in
simulated s, ``age`` the copy's age on arrival: arrival minus the state's stamp, s) and gives,
for each window of ``every`` simulated seconds by arrival time, the delivered messages'
count and their mean and 95th-percentile age. Outputs: ``copy_age.json`` and ``copy_age.md``.
"""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from ramensim.core.errors import InputError

def read_delivered(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(arrival time s, age on arrival s) of every delivered message in ``messages.csv`` (``path``
    or a run folder holding it); :class:`InputError` naming a missing or malformed file or line."""
    if path.is_dir():
        path = path / "messages.csv"
    if not path.is_file():
        raise InputError(f"{path}: no such file; expected a run folder with the per-message log "
                         f"messages.csv (written when output.message_log is on, the default) or the file itself.")
    arrival, age = [], []
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        missing = {"status", "t_done", "age"} - set(reader.fieldnames or ())
        if missing:
            raise InputError(f"{path}: the columns {sorted(missing)} are missing; expected a ramensim "
                             f"messages.csv (status, t_done, age, ...).")
        for row_no, row in enumerate(reader, start=2):
            if row["status"] != "delivered":
                continue
            try:
                t, a = float(row["t_done"]), float(row["age"])
            except ValueError:
                raise InputError(f"{path}, line {row_no}: t_done {row['t_done']!r} / age {row['age']!r} "
                                 f"of a delivered message are not numbers.") from None
            if not (math.isfinite(t) and math.isfinite(a)):
                raise InputError(f"{path}, line {row_no}: a delivered message with a non-finite "
                                 f"t_done or age ({t}, {a}).")
            arrival.append(t)
            age.append(a)
    return np.asarray(arrival, dtype=float), np.asarray(age, dtype=float)


def age_by_window(arrival: np.ndarray, age: np.ndarray, every: float) -> list[dict[str, Any]]:
    """One entry per window ``[k * every, (k + 1) * every)`` of arrival time that holds a
    delivered message: ``{"from_s", "to_s", "delivered", "mean_s", "p95_s"}`` (s; ages of copies
    arriving in the window); :class:`InputError` for a window that is not a positive number of s."""
    if every <= 0 or not math.isfinite(every):
        raise InputError(f"--every {every}: expected a positive number of simulated seconds.")
    rows = []
    window = np.floor(arrival / every).astype(np.int64)
    for k in np.unique(window):
        sel = age[window == k]
        rows.append({"from_s": float(k * every), "to_s": float((k + 1) * every), "delivered": int(sel.size),
                     "mean_s": float(sel.mean()), "p95_s": float(np.percentile(sel, 95))})
    return rows


def render(source: Path, rows: list[dict[str, Any]], total: tuple[int, float]) -> str:
    """The windows as Markdown under a line with the run's delivered count and mean age (s) ``total``."""
    lines = [f"Copy age on arrival, {source}: {total[0]} delivered, mean {total[1]:.3f} s", "",
             "| arrival (s) | delivered | mean age (s) | 95th percentile (s) |", "|---|---:|---:|---:|"]
    lines += [f"| {r['from_s']:g}-{r['to_s']:g} | {r['delivered']} | {r['mean_s']:.3f} | {r['p95_s']:.3f} |"
              for r in rows]
    return "\n".join(lines) + "\n"


def analyse(run: Path, every: float) -> dict[str, Any]:
    """The study of one run (a folder or its messages.csv): ``{"run", "every_s", "delivered",
    "mean_s", "windows"}`` with the delivered messages' count, their mean age on arrival (s; NaN
    when none) and :func:`age_by_window`'s rows for windows of ``every`` simulated s."""
    arrival, age = read_delivered(run)
    rows = age_by_window(arrival, age, every)
    mean = float(age.mean()) if age.size else math.nan
    return {"run": str(run), "every_s": every, "delivered": int(age.size), "mean_s": mean, "windows": rows}
