"""Tables of aggregated results (paper Table I style): mean +- std cells, CSV and Markdown.

Pure functions over rows (a list of dicts); no knowledge of sweeps or agents.
"""
from __future__ import annotations

import csv
import io
import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np


def mean_std(values: Iterable[float]) -> tuple[float, float, int]:
    """Mean and population standard deviation (ddof=0, numpy's default) of the finite values,
    and how many there were; (nan, nan, 0) when none are finite. Units: those of the values."""
    arr = np.asarray([float(v) for v in values], dtype=np.float64)
    arr = arr[np.isfinite(arr)]
    if arr.size == 0:
        return math.nan, math.nan, 0
    return float(arr.mean()), float(arr.std()), int(arr.size)


def format_number(value: Any, digits: int = 2) -> str:
    """A cell: floats with ``digits`` decimals, NaN/None as an en dash, others as text."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(float(value)):
            return "–"
        v = float(value)
        if v != 0 and (abs(v) >= 1e6 or abs(v) < 10 ** -digits):
            return f"{v:.{max(digits, 1)}e}"
        return f"{v:.{digits}f}"
    return str(value)


def format_mean_std(mean: float | None, std: float | None, digits: int = 2) -> str:
    """``mean ± std`` with both at the mean's precision (an en dash when the mean is missing; the
    mean alone when std is). ``digits`` decimals for means of 0.1 and more; smaller means keep 3
    significant figures (a consensus error of 0.0152 reads ``0.0152 ± 0.0004``, not ``0.02 ±
    4.15e-04``); means of a million or more (bytes) are in scientific notation, the std too. A
    non-zero std that would round to zero at that precision is shown to one significant figure."""
    if mean is None or isinstance(mean, bool) or not isinstance(mean, (int, float, np.integer, np.floating)):
        return format_number(mean, digits)
    v = float(mean)
    if not math.isfinite(v):
        return "–"
    if isinstance(mean, (int, np.integer)):
        m, d = str(int(mean)), digits
    elif v != 0 and abs(v) >= 1e6:
        m = f"{v:.{digits}e}"
        d = -1
    else:
        d = digits if (v == 0 or abs(v) >= 0.1) else max(digits, 2 - math.floor(math.log10(abs(v))))
        m = f"{v:.{d}f}"
    if std is None or isinstance(std, bool) or not math.isfinite(float(std)):
        return m
    sd = float(std)
    if d < 0:
        s = f"{sd:.{digits}e}" if sd != 0 else "0"
    else:
        s = f"{sd:.{d}f}"
        if sd != 0 and float(s) == 0:
            s = f"{sd:.1g}"
    return f"{m} ± {s}"


def to_csv(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """CSV text with a header row; floats at full precision (repr), missing cells empty."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        cells = []
        for col in columns:
            v = row.get(col)
            if v is None or (isinstance(v, float) and math.isnan(v)):
                cells.append("")
            elif isinstance(v, (float, np.floating)):
                cells.append(repr(float(v)))
            else:
                cells.append(v if isinstance(v, str) else format_number(v))
        writer.writerow(cells)
    return buf.getvalue()


def _md_escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def to_markdown(rows: Sequence[Mapping[str, Any]], columns: Sequence[str],
                headers: Mapping[str, str] | None = None, digits: int = 2) -> str:
    """A GitHub-flavoured Markdown table; cells that are already strings are kept as they are."""
    headers = headers or {}
    head = [_md_escape(headers.get(c, c)) for c in columns]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    for row in rows:
        cells = []
        for c in columns:
            v = row.get(c)
            cells.append(_md_escape(v if isinstance(v, str) else format_number(v, digits)))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
