"""Which of the paper's main claims survive which knob of the reproduced RAMEN (issue 56, item 4).

    python tools/sensitivity_table.py --out docs/results/sensitivity.md
    python tools/sensitivity_table.py --runs runs/sweeps      # also the sweeps not archived yet -> stdout

The sensitivity sweeps (``scenarios/sweeps/sensitivity/*.yaml``, ``--sweeps``) vary one knob at a
time around the defaults at the Table I setting for 300 simulated s on two trials (run seed x
house layout): ``consensus.dual_step`` (``sensitivity_dual_step``), eq. 19's floor
``consensus.ramen.beta_l`` (``sensitivity_beta_l``) and the ADMM penalty ``consensus.ramen.rho``
(``sensitivity_rho``, with DiNNO at the same values in ``sensitivity_rho_dinno``); the default
RAMEN is ``sensitivity_references`` and DiNNO, centralised and local at their defaults are
``sensitivity_methods``. Their runs are read from the archives ``--results/<sweep name>/`` (made
by ``tools/archive_sweep.py``) and, with ``--runs DIR``, from the sweep folders ``DIR/<sweep
name>/`` of sweeps not archived yet (an archived run is taken first).

For each knob value (the default: the references and the methods runs), four claims are judged
with the rules, thresholds and intervals of docs/results/paper/claims.md (``tools/paper_claims.py``:
:data:`paper_claims.CENTRAL_GAP` and :func:`paper_claims.central_gap`, ``DINNO_LEAD`` /
``dinno_lead``, ``RAMEN_DROP`` / ``completion_drop``, ``ABOVE_LOCAL`` / ``robots_above``; paired
95 % Student t intervals over the trials, ``evaluation/intervals.py``): Table I's gap to
centralised (RAMEN at 50 % success minus centralised), Table I's lead over DiNNO (RAMEN minus
DiNNO at 50 %; in the rho rows DiNNO's own runs at the same rho), Fig. 5's drop of RAMEN from 100
to 20 % success, and every RAMEN robot above every local robot at 1 %. Each claim's verdict is
*holds*, *fails* or *inconclusive* from its interval (``paper_claims.Claim.verdict``), "not run"
where no run of a trial it needs exists, and "not judged" where such runs exist but are not usable.
A trial on which the row's RAMEN run diverged (a robot marked ``diverged`` in its metrics.json by
the run's divergence rule, ``ramensim/divergence.py``: its loss 100x its running minimum, or a
non-finite map) is a failed trial, not a missing one, and the claim **fails** at that knob value
whatever the other trials give: a setting under which RAMEN's maps turn to noise does not keep it.

Bad input is named and the rest judged, as in ``tools/paper_claims.py``: a run that failed, has
no readable metrics.json, was made from other settings than its archive's plan point, or lacks a
number a rule needs is listed under "Runs not judged"; a trial whose compared runs ran on
different hosts (``ramensim.provenance.same_host``) is marked † and its runs named with their
hosts, ‡ where a run has no host record. The page opens with how many of the planned runs exist.

Exit status: 0 when at least one claim was judged on one trial; 1 when nothing could be judged
(the page is still written); 2 with one paragraph when ``--results``, ``--runs`` or ``--sweeps``
is not a folder or a sensitivity sweep file is missing or invalid.
"""
from __future__ import annotations

import argparse
import logging
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import paper_claims as pc  # a sibling tool: the claims' rules, the archives' reading, the judging

log = logging.getLogger("sensitivity_table")

REPO = Path(__file__).resolve().parents[1]
RATE = "channel.success_rate"
TABLE_RATE, FULL_RATE, LOW_RATE, LOSSY_RATE = 0.5, 1.0, 0.2, 0.01
"""Success rates: Table I's (50 %), Fig. 5's drop from 100 % to 20 %, and 1 %."""
REFERENCES, METHODS = "sensitivity_references", "sensitivity_methods"
"""The sweeps of the default RAMEN and of DiNNO, centralised and local at their defaults."""


@dataclass(frozen=True)
class Knob:
    """One knob: the scenario key RAMEN's sweep varies, and where DiNNO's paired runs are when
    DiNNO is varied with it (``dinno_sweep``, ``dinno_key``: the same values)."""
    name: str
    key: str
    sweep: str
    dinno_sweep: str | None = None
    dinno_key: str | None = None


