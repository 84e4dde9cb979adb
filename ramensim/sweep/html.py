"""A sweep's report as one self-contained HTML page (``report.html``), viewable offline.

Written by ``ramensim report`` beside ``summary.md``: the sweep's name and progress (runs done
of planned, the missing ones), the summary table (mean ± std per condition), the time to
consensus, every figure of ``plots/`` (``embed=True``, the default: as a PNG data URI, so no file
beside the page is needed; ``embed=False``: linked as ``plots/NAME.png``, a page of a few kB for
folders kept under version control, where the embedded copy would double the plots), the
scenario of each condition (the resolved ``scenario.yaml`` of its first finished run) and a
link to every run folder (relative, so they work when the sweep folder is opened where it lies).
"""
from __future__ import annotations

import base64
import html
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

from ramensim.evaluation.plots import metric_label
from ramensim.evaluation.tables import format_mean_std
from ramensim.sweep import store

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;max-width:1200px;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{font-size:1.25em;margin-top:2em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}figcaption{font-size:.85em;color:#555}
pre{background:#f7f7f7;padding:.5em;font-size:.8em;overflow:auto;max-height:24em}.note{color:#555;font-size:.9em}
"""

_CAPTIONS = {
    "completion_over_time": "Completion ratio and completion on the part only teammates saw (%) against simulated "
                            "time (s), mean ± std over trials (run seed × house layout); local and centralised are "
                            "the floor and the ceiling.",
    "consensus_timeline": "Consensus error (RMS spread of the maps' parameters, eq. CE-1) over simulated time.",
    "consensus_weighted_timeline": "Consensus error weighted by eq. 19 (CE-2): the disagreement RAMEN's penalty sees.",
}


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return "–" if not math.isfinite(v) else f"{v:.4g}"
    return html.escape(str(v))


def _table(rows: Sequence[Mapping[str, Any]], cols: Sequence[str], headers: Mapping[str, str] | None = None) -> str:
    head = "".join(f"<th>{html.escape((headers or {}).get(c, c))}</th>" for c in cols)
    body = "".join("<tr>" + "".join(f"<td>{_cell(r.get(c))}</td>" for c in cols) + "</tr>" for r in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _mean_std(row: Mapping[str, Any], metric: str) -> str:
    m, s = row.get(f"{metric}_mean"), row.get(f"{metric}_std")
    if not isinstance(m, (int, float)) or not math.isfinite(m):
        return "–"
    return format_mean_std(m, s if isinstance(s, (int, float)) else None)


def _figure(png: Path, embed: bool) -> str:
    if embed:
        src = "data:image/png;base64," + base64.b64encode(png.read_bytes()).decode("ascii")
    else:
        src = html.escape(f"{png.parent.name}/{png.name}")  # relative to report.html, beside plots/
    caption = _CAPTIONS.get(png.stem, png.stem.replace("_", " "))
    return (f'<figure><img alt="{html.escape(png.stem)}" src="{src}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def write_html(root: Path, title: str, progress: str, rows: Sequence[Mapping[str, Any]], keys: Sequence[str],
               metrics: Sequence[str], records: Sequence[Any], ttc_rows: Sequence[Mapping[str, Any]],
               embed: bool = True) -> Path:
    """Write ``root/report.html`` (see the module docstring) and return its path."""
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{_STYLE}</style></head><body><h1>Sweep {html.escape(title)}</h1>"
             f"<p>{html.escape(progress)}</p>"]
    cells = [{**{k: str(r.get(k)) for k in keys}, "runs": r.get("runs"), "failed": r.get("failed"),
              **{m: _mean_std(r, m) for m in metrics}} for r in rows]
    parts.append("<h2>Results per condition</h2><p class='note'>Mean ± population std over agents and trials.</p>")
    parts.append(_table(cells, [*keys, "runs", "failed", *metrics], {m: metric_label(m) for m in metrics}))
    if ttc_rows:
        parts.append("<h2>Time to consensus</h2><p class='note'>First evaluation after which a run's completion "
                     "stays within 5 points of the centralised run of its trial (s); never: outside at the end.</p>")
        parts.append(_table(ttc_rows, list(ttc_rows[0].keys())))
    pngs = sorted((root / "plots").glob("*.png"), key=lambda p: (p.stem != "completion_over_time", p.stem))
    if pngs:
        parts.append("<h2>Figures</h2>" + "".join(_figure(p, embed) for p in pngs))
    parts.append("<h2>Scenario of each condition</h2>")
    shown: set[tuple] = set()
    for rec in records:
        cond = tuple(str(rec.axes.get(k)) for k in keys)
        yaml_path = root / store.RUNS / rec.name / "scenario.yaml"
        if cond in shown or rec.status not in store.COMPLETE or not yaml_path.is_file():
            continue
        shown.add(cond)
        label = ", ".join(f"{k} = {v}" for k, v in zip(keys, cond)) or title
        parts.append(f"<details><summary>{html.escape(label)} (from {html.escape(rec.name)})</summary>"
                     f"<pre>{html.escape(yaml_path.read_text(encoding='utf-8', errors='replace'))}</pre></details>")
    parts.append("<h2>Runs</h2><ul>")
    for rec in records:
        link = f"{store.RUNS}/{rec.name}/"
        err = f" — {html.escape(rec.error)}" if getattr(rec, "error", None) else ""
        parts.append(f"<li><a href='{html.escape(link)}'>{html.escape(rec.name)}</a>: "
                     f"{html.escape(rec.status)}{err}</li>")
    parts.append("</ul></body></html>")
    path = root / "report.html"
    store.atomic_write_text(path, "".join(parts))
    return path
