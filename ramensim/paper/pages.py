"""The claims page (docs/results/paper/claims.md) in Markdown: one row per claim (rule, quantity
with its 95 % interval, trials and units judged, verdict, cause, every trial's numbers), then the
runs done per experiment and condition, the runs not judged and the trials whose compared runs
ran on different hosts."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

from ramensim.paper.claims import runs_done
from ramensim.paper.rules import MIXED, UNRECORDED, Claim, Test
from ramensim.paper.trials import Judging


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _estimate(t: Test, iv) -> str:
    """``13.5x [10.3, 17.8]`` or ``+0.06 [+0.02, +0.09]``: an interval in the test's notation."""
    if t.kind == "ratio":
        return f"{iv.estimate:.1f}x" + (f" [{iv.lo:.1f}, {iv.hi:.1f}]" if iv.defined else "")
    return f"{iv.estimate:+.2f}" + (f" [{iv.lo:+.2f}, {iv.hi:+.2f}]" if iv.defined else "")


def _with_trial_reading(c: Claim) -> str:
    """The claim's cause, plus what the verdict was with every trial taken as an independent unit
    when that reading differs from the one over run seeds."""
    if not c.samples or c.n_units() == c.n() or c.trial_verdict() == c.verdict():
        return c.cause
    shown = "; ".join(_estimate(t, iv) for t, iv in zip(c.tests, c.trial_intervals()))
    note = (f"with the {c.n()} trials taken as independent units (this page before 2026-11-28) it "
            f"{c.trial_verdict()} ({shown}); over the {c.n_units()} run seeds it is {c.verdict()}")
    return "; ".join(x for x in (c.cause, note) if x)


def _runs_done_markdown(rows: Sequence[tuple[str, str, list[tuple[int, int]], int]]) -> list[str]:
    total = sum(len(d) for _, _, d, _ in rows)
    planned = sum(n for _, _, _, n in rows)
    lines = ["", f"## Runs done: {total} of {planned} planned", "",
             "Per experiment and condition (the sweep file's axes other than run seed and layout), the trials "
             "with a finished run (s = run seed, L = house layout).", "",
             "| experiment | condition | trials done | which |", "|---|---|---:|---|"]
    for title, cond, done, n in rows:
        which = "all" if len(done) == n else (", ".join(f"s{s}L{lay}" for s, lay in done) or "none")
        lines.append(f"| {title} | {cond} | {len(done)} of {n} | {which} |")
    return lines


def to_markdown(claims: Sequence[Claim], results: Path, notes: Sequence[tuple[str, str]] = (),
                judging: Judging | None = None) -> str:
    """claims.md for ``claims`` judged on the archives under ``results``: the table, the runs done
    (:func:`~ramensim.paper.claims.runs_done`), ``notes`` (the runs not judged,
    :func:`~ramensim.paper.claims.not_judged`) and the trials on different hosts that ``judging``
    (the pass that judged ``claims``) noted; without ``judging`` the archives are read afresh and
    no such trial is listed."""
    judging = judging if judging is not None else Judging()
    lines = ["# The paper's claims on the paper-horizon runs, with 95 % intervals", "",
             f"Made by `ramensim claims --out {results.as_posix()}/claims.md` from the archives under "
             f"`{results.as_posix()}/` and the cause studies and the Fig. 7 sweeps beyond the paper's runs beside them "
             "(`cause/`, `fig7/`; 600 simulated s; trials: run seed x house "
             "layout, 6 planned per claim). A trial is judged once every run its rule needs is complete. **The "
             "independent unit is the run seed**: the two layouts of one run seed meet the same channel realisation "
             "(the channel's draws are keyed by run seed, link and send time) and the same map initialisation, so "
             "the 6 trials are 3 units with 2 layouts nested in each; a unit's trials are averaged first (eq. U-1 of "
             "`evaluation/intervals.py`; geometric mean for the falls, robots pooled for a pooled std). Each claim "
             "compares one quantity per trial with a threshold; the interval is the paired 95 % interval over the "
             "units judged (Student t over the per-unit values; over their logs for the consensus-error falls, "
             "shown as the geometric mean; a bootstrap over whole units, every resample enumerated, for a standard "
             "deviation pooled over robots and trials). Where taking the 6 trials as 6 independent units (as this "
             "page did before 2026-11-28) gives another verdict, the cause column says so. The thresholds (within 5 "
             "points of centralised, local + 15, 70 %, a 5-point drop, a 10x fall) are the project's readings of the "
             "paper's words, not the paper's numbers. Verdict: **holds** when the interval clears the threshold on "
             "the claim's side, **fails** when it lies wholly on the wrong side, **inconclusive** when it straddles "
             "it (or there is no interval); a claim with two comparisons fails if one fails and holds if both hold "
             "(`evaluation/intervals.py`). \"n\": trials judged of those planned, the independent units (run seeds) "
             "they form, and on how many trials the trial's own numbers clear the threshold (✓). \"Every robot\" compares each robot of one method with each robot "
             "of the other: the margin is the smallest over all pairs. The consensus-error falls are the peak after "
             "the start-up transient over the mean of the last 60 s of readings (docs/ALGORITHM.md section 5). "
             f"{MIXED}: the trial's compared runs ran on different hosts (metrics.json `build`, "
             f"`ramensim.provenance.same_host`; listed below); runs of two hosts differ by float rounding "
             f"(docs/RESULTS.md, protocol). {UNRECORDED}: a compared run has no host record (archived before "
             "2026-11-25).", "",
             "| claim | rule | quantity: estimate [95 % interval] | n | verdict | cause | per trial |",
             "|---|---|---|---|---|---|---|"]
    for c in claims:
        cells = "; ".join(f"{label}: {'✓' if ok else '✗'} {text}" for label, ok, text in c.judged) or "—"
        ivs = c.intervals() if c.samples else []
        quantity = "; ".join(t.describe(iv) for t, iv in zip(c.tests, ivs)) or "—"
        held = sum(ok for _, ok, _ in c.judged[:c.n()])
        units = f" in {c.n_units()} unit{'s' if c.n_units() != 1 else ''}" if c.samples else ""
        n = f"{c.n()} of {c.planned}{units} ({held} ✓)" if not c.pooled else \
            f"{c.n()} of {c.planned}{units} (pooled)"
        lines.append(f"| {_cell(c.name)} | {_cell(c.rule)} | {_cell(quantity)} | {n} | **{c.verdict()}** | "
                     f"{_cell(_with_trial_reading(c)) or '—'} | {_cell(cells)} |")
    lines += _runs_done_markdown(runs_done(results, judging))
    lines += ["", f"## Runs not judged: {len(notes)}", ""]
    if notes:
        lines += ["Each claim is judged on the other runs.", "", "| run or trial | why |", "|---|---|"]
        lines += [f"| {_cell(what)} | {_cell(why)} |" for what, why in notes]
    else:
        lines.append("None: every planned run is complete and has what its rules need.")
    if judging.mixed_runs:
        lines += ["", f"## Trials whose compared runs ran on different hosts ({MIXED}): {len(judging.mixed_runs)}", "",
                  "Judged as the others: runs of two hosts differ by float rounding. Each row: the runs one trial's "
                  "rule compared, with the host each ran on (metrics.json `build`: CPU model, SIMD level, torch "
                  "device, host fingerprint).", "",
                  "| runs (host) |", "|---|"]
        lines += ["| " + _cell("; ".join(f"{w} ({m})" for w, m in runs)) + " |" for runs in judging.mixed_runs]
    return "\n".join(lines) + "\n"