KNOBS = (Knob("dual_step", "consensus.dual_step", "sensitivity_dual_step"),
         Knob("beta_l", "consensus.ramen.beta_l", "sensitivity_beta_l"),
         Knob("rho", "consensus.ramen.rho", "sensitivity_rho", "sensitivity_rho_dinno", "consensus.dinno.rho"))
SWEEPS = (REFERENCES, METHODS) + tuple(s for k in KNOBS for s in (k.sweep, k.dinno_sweep) if s)
"""Every sweep the page reads, by name (``name:`` of its file)."""


class Sweep:
    """One sensitivity sweep: its plan (the sweep file) and its complete runs, read from its
    archive and, if given, its run folder (:class:`paper_claims.Archive` each; the archive first)."""

    def __init__(self, plan: Any, folders: Sequence[tuple[str, Path]]) -> None:
        self.plan = plan
        self.name: str = plan.name
        self.sources = [(where, pc.Archive(folder)) for where, folder in folders if folder.is_dir()]

    def run(self, seed: int, layout: int, axes: dict[str, Any]) -> pc.RunValues | None:
        """The complete run of this trial with these axis values, from the first source that has one."""
        for _, arc in self.sources:
            got = arc.run(seed, layout, **{k.replace(".", "__"): v for k, v in axes.items()})
            if got is not None:
                return got
        return None

    def point(self, seed: int, layout: int, axes: dict[str, Any]) -> str:
        """The plan's name of the point with these settings."""
        want = {"seed": seed, "world.scene.seed": layout, **axes}
        for p in self.plan.points:
            if all(pc._same(p.axes.get(k), v) for k, v in want.items()):
                return p.name
        return "__".join(f"{k}={v}" for k, v in want.items())

    def done(self) -> dict[str, str]:
        """Each planned point with a complete run: point name -> the source it is read from."""
        out: dict[str, str] = {}
        for p in self.plan.points:
            for where, arc in self.sources:
                if any(all(pc._same(r.axes.get(k), v) for k, v in p.axes.items()) for r in arc.records):
                    out[p.name] = where
                    break
        return out

    def problems(self) -> list[tuple[str, str]]:
        """(sweep/run, why) for the runs its sources hold but that are not judged (failed, unreadable,
        other settings), leaving out points that another source has complete and points not run."""
        done = self.done()
        out: list[tuple[str, str]] = []
        for where, arc in self.sources:
            for run, why in arc.problems:
                if why != pc.NOT_RUN and run not in done:
                    out.append((f"{where}/{run}", why))
        return out

    def why_missing(self, point: str) -> str:
        """Why a planned point has no usable run: the first source's problem with it, else not run."""
        for run, why in self.problems():
            if run.rsplit("/", 1)[-1] == point:
                return why
        return "not run"


@dataclass
class Need:
    """One run a claim needs on a trial: its role (in words), its sweep and its axis values."""
    role: str
    sweep: Sweep
    axes: dict[str, Any]


@dataclass(frozen=True)
class ClaimRule:
    """One claim of the table: its column title, the shared test and rule of tools/paper_claims.py,
    and which two runs of a row it compares."""
    title: str
    test: Any
    rule: Callable[[Any, Any], tuple[float, str]]
    needs: Callable[["Row"], tuple[Need, Need]]


@dataclass
class Row:
    """One knob value (or the defaults): where its RAMEN runs and its paired references are."""
    label: str
    ramen: Sweep
    ramen_axes: dict[str, Any]
    dinno: Sweep
    dinno_axes: dict[str, Any]
    methods: Sweep
    claims: list[pc.Claim] = field(default_factory=list)
    missing: list[dict[tuple[int, int], str]] = field(default_factory=list)
    """Per claim: trial -> why it was not judged (the runs missing or not usable)."""
    missing_roles: list[dict[str, str]] = field(default_factory=list)
    """Per claim: role of a run no trial had -> "not run" or "not judged"."""
    diverged: list[dict[tuple[int, int], str]] = field(default_factory=list)
    """Per claim: trial -> which of the row's RAMEN runs diverged (:func:`diverged`): a failed trial."""
    drifting: list[dict[tuple[int, int], str]] = field(default_factory=list)
    """Per claim: trial -> which of the row's RAMEN runs it judged have maps drifting apart (:func:`drifting`)."""

    def need(self, role: str, rate: float | None = None) -> Need:
        if role == "RAMEN":
            return Need(f"RAMEN at {rate * 100:g} %", self.ramen, {**self.ramen_axes, RATE: rate})
        if role == "DiNNO":
            return Need("DiNNO", self.dinno, dict(self.dinno_axes))
        return Need(role, self.methods, {"method": role})


