"""Which of the paper's main claims survive which knob of the reproduced RAMEN (issue 56, item 4);
the page: :mod:`ramensim.paper.sensitivity_page`.

    ramensim sensitivity --out docs/results/sensitivity.md
    ramensim sensitivity --runs runs/sweeps      # also the sweeps not archived yet -> stdout

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
with the rules, thresholds and intervals of docs/results/paper/claims.md (:mod:`ramensim.paper.rules`:
:data:`~ramensim.paper.rules.CENTRAL_GAP` and :func:`~ramensim.paper.rules.central_gap`, ``DINNO_LEAD`` /
``dinno_lead``, ``RAMEN_DROP`` / ``completion_drop``, ``ABOVE_LOCAL`` / ``robots_above``; paired
95 % Student t intervals over the trials, ``evaluation/intervals.py``): Table I's gap to
centralised (RAMEN at 50 % success minus centralised), Table I's lead over DiNNO (RAMEN minus
DiNNO at 50 %; in the rho rows DiNNO's own runs at the same rho), Fig. 5's drop of RAMEN from 100
to 20 % success, and every RAMEN robot above every local robot at 1 %. Each claim's verdict is
*holds*, *fails* or *inconclusive* from its interval (:meth:`ramensim.paper.rules.Claim.verdict`), "not run"
where no run of a trial it needs exists, and "not judged" where such runs exist but are not usable.
A trial on which the row's RAMEN run diverged (a robot marked ``diverged`` in its metrics.json by
the run's divergence rule, ``ramensim/divergence.py``: its loss 100x its running minimum, or a
non-finite map) is a failed trial, not a missing one, and the claim **fails** at that knob value
whatever the other trials give: a setting under which RAMEN's maps turn to noise does not keep it.

Bad input is named and the rest judged, as in ``ramensim claims``: a run that failed, has
no readable metrics.json, was made from other settings than its archive's plan point, or lacks a
number a rule needs is listed under "Runs not judged"; a trial whose compared runs ran on
different hosts (``ramensim.provenance.same_host``) is marked † and its runs named with their
hosts, ‡ where a run has no host record. The page opens with how many of the planned runs exist.

Exit status: 0 when at least one claim was judged on one trial; 1 when nothing could be judged
(the page is still written); 2 with one paragraph when ``--results``, ``--runs`` or ``--sweeps``
is not a folder or a sensitivity sweep file is missing or invalid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from ramensim.paper.archive import NOT_RUN, RunValues, same
from ramensim.paper.rules import (ABOVE_LOCAL, CENTRAL_GAP, DINNO_LEAD, RAMEN_DROP, Claim, Unjudgeable, central_gap,
                                  completion_drop, dinno_lead, robots_above)
from ramensim.paper.trials import Judging

REPO = Path(__file__).resolve().parents[2]
"""The repository (an editable install's source tree): the pages show paths inside it relative to it."""
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
    archive and, if given, its run folder (:class:`ramensim.paper.archive.Archive` each, read in
    the judging pass ``judging``; the archive first)."""

    def __init__(self, plan: Any, folders: Sequence[tuple[str, Path]], judging: Judging) -> None:
        self.plan = plan
        self.name: str = plan.name
        self.judging = judging
        self.sources = [(where, judging.archive(folder)) for where, folder in folders if folder.is_dir()]

    def run(self, seed: int, layout: int, axes: dict[str, Any]) -> RunValues | None:
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
            if all(same(p.axes.get(k), v) for k, v in want.items()):
                return p.name
        return "__".join(f"{k}={v}" for k, v in want.items())

    def done(self) -> dict[str, str]:
        """Each planned point with a complete run: point name -> the source it is read from."""
        out: dict[str, str] = {}
        for p in self.plan.points:
            for where, arc in self.sources:
                if any(all(same(r.axes.get(k), v) for k, v in p.axes.items()) for r in arc.records):
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
                if why != NOT_RUN and run not in done:
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
    """One claim of the table: its column title, the shared test and rule of
    :mod:`ramensim.paper.rules`, and which two runs of a row it compares."""
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
    claims: list[Claim] = field(default_factory=list)
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
    ClaimRule("Table I: gap to centralised", CENTRAL_GAP, central_gap,
              lambda r: (r.need("RAMEN", TABLE_RATE), r.need("centralised"))),
    ClaimRule("Table I: lead over DiNNO", DINNO_LEAD, dinno_lead,
              lambda r: (r.need("RAMEN", TABLE_RATE), r.need("DiNNO"))),
    ClaimRule("Fig. 5: RAMEN's drop from 100 to 20 %", RAMEN_DROP, completion_drop,
              lambda r: (r.need("RAMEN", FULL_RATE), r.need("RAMEN", LOW_RATE))),
    ClaimRule("At 1 %: every RAMEN robot above every local robot", ABOVE_LOCAL, robots_above,
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


def diverged(run: RunValues) -> str | None:
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


def drifting(run: RunValues) -> str | None:
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


def judge_row(judging: Judging, row: Row, trial_list: Sequence[tuple[int, int]]) -> None:
    """Each claim of :data:`CLAIMS` on the row's runs, trial by trial (:meth:`Judging.per_trial
    <ramensim.paper.trials.Judging.per_trial>`: the same per-trial values, host marks and intervals
    as claims.md); a trial whose RAMEN run diverged is kept in :attr:`Row.diverged` instead of
    being judged."""
    for spec in CLAIMS:
        claim = Claim(f"{row.label}: {spec.title}", f"{spec.test.what} {spec.test.side} {spec.test.threshold:g}",
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
            except Unjudgeable as exc:
                missing[(seed, layout)] = f"not judged: {exc}"
                roles["a number a rule needs"] = "not judged"
                raise
            apart = [f"{n.role}: {how}" for n, got in own if (how := drifting(got))]
            if apart:
                drift[(seed, layout)] = "; ".join(apart)
                text += f"; {DRIFTS} " + "; ".join(apart)
            return (value,), text

        row.claims.append(judging.per_trial(claim, need, trial_list))
        row.missing.append(missing)
        row.missing_roles.append(roles)
        row.diverged.append(gone)
        row.drifting.append(drift)


def judge_all(results: Path, sweeps_dir: Path, runs: Path | None = None) -> tuple[list[Row], dict[str, Sweep],
                                                                                      list[tuple[int, int]], dict]:
    """Every row judged, in one judging pass (each sweep's :attr:`Sweep.judging`, whose notes the
    page reads: :func:`judging_of`): (rows, the sweeps by name, the trials, the defaults)."""
    judging = Judging()
    plans = load_plans(sweeps_dir)
    sweeps = {}
    for name in SWEEPS:
        folders = [(shown(results / name), results / name)] + \
            ([(shown(runs / name), runs / name)] if runs is not None else [])
        sweeps[name] = Sweep(plans[name], folders, judging)
    base = defaults(plans)
    trial_list = trials(plans)
    rows = build_rows(sweeps, base)
    for row in rows:
        judge_row(judging, row, trial_list)
    return rows, sweeps, trial_list, base


def judging_of(sweeps: dict[str, Sweep]) -> Judging:
    """The judging pass :func:`judge_all` read ``sweeps`` in (one for all of them): its runs not
    judged for a missing number and its trials on different hosts go on the page."""
    (judging,) = {id(s.judging): s.judging for s in sweeps.values()}.values()
    return judging


def shown(path: Path) -> str:
    """A path as the page shows it: relative to the repository when inside it."""
    try:
        return path.resolve().relative_to(REPO).as_posix()
    except ValueError:
        return path.as_posix()

