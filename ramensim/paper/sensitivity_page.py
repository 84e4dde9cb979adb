"""The sensitivity page (docs/results/sensitivity.md) in Markdown: a row per knob value with each
main claim's estimate, 95 % interval and verdict (:func:`cell`), every trial's numbers, the runs
done per sweep, the runs not judged and the trials whose compared runs ran on different hosts."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

from ramensim.paper.archive import same
from ramensim.paper.rules import MIXED, UNRECORDED, label
from ramensim.paper.sensitivity import CLAIMS, DRIFTS, METHODS, REFERENCES, ClaimRule, Row, Sweep, judging_of, shown


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def cell(row: Row, i: int) -> str:
    """One cell: ``estimate [lo, hi] verdict`` (with the trials judged if not all), or "not run" /
    "not judged" with the runs lacking."""
    claim = row.claims[i]
    if row.diverged[i]:
        rest = ""
        if claim.samples:
            (iv,) = claim.intervals()
            rest = f"; the other {claim.n()}: {iv.estimate:+.2f}"
        ran = len(row.diverged[i]) + claim.n()  # the trials judged: diverged or with a value
        part = f" ({ran} of {claim.planned} trials run)" if ran < claim.planned else ""
        return f"**fails**: RAMEN diverged on {len(row.diverged[i])} of {ran} trials{part}{rest}"
    if not claim.samples:
        roles = row.missing_roles[i]
        state = "not judged" if "not judged" in roles.values() else "not run"
        return f"{state} ({', '.join(roles)})" if roles else state
    (iv,) = claim.intervals()
    if iv.defined:
        span = f"[{iv.lo:+.2f}, {iv.hi:+.2f}]"
    elif claim.n() == 1:
        span = "(one trial: no interval)"
    else:
        units = claim.n_units()
        agree = sum(ok for _, ok, _ in claim.judged)
        span = (f"(no interval: {claim.n()} trials in {units} unit{'s' if units != 1 else ''}; "
                f"{agree} of {claim.n()} trials ✓)")
    part = f" ({claim.n()} of {claim.planned} trials)" if claim.n() < claim.planned else ""
    marks = "".join(sorted({m for trial, _, _ in claim.judged for m in (MIXED, UNRECORDED) if m in trial}))
    apart = f" {DRIFTS} (maps drift apart on {len(row.drifting[i])} of {claim.n()})" if row.drifting[i] else ""
    return f"{iv.estimate:+.2f} {span} **{claim.verdict()}**{part}{marks}{apart}"


_SIDE = {">=": "≥", ">": ">", "<=": "≤", "<": "<"}


def _header(spec: ClaimRule) -> str:
    t = spec.test
    return f"{spec.title}: {t.what} {_SIDE[t.side]} {t.threshold:g} holds"


def to_markdown(rows: Sequence[Row], sweeps: dict[str, Sweep], trial_list: Sequence[tuple[int, int]],
                base: dict[str, float], results: Path, runs: Path | None = None) -> str:
    """docs/results/sensitivity.md for the rows :func:`~ramensim.paper.sensitivity.judge_all` judged
    (``results``, ``runs``: the folders it read, shown on the page with the command)."""
    from ramensim.evaluation.consensus_fall import DRIFT
    from ramensim.evaluation.intervals import LEVEL, t_interval

    planned = sum(len(s.plan.points) for s in sweeps.values())
    done = {name: s.done() for name, s in sweeps.items()}
    total = sum(len(d) for d in done.values())
    trials_words = ", ".join(f"run seed {s} on house layout {lay}" for s, lay in trial_list)
    command = "ramensim sensitivity --out docs/results/sensitivity.md" + \
        (f" --runs {shown(runs)}" if runs is not None else "")
    lines = [
        "# Sensitivity of the main claims to dual_step, beta_l and rho (300 s)", "",
        f"**Runs done: {total} of {planned} planned.** Part of [the results of the paper's experiments]"
        "(../RESULTS.md); the claims at 600 s on six trials: [claims.md](paper/claims.md).", "",
        f"Made by `{command}` from the archives under `{shown(results)}/`"
        + (f" and the sweep folders under `{shown(runs)}/` not archived yet" if runs is not None else "")
        + f" (the sweep files: `scenarios/sweeps/sensitivity/`). One knob at a time at the Table I setting "
        f"(house, 3 robots, complete graph, 0.05 m/s) for {base['duration']:g} simulated s, on {len(trial_list)} "
        f"trials ({trials_words}). The defaults, never moved to suit a claim: `consensus.dual_step` "
        f"{base['consensus.dual_step']:g}, eq. 19's floor `consensus.ramen.beta_l` {base['consensus.ramen.beta_l']:g} "
        f"(rho / 1000), `consensus.ramen.rho` {base['consensus.ramen.rho']:g} (and DiNNO's `consensus.dinno.rho` "
        f"{base['consensus.dinno.rho']:g}); the default row is the default RAMEN ({REFERENCES}) with DiNNO, "
        f"centralised and local at their defaults ({METHODS}, at 50 % success; centralised and local do not "
        "communicate). In the rho rows eq. 19's bounds keep their defaults' relation to rho (beta_u = rho, "
        "beta_l = rho / 1000), so every weight scales with rho; the beta_l rows move the floor alone.", "",
        "The claims are judged as in [claims.md](paper/claims.md), with its rules and thresholds "
        "(`ramensim/paper/rules.py`) and intervals (`evaluation/intervals.py`): per trial one quantity (completion, "
        f"%, 5 cm; points), over the trials its paired {LEVEL * 100:g} % Student t interval; **holds** when the "
        "interval clears the threshold on the claim's side, **fails** when it lies wholly on the wrong side, "
        "**inconclusive** when it straddles it or there is one independent unit only; a claim also **fails** at a knob value "
        "where RAMEN's maps diverged on a trial (a robot marked `diverged` by the run's divergence rule, "
        "`ramensim/divergence.py`: its loss 100 times its running minimum, or a non-finite map): such a trial is "
        "a failure, not a missing run. Table I's two claims compare RAMEN at "
        "50 % success; the lead over DiNNO compares it with DiNNO at its defaults in the default, dual_step and "
        "beta_l rows (DiNNO's dual step, which it shares with RAMEN's C-ADMM, stays 0.2), and in the rho rows "
        "with DiNNO's own runs at the same rho (sensitivity_rho_dinno), the paired reference there. Fig. 5's "
        "claim is judged on RAMEN's drop only (claims.md also asks it to be smaller than DiNNO's; the "
        "sensitivity sweeps run DiNNO at 50 % only). At 1 % every RAMEN robot is compared with every robot of "
        "the local run of the trial.",
    ]
    # the units of the trials that have runs (a second run seed may be planned and not run yet)
    ran = [t for t in trial_list
           if any(p.name in done[name] and same(p.axes.get("seed"), t[0]) and same(p.axes.get("world.scene.seed"), t[1])
                  for name, sweep in sweeps.items() for p in sweep.plan.points)]
    seeds = sorted({t[0] for t in ran})
    if len(seeds) == 1:
        lines += ["", f"**One independent unit.** The {len(ran)} trials run so far are {len(ran)} house layouts run "
                  f"with one run seed ({seeds[0]}): they meet the same channel realisation (the channel's draws are "
                  "keyed by run seed, link and send time: the same messages arrive on both layouts) and the same map "
                  "initialisation, so they are one unit (`evaluation/intervals.py`, eq. U-1), and no cell has an "
                  "interval: every verdict is **inconclusive** until the rows run on a second run seed. Until "
                  "2026-11-28 this page took the two layouts as two independent trials (t with one degree of freedom) "
                  "and read holds or fails where both agreed closely; the cells now give the estimate and on how many "
                  "trials the trial's own value clears the threshold, which says how the two layouts agree, not "
                  "how a second channel would fall." + (
                      " The other planned trials (" + ", ".join(f"run seed {a} on house layout {b}" for a, b in trial_list
                                                              if (a, b) not in ran) + ") have no run yet."
                      if len(ran) < len(trial_list) else "")]
    elif len(seeds) == 2:
        unit = t_interval([0.0, 1.0])
        lines += ["", f"With two units the interval is the mean ± {(unit.hi - unit.lo) / 2:.2f} times the "
                  "difference of the two units' values (t with one degree of freedom): a claim holds or fails only "
                  "where both agree closely, well clear of its threshold."]
    lines += ["", "Cells: estimate [95 % interval] **verdict**; \"**fails**: RAMEN diverged on k of n trials\" (and "
              f"the others' mean, if any) where it diverged; {DRIFTS} where a RAMEN run a trial compared has maps "
              "that drift apart without having diverged yet (its consensus error ends at least "
              f"{DRIFT:g} times its lowest reading after start-up, `evaluation/consensus_fall.py: consensus_growth`; "
              "`DRIFT` there says how the threshold was chosen): the verdict stands, but its numbers "
              "come from maps that stopped agreeing; \"not run\" (and the runs lacking) where a run a "
              f"claim needs does not exist yet, \"not judged\" where it exists but is not usable (below). {MIXED}: "
              f"a trial's compared runs ran on different hosts, {UNRECORDED}: a run has no host record (both "
              "listed below).", "",
              "| knob value | " + " | ".join(_cell(_header(c)) for c in CLAIMS) + " |",
              "|---" * (len(CLAIMS) + 1) + "|"]
    for row in rows:
        lines.append(f"| {row.label} | " + " | ".join(_cell(cell(row, i)) for i in range(len(CLAIMS))) + " |")

    lines += ["", "## Per trial", "",
              "Each trial's numbers (✓: the trial's own value clears the threshold), or the runs it lacks; a "
              "claim with no run on any trial is left out here (the table above names what it lacks, \"Runs "
              "done\" below the sweeps to run).", "",
              "| knob value | claim | per trial |", "|---|---|---|"]
    for row in rows:
        for i, spec in enumerate(CLAIMS):
            if not row.claims[i].judged and not row.diverged[i] and set(row.missing_roles[i].values()) <= {"not run"}:
                continue
            judged = iter(row.claims[i].judged)
            parts = []
            for t in trial_list:
                if t in row.diverged[i]:
                    parts.append(f"{label(*t)}: ✗ {row.diverged[i][t]}")
                elif t in row.missing[i]:
                    parts.append(f"{label(*t)}: {row.missing[i][t]}")
                else:
                    trial, ok, text = next(judged)
                    parts.append(f"{trial}: {'✓' if ok else '✗'} {text}")
            lines.append(f"| {row.label} | {spec.title} | {_cell('; '.join(parts))} |")

    lines += ["", f"## Runs done: {total} of {planned} planned", "",
              "Per sweep, the runs with a complete result. To run a sweep and keep it: `ramensim sweep "
              "scenarios/sweeps/sensitivity/FILE.yaml`, then `python tools/archive_sweep.py runs/sweeps/NAME "
              "docs/results/sensitivity/NAME` and this page's command.", "",
              "| sweep | file | runs done | read from |", "|---|---|---:|---|"]
    for name, sweep in sweeps.items():
        where = sorted(set(done[name].values()))
        lines.append(f"| {name} | `{shown(sweep.plan.source)}` | {len(done[name])} of {len(sweep.plan.points)} | "
                     f"{', '.join(f'`{w}`' for w in where) or '—'} |")

    notes = not_judged(sweeps)
    lines += ["", f"## Runs not judged: {len(notes)}", ""]
    if notes:
        lines += ["Runs that exist but are not usable, and trials a missing number kept out; every claim is judged "
                  "on the other runs.", "", "| run or trial | why |", "|---|---|"]
        lines += [f"| {_cell(what)} | {_cell(why)} |" for what, why in notes]
    else:
        lines.append("None: every run that exists is complete and has what its rules need.")
    judging = judging_of(sweeps)
    if judging.mixed_runs:
        lines += ["", f"## Trials whose compared runs ran on different hosts ({MIXED}): {len(judging.mixed_runs)}", "",
                  "Judged as the others: runs of two hosts differ by float rounding (docs/DESIGN.md, "
                  "\"Determinism\"). Each row: the runs one trial's rule compared, with the host each ran on "
                  "(metrics.json `build`: CPU model, SIMD level, torch device, host fingerprint).", "",
                  "| runs (host) |", "|---|"]
        lines += ["| " + _cell("; ".join(f"{w} ({m})" for w, m in runs)) + " |" for runs in judging.mixed_runs]
    return "\n".join(lines) + "\n"


def not_judged(sweeps: dict[str, Sweep]) -> list[tuple[str, str]]:
    """(run or claim and trial, why) for every run that exists but is not usable, and every trial a
    run's missing number kept out (the judging pass's ``skipped``, :func:`~ramensim.paper.sensitivity.judging_of`)."""
    out = [p for s in sweeps.values() for p in s.problems()]
    return out + list(judging_of(sweeps).skipped)