CLAIMS = (
    ClaimRule("Table I: gap to centralised", pc.CENTRAL_GAP, pc.central_gap,
              lambda r: (r.need("RAMEN", TABLE_RATE), r.need("centralised"))),
    ClaimRule("Table I: lead over DiNNO", pc.DINNO_LEAD, pc.dinno_lead,
              lambda r: (r.need("RAMEN", TABLE_RATE), r.need("DiNNO"))),
    ClaimRule("Fig. 5: RAMEN's drop from 100 to 20 %", pc.RAMEN_DROP, pc.completion_drop,
              lambda r: (r.need("RAMEN", FULL_RATE), r.need("RAMEN", LOW_RATE))),
    ClaimRule("At 1 %: every RAMEN robot above every local robot", pc.ABOVE_LOCAL, pc.robots_above,
              lambda r: (r.need("RAMEN", LOSSY_RATE), r.need("local"))),
)


def load_plans(sweeps: Path) -> dict[str, Any]:
    """Every sweep file under ``sweeps`` by its name; InputError naming the folder when one of
    :data:`SWEEPS` is missing (an invalid file raises plan_sweep's InputError naming it)."""
    from ramensim.core.errors import InputError
    from ramensim.sweep.spec import load_spec, plan_sweep

    if not sweeps.is_dir():
        raise InputError(f"--sweeps {sweeps} is not a folder; expected the folder of the sensitivity sweep files "
                         f"(scenarios/sweeps/sensitivity).")
    files = {}
    for path in sorted(sweeps.glob("*.yaml")):
        files.setdefault(load_spec(path).name or path.stem, path)
    lost = [s for s in SWEEPS if s not in files]
    if lost:
        raise InputError(f"--sweeps {sweeps}: no sweep file named {', '.join(lost)} (the 'name:' key); expected "
                         f"the six sensitivity sweep files of scenarios/sweeps/sensitivity ({', '.join(SWEEPS)}).")
    plans = {name: plan_sweep(files[name]) for name in SWEEPS}
    for knob in KNOBS:
        for sweep, key in ((knob.sweep, knob.key), (knob.dinno_sweep, knob.dinno_key)):
            if sweep and key not in plans[sweep].axes:
                raise InputError(f"{plans[sweep].source}: key 'axes.{key}' is missing; expected the {knob.name} "
                                 f"values this sweep varies.")
    return plans


def defaults(plans: dict[str, Any]) -> dict[str, float]:
    """The knobs' values in the default runs (the resolved scenario of the references' first point):
    dual_step, RAMEN's rho, beta_l (eq. 19's floor; rho / 1000 unless set) and DiNNO's rho."""
    from ramensim import config

    sc = config.validate(plans[REFERENCES].points[0].data, str(plans[REFERENCES].source))
    ramen = sc.consensus.ramen
    return {"consensus.dual_step": sc.consensus.dual_step, "consensus.ramen.beta_l": ramen.resolved_beta_l(),
            "consensus.ramen.rho": ramen.rho, "consensus.dinno.rho": sc.consensus.dinno.rho,
            "duration": float(sc.duration)}


def trials(plans: dict[str, Any]) -> list[tuple[int, int]]:
    """The trials (run seed, house layout) of the references' plan, in plan order."""
    out: list[tuple[int, int]] = []
    for p in plans[REFERENCES].points:
        t = (p.axes.get("seed"), p.axes.get("world.scene.seed"))
        if t not in out:
            out.append(t)
    return out


def build_rows(sweeps: dict[str, Sweep], base: dict[str, float]) -> list[Row]:
    """The default row, then each knob's values in its sweep file's order."""
    methods = sweeps[METHODS]
    label = "default (" + ", ".join(f"{k.name} {base[k.key]:g}" for k in KNOBS) + ")"
    rows = [Row(label, sweeps[REFERENCES], {}, methods, {"method": "dinno"}, methods)]
    for knob in KNOBS:
        for value in sweeps[knob.sweep].plan.axes[knob.key]:
            times = value / base[knob.key] if base.get(knob.key) else math.nan
            label = f"{knob.name} {value:g}" + (f" ({times:g}x)" if knob.name == "rho" else "")
            dinno = (sweeps[knob.dinno_sweep], {knob.dinno_key: value}) if knob.dinno_sweep else \
                (methods, {"method": "dinno"})
            rows.append(Row(label, sweeps[knob.sweep], {knob.key: value}, *dinno, methods))
    return rows


def diverged(run: pc.RunValues) -> str | None:
    """How a run's maps diverged (``k of n robots, in rounds a-b``) when its metrics.json marks a
    robot ``diverged`` (``ramensim/divergence.py``), else None."""
    agents = run.metrics.get("per_agent")
    if not isinstance(agents, dict) or not agents:
        return None
    gone = [a for a in agents.values() if isinstance(a, dict) and a.get("diverged") is True]
    if not gone:
        return None
    rounds = sorted(int(a["diverged_round"]) for a in gone if isinstance(a.get("diverged_round"), (int, float)))
    when = "" if not rounds else f", in round {rounds[0]}" if rounds[0] == rounds[-1] else \
        f", in rounds {rounds[0]}-{rounds[-1]}"
    return f"{len(gone)} of {len(agents)} robots diverged{when}"


DRIFTS = "§"
"""Mark of a claim and trial whose RAMEN run's maps drift apart (:func:`drifting`)."""


def drifting(run: pc.RunValues) -> str | None:
    """``maps drift apart (consensus error 29x its trough)`` when the run's consensus error (CE-1)
    ends at least :data:`evaluation.consensus_fall.DRIFT` times above its lowest reading after
    start-up (:func:`evaluation.consensus_fall.consensus_growth`), else None: the run is judged,
    but its numbers come from maps that stopped agreeing (not yet diverged by the run's rule)."""
    from ramensim.evaluation.consensus_fall import DRIFT, consensus_growth

    m = run.metrics
    end = m.get("sim_time_s")
    grow = consensus_growth(m.get("consensus_timeline"), "consensus_error",
                            float(end) if isinstance(end, (int, float)) else None)
    if grow is None or not grow.ratio >= DRIFT:
        return None
    return (f"maps drift apart (consensus error {grow.settled:.2g} in the last minute, {grow.ratio:.0f}x its trough "
            f"{grow.trough:.2g} at {grow.t_trough:g} s)")


def judge_row(row: Row, trial_list: Sequence[tuple[int, int]]) -> None:
    """Each claim of :data:`CLAIMS` on the row's runs, trial by trial (``paper_claims._per_trial``:
    the same per-trial values, host marks and intervals as claims.md); a trial whose RAMEN run
    diverged is kept in :attr:`Row.diverged` instead of being judged."""
    for spec in CLAIMS:
        claim = pc.Claim(f"{row.label}: {spec.title}", f"{spec.test.what} {spec.test.side} {spec.test.threshold:g}",
                         len(trial_list), [spec.test])
        missing: dict[tuple[int, int], str] = {}
        roles: dict[str, str] = {}
        gone: dict[tuple[int, int], str] = {}
        drift: dict[tuple[int, int], str] = {}

        def need(seed: int, layout: int, spec: ClaimRule = spec, missing=missing, roles=roles, gone=gone,
                 drift=drift):
            runs, lost = [], []
            for n in spec.needs(row):
                got = n.sweep.run(seed, layout, n.axes)
                if got is None:
                    point = n.sweep.point(seed, layout, n.axes)
                    why = n.sweep.why_missing(point)
                    lost.append(f"{n.role} {why} ({n.sweep.name}/{point})")
                    roles[n.role] = "not run" if why == "not run" and roles.get(n.role) != "not judged" \
                        else "not judged"
                runs.append(got)
            if lost:
                missing[(seed, layout)] = "; ".join(lost)
                return None
            own = [(n, got) for n, got in zip(spec.needs(row), runs)
                   if n.sweep is row.ramen and n.role.startswith("RAMEN")]
            broke = [f"{n.role} diverged: {how}" for n, got in own if (how := diverged(got))]
            if broke:
                gone[(seed, layout)] = "; ".join(broke)
                return None
            try:
                value, text = spec.rule(*runs)
            except pc.Unjudgeable as exc:
                missing[(seed, layout)] = f"not judged: {exc}"
                roles["a number a rule needs"] = "not judged"
                raise
            apart = [f"{n.role}: {how}" for n, got in own if (how := drifting(got))]
            if apart:
                drift[(seed, layout)] = "; ".join(apart)
                text += f"; {DRIFTS} " + "; ".join(apart)
            return (value,), text

        row.claims.append(pc._per_trial(claim, need, trial_list))
        row.missing.append(missing)
        row.missing_roles.append(roles)
        row.diverged.append(gone)
        row.drifting.append(drift)


def judge_all(results: Path, sweeps_dir: Path, runs: Path | None = None) -> tuple[list[Row], dict[str, Sweep],
                                                                                      list[tuple[int, int]], dict]:
    """Every row judged: (rows, the sweeps by name, the trials, the defaults)."""
    pc.SKIPPED.clear()
    pc.MIXED_RUNS.clear()
    plans = load_plans(sweeps_dir)
    sweeps = {}
    for name in SWEEPS:
        folders = [(_shown(results / name), results / name)] + \
            ([(_shown(runs / name), runs / name)] if runs is not None else [])
        sweeps[name] = Sweep(plans[name], folders)
    base = defaults(plans)
    trial_list = trials(plans)
    rows = build_rows(sweeps, base)
    for row in rows:
        judge_row(row, trial_list)
    return rows, sweeps, trial_list, base


def _shown(path: Path) -> str:
    """A path as the page shows it: relative to the repository when inside it."""
    try:
        return path.resolve().relative_to(REPO).as_posix()
    except ValueError:
        return path.as_posix()


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
        return f"**fails**: RAMEN diverged on {len(row.diverged[i])} of {claim.planned} trials{rest}"
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
    marks = "".join(sorted({m for label, _, _ in claim.judged for m in (pc.MIXED, pc.UNRECORDED) if m in label}))
    apart = f" {DRIFTS} (maps drift apart on {len(row.drifting[i])} of {claim.n()})" if row.drifting[i] else ""
    return f"{iv.estimate:+.2f} {span} **{claim.verdict()}**{part}{marks}{apart}"


_SIDE = {">=": "≥", ">": ">", "<=": "≤", "<": "<"}


def _header(spec: ClaimRule) -> str:
    t = spec.test
    return f"{spec.title}: {t.what} {_SIDE[t.side]} {t.threshold:g} holds"


def to_markdown(rows: Sequence[Row], sweeps: dict[str, Sweep], trial_list: Sequence[tuple[int, int]],
                base: dict[str, float], results: Path, runs: Path | None = None) -> str:
    from ramensim.evaluation.consensus_fall import DRIFT
    from ramensim.evaluation.intervals import LEVEL, t_interval

    planned = sum(len(s.plan.points) for s in sweeps.values())
    done = {name: s.done() for name, s in sweeps.items()}
    total = sum(len(d) for d in done.values())
    trials_words = ", ".join(f"run seed {s} on house layout {lay}" for s, lay in trial_list)
    command = "python tools/sensitivity_table.py --out docs/results/sensitivity.md" + \
        (f" --runs {_shown(runs)}" if runs is not None else "")
    lines = [
        "# Sensitivity of the main claims to dual_step, beta_l and rho (300 s)", "",
        f"**Runs done: {total} of {planned} planned.** Part of [the results of the paper's experiments]"
        "(../RESULTS.md); the claims at 600 s on six trials: [claims.md](paper/claims.md).", "",
        f"Made by `{command}` from the archives under `{_shown(results)}/`"
        + (f" and the sweep folders under `{_shown(runs)}/` not archived yet" if runs is not None else "")
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
        "(`tools/paper_claims.py`) and intervals (`evaluation/intervals.py`): per trial one quantity (completion, "
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
    seeds = sorted({t[0] for t in trial_list})
    if len(seeds) == 1:
        lines += ["", f"**One independent unit.** The {len(trial_list)} trials are {len(trial_list)} house layouts run "
                  f"with one run seed ({seeds[0]}): they meet the same channel realisation (the channel's draws are "
                  "keyed by run seed, link and send time: the same messages arrive on both layouts) and the same map "
                  "initialisation, so they are one unit (`evaluation/intervals.py`, eq. U-1), and no cell has an "
                  "interval: every verdict is **inconclusive** until the rows run on a second run seed. Until "
                  "2026-11-28 this page took the two layouts as two independent trials (t with one degree of freedom) "
                  "and read holds or fails where both agreed closely; the cells now give the estimate and on how many "
                  "trials the trial's own value clears the threshold, which says how the two layouts agree, not "
                  "how a second channel would fall."]
    elif len(trial_list) == 2:
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
              f"claim needs does not exist yet, \"not judged\" where it exists but is not usable (below). {pc.MIXED}: "
              f"a trial's compared runs ran on different hosts, {pc.UNRECORDED}: a run has no host record (both "
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
                    parts.append(f"{pc._label(*t)}: ✗ {row.diverged[i][t]}")
                elif t in row.missing[i]:
                    parts.append(f"{pc._label(*t)}: {row.missing[i][t]}")
                else:
                    label, ok, text = next(judged)
                    parts.append(f"{label}: {'✓' if ok else '✗'} {text}")
            lines.append(f"| {row.label} | {spec.title} | {_cell('; '.join(parts))} |")

    lines += ["", f"## Runs done: {total} of {planned} planned", "",
              "Per sweep, the runs with a complete result. To run a sweep and keep it: `ramensim sweep "
              "scenarios/sweeps/sensitivity/FILE.yaml`, then `python tools/archive_sweep.py runs/sweeps/NAME "
              "docs/results/sensitivity/NAME` and this page's command.", "",
              "| sweep | file | runs done | read from |", "|---|---|---:|---|"]
    for name, sweep in sweeps.items():
        where = sorted(set(done[name].values()))
        lines.append(f"| {name} | `{_shown(sweep.plan.source)}` | {len(done[name])} of {len(sweep.plan.points)} | "
                     f"{', '.join(f'`{w}`' for w in where) or '—'} |")

    notes = not_judged(sweeps)
    lines += ["", f"## Runs not judged: {len(notes)}", ""]
    if notes:
        lines += ["Runs that exist but are not usable, and trials a missing number kept out; every claim is judged "
                  "on the other runs.", "", "| run or trial | why |", "|---|---|"]
        lines += [f"| {_cell(what)} | {_cell(why)} |" for what, why in notes]
    else:
        lines.append("None: every run that exists is complete and has what its rules need.")
    if pc.MIXED_RUNS:
        lines += ["", f"## Trials whose compared runs ran on different hosts ({pc.MIXED}): {len(pc.MIXED_RUNS)}", "",
                  "Judged as the others: runs of two hosts differ by float rounding (docs/DESIGN.md, "
                  "\"Determinism\"). Each row: the runs one trial's rule compared, with the host each ran on "
                  "(metrics.json `build`: CPU model, SIMD level, torch device, host fingerprint).", "",
                  "| runs (host) |", "|---|"]
        lines += ["| " + _cell("; ".join(f"{w} ({m})" for w, m in runs)) + " |" for runs in pc.MIXED_RUNS]
    return "\n".join(lines) + "\n"


def not_judged(sweeps: dict[str, Sweep]) -> list[tuple[str, str]]:
    """(run or claim and trial, why) for every run that exists but is not usable, and every trial a
    run's missing number kept out (``paper_claims.SKIPPED``, filled while judging)."""
    out = [p for s in sweeps.values() for p in s.problems()]
    return out + list(pc.SKIPPED)


def main(argv: Sequence[str] | None = None) -> int:
    from ramensim.core.errors import InputError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=REPO / "docs" / "results" / "sensitivity",
                    help="the folder holding the archived sensitivity sweeps (default: docs/results/sensitivity)")
    ap.add_argument("--runs", type=Path, default=None,
                    help="also read the sweep folders DIR/<sweep name> not archived yet (e.g. runs/sweeps)")
    ap.add_argument("--sweeps", type=Path, default=REPO / "scenarios" / "sweeps" / "sensitivity",
                    help="the folder of the sensitivity sweep files (default: scenarios/sweeps/sensitivity)")
    ap.add_argument("--out", type=Path, default=None, help="write the page here (default: stdout)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    for flag, folder in (("--results", args.results), ("--runs", args.runs)):
        if folder is not None and not folder.is_dir():
            log.error("sensitivity_table: %s %s is not a folder; expected the folder holding the sensitivity sweep "
                      "folders (sensitivity_references/, sensitivity_dual_step/, ...), e.g. %s.", flag, folder,
                      "docs/results/sensitivity" if flag == "--results" else "runs/sweeps")
            return 2
    try:
        rows, sweeps, trial_list, base = judge_all(args.results, args.sweeps, args.runs)
        text = to_markdown(rows, sweeps, trial_list, base, args.results, args.runs)
    except InputError as exc:
        log.error("sensitivity_table: %s", exc)
        return 2
    for what, why in not_judged(sweeps):
        log.warning("sensitivity_table: not judged: %s: %s", what, why)
    if args.out is None:
        sys.stdout.write(text)
    else:
        args.out.write_text(text, encoding="utf-8")
    if not any(c.samples for row in rows for c in row.claims):
        log.error("sensitivity_table: nothing judged: no claim has a trial with every run it needs (the page lists "
                  "the runs done and lacking)")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
