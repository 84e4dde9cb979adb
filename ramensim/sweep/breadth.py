"""Table I's three comparisons and Fig. 5's drop judged beyond one house (issue 68, item 2): per
scene family and pooled, with the layouts as independent units.

A *breadth sweep* (``scenarios/sweeps/evidence/*.yaml``) gives each layout its own run seed
(the sweep file's ``trials``) and runs, per trial, the variants ``ramen``, ``dinno``, ``local``
and ``centralised`` at 50 % success and ``ramen_20``, ``dinno_20``, ``ramen_100``,
``dinno_100`` at 20 % and 100 %. Per trial each claim reads one quantity from the runs' team
means (a run's mean over its robots' finite completion ratios, %; differences in points):

- Table I, RAMEN within 5 points of centralised: RAMEN − centralised ≥ −5;
- Table I, RAMEN ≥ local + 15: RAMEN − local ≥ 15;
- Table I, DiNNO below RAMEN: RAMEN − DiNNO > 0;
- Fig. 5, RAMEN loses ≤ 5 points from 100 to 20 %, less than DiNNO: RAMEN's drop ≤ 5 and
  DiNNO's drop − RAMEN's > 0 (both must hold).

The thresholds are the project's readings of the paper's words (claims.md uses the same). Over
the units (eq. U-1 of :mod:`ramensim.evaluation.intervals`: trials sharing a run seed averaged
first) each quantity gets its 95 % Student t interval and the three-way verdict of
:func:`ramensim.evaluation.intervals.verdict`. A trial is judged once every run its rule needs
is complete; a missing or failed run is named, never raised on. The *family* of a sweep is read
from its runs' resolved ``scenario.yaml``: the scene's name, plus "noisy sensor" where the
camera's sensor adds depth or colour noise.

A run made with the paper's update as written (``consensus.preset: paper``, e.g.
``scenarios/sweeps/evidence/house_paper_update.yaml``, issue 68 item 3) counts as variant
``NAME@paper`` of its trial: the claims are judged again with RAMEN's and DiNNO's runs of the
paper's update in place of the project's (local and centralised, which run no consensus, are the
trial's own), and :func:`paper_update_section` sets each such run beside the project's run of the
same trial, method and rate (common random numbers: only the update differs).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from ramensim.evaluation.intervals import Interval, combine, nest, t_interval, verdict
from ramensim.evaluation.summary import finite_mean
from ramensim.sweep.breadth_names import PAPER, method_label, rate_of
log = logging.getLogger(__name__)

COMPLETION = "completion_ratio_pct"

@dataclass(frozen=True)
class Rule:
    """One comparison: the quantity's name (with its unit), its threshold and side."""
    what: str
    threshold: float
    side: str

    def clears(self, x: float) -> bool:
        """Whether one trial's value is on the rule's side of its threshold (the per-trial ✓)."""
        t = self.threshold
        return {">=": x >= t, ">": x > t, "<=": x <= t, "<": x < t}[self.side]


@dataclass(frozen=True)
class ClaimSpec:
    """A claim: its name (claims.md's words), the variants it reads and its rules; ``value``
    maps the trial's team means (variant -> %) to one number per rule."""
    name: str
    needs: tuple[str, ...]
    rules: tuple[Rule, ...]
    value: Callable[[Mapping[str, float]], tuple[float, ...]]


CLAIMS = (
    ClaimSpec("Table I: RAMEN within 5 points of centralised", ("ramen", "centralised"),
              (Rule("RAMEN − centralised (points)", -5.0, ">="),), lambda m: (m["ramen"] - m["centralised"],)),
    ClaimSpec("Table I: RAMEN ≥ local + 15", ("ramen", "local"),
              (Rule("RAMEN − local (points)", 15.0, ">="),), lambda m: (m["ramen"] - m["local"],)),
    ClaimSpec("Table I: DiNNO below RAMEN", ("ramen", "dinno"),
              (Rule("RAMEN − DiNNO (points)", 0.0, ">"),), lambda m: (m["ramen"] - m["dinno"],)),
    ClaimSpec("Fig. 5: RAMEN loses ≤ 5 points from 100 to 20 %, less than DiNNO",
              ("ramen_100", "ramen_20", "dinno_100", "dinno_20"),
              (Rule("RAMEN's drop (points)", 5.0, "<="), Rule("DiNNO's drop − RAMEN's (points)", 0.0, ">")),
              lambda m: (m["ramen_100"] - m["ramen_20"],
                         (m["dinno_100"] - m["dinno_20"]) - (m["ramen_100"] - m["ramen_20"]))),
)
"""The claims judged, in the order the page lists them."""


def _paper_claim(c: ClaimSpec) -> ClaimSpec:
    """``c`` judged with the paper's update: its RAMEN and DiNNO variants read from ``NAME@paper``."""
    swap = {v: v + PAPER for v in c.needs if v.startswith(("ramen", "dinno"))}
    return ClaimSpec(f"{c.name} — the paper's update", tuple(swap.get(v, v) for v in c.needs), c.rules,
                     lambda m, c=c, swap=swap: c.value({**m, **{v: m[p] for v, p in swap.items()}}))


PAPER_CLAIMS = tuple(_paper_claim(c) for c in CLAIMS)
"""The same claims with RAMEN's and DiNNO's runs of the paper's update (judged where such runs exist)."""


@dataclass
class Trial:
    """One trial of a breadth sweep: its family, run seed (the unit), layout and team means."""
    family: str
    seed: Any
    layout: Any
    means: dict[str, float] = field(default_factory=dict)
    """Variant -> team mean completion (%) of its complete run."""
    robots: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    """Variant (ramen, local) -> per robot (completion %, own coverage %: the share of the team's
    seen surface its own cameras saw), from the run's metrics.json."""


@dataclass
class Judged:
    """One claim over a set of trials: per trial its values, per rule the interval over units."""
    claim: ClaimSpec
    scope: str
    trials: list[tuple[Trial, tuple[float, ...]]] = field(default_factory=list)

    def units(self) -> list[Any]:
        return [(t.family, t.seed) for t, _ in self.trials]

    def intervals(self) -> list[Interval]:
        return [t_interval(nest([v[i] for _, v in self.trials], self.units()))
                for i in range(len(self.claim.rules))]

    def verdict(self) -> str:
        if not self.trials:
            return "no run yet"
        return combine([verdict(iv, r.threshold, r.side) for r, iv in zip(self.claim.rules, self.intervals())])

    def n_units(self) -> int:
        return len(dict.fromkeys(self.units()))


def family_of(scenario: Mapping[str, Any]) -> str:
    """A run's scene family in words: the scene's name (or kind), plus "noisy sensor" where its
    camera's sensor adds depth or colour noise."""
    world = scenario.get("world") or {}
    scene = world.get("scene") or {}
    name = str(scene.get("name") or scene.get("kind") or "scene")
    sensor = (world.get("camera") or {}).get("sensor") or {}
    noisy = any(float(sensor.get(k) or 0.0) > 0.0 for k in ("depth_noise_a", "depth_noise_b", "color_noise"))
    return f"{name}, noisy sensor" if noisy else name


def load_trials(folder: str | Path, notes: list[tuple[str, str]]) -> list[Trial]:
    """The trials of one breadth sweep folder (an archive or ``ramensim sweep``'s ``--out``):
    per (run seed, layout) the team means of its complete runs by variant; runs not complete are
    named in ``notes``."""
    import yaml

    from ramensim.sweep import store
    from ramensim.sweep.aggregate import load_runs

    root = Path(folder)
    _, records = load_runs(root)
    trials: dict[tuple[Any, Any], Trial] = {}
    for r in records:
        variant = r.axes.get("variant")
        if variant is None:
            notes.append((f"{root.name}/{r.name}", "no 'variant' axis: not a breadth sweep's run"))
            continue
        if r.status not in store.COMPLETE:
            notes.append((f"{root.name}/{r.name}", f"status {r.status!r}" + (f": {r.error}" if r.error else "")))
            continue
        mean = finite_mean(r.values.get(COMPLETION))
        if not math.isfinite(mean):
            notes.append((f"{root.name}/{r.name}", f"no finite {COMPLETION} in its metrics.json"))
            continue
        path = root / store.RUNS / r.name / "scenario.yaml"
        try:
            scenario = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
        except (OSError, yaml.YAMLError) as exc:
            notes.append((f"{root.name}/{r.name}", f"unreadable scenario.yaml ({exc}); not judged"))
            continue
        key = (family_of(scenario), r.axes.get("seed"), r.axes.get("world.scene.seed"))
        if key not in trials:
            trials[key] = Trial(key[0], key[1], key[2])
        if ((scenario.get("consensus") or {}).get("preset")) == "paper":
            variant = f"{variant}{PAPER}"
        trials[key].means[str(variant)] = mean
        if variant in ("ramen", "local"):
            trials[key].robots[str(variant)] = _robots(root / store.RUNS / r.name / "metrics.json")
    return list(trials.values())


def merge_trials(trials: Sequence[Trial]) -> list[Trial]:
    """One trial per (family, run seed, layout) from several folders' (e.g. the runs of the paper's
    update archived apart from the project's): their runs' variants together, in first-seen order;
    a variant two folders both ran keeps the first folder's run."""
    out: dict[tuple[Any, Any, Any], Trial] = {}
    for t in trials:
        key = (t.family, t.seed, t.layout)
        if key not in out:
            out[key] = Trial(t.family, t.seed, t.layout)
        for v, x in t.means.items():
            out[key].means.setdefault(v, x)
        for v, rows in t.robots.items():
            out[key].robots.setdefault(v, rows)
    return list(out.values())


def _robots(path: Path) -> list[tuple[float, float]]:
    """Per robot of a run (metrics.json's per_agent order): completion (%) and own coverage (%),
    NaN where missing or unreadable."""
    import json

    try:
        per = json.loads(path.read_text(encoding="utf-8")).get("per_agent") or {}
    except (OSError, ValueError):
        return []

    def num(x: Any) -> float:
        return float(x) if isinstance(x, (int, float)) else math.nan

    return [(num(a.get(COMPLETION)), num(a.get("own_coverage_pct"))) for a in per.values()]


def gain_vs_own_coverage(trials: Sequence[Trial]) -> list[str]:
    """The page's section on what RAMEN's gain over a robot alone depends on: per robot, RAMEN's
    completion minus its local run's (points) against its own coverage (%, the same poses in both
    runs), per family and over all: the ranges, Pearson's r and the least-squares line."""
    import numpy as np

    rows: dict[str, list[tuple[float, float]]] = {}
    for t in trials:
        ramen, local = t.robots.get("ramen") or [], t.robots.get("local") or []
        for (cr, own), (cl, _) in zip(ramen, local):
            if all(math.isfinite(x) for x in (cr, own, cl)):
                rows.setdefault(t.family, []).append((own, cr - cl))
    if not rows:
        return []
    scopes = list(rows.items())
    if len(rows) > 1:
        scopes.append(("all families pooled", [x for v in rows.values() for x in v]))
    lines = ["", "## RAMEN's gain over a robot alone against what the robot sees alone", "",
             "Per robot: its completion with RAMEN minus its completion alone (`local`) in the same trial "
             "(points), against its own coverage in the RAMEN run (the share of the team's seen surface its own "
             "cameras saw, %; the same poses in both runs): does a robot that sees more alone gain less from its "
             "teammates? A negative r says so across these robots and layouts; an association, not an "
             "intervention.", "",
             "| scenes | robots | own coverage (%) | gain (points) | Pearson r | least squares: gain = a + b x own |",
             "|---|---|---|---|---|---|"]
    for scope, pts in scopes:
        a = np.asarray(pts, dtype=np.float64)
        if len(a) >= 3 and np.ptp(a[:, 0]) > 0 and np.ptp(a[:, 1]) > 0:
            r = f"{np.corrcoef(a[:, 0], a[:, 1])[0, 1]:+.2f}"
            slope, icpt = np.polyfit(a[:, 0], a[:, 1], 1)
            fit = f"{icpt:+.2f} {slope:+.3f} x own"
        else:
            r, fit = "—", "—"
        lines.append(f"| {scope} | {len(a)} | {a[:, 0].min():.1f}-{a[:, 0].max():.1f} | "
                     f"{a[:, 1].min():+.2f} to {a[:, 1].max():+.2f} | {r} | {fit} |")
    return lines


def judge(trials: Sequence[Trial]) -> list[Judged]:
    """Every claim per family (in the order families first appear) and pooled over all."""
    families = list(dict.fromkeys(t.family for t in trials))
    scopes = [(f, [t for t in trials if t.family == f]) for f in families]
    if len(families) > 1:
        scopes.append(("all families pooled", list(trials)))
    out = []
    paper = any(v.endswith(PAPER) for t in trials for v in t.means)
    for claim in CLAIMS + (PAPER_CLAIMS if paper else ()):
        for scope, members in scopes:
            j = Judged(claim, scope)
            for t in members:
                if all(v in t.means for v in claim.needs):
                    j.trials.append((t, claim.value(t.means)))
            out.append(j)
    return out


def paper_update_section(trials: Sequence[Trial]) -> list[str]:
    """The page's section on the paper's update as written beside the project's: per family,
    method and rate, the team mean completion (%) of both updates over the trials that ran both
    (the same trial: its run seed, layout, channel and start), their difference paper − project
    (points) with its 95 % t interval over units, and per trial the difference. Empty without
    runs of the paper's update."""
    pairs: dict[tuple[str, str], list[tuple[Trial, float, float]]] = {}
    for t in trials:
        for v, x in t.means.items():
            if v.endswith(PAPER) and v[:-len(PAPER)] in t.means:
                pairs.setdefault((t.family, v[:-len(PAPER)]), []).append((t, t.means[v[:-len(PAPER)]], x))
    if not pairs:
        return []
    lines = ["", "## The paper's update as written beside the project's", "",
             "Per trial the same run twice but for the C-ADMM update: the project's (`consensus.preset: ramensim`: "
             "a proximal primal step, an antisymmetric per-link dual, dual step 0.2) and the paper's as written "
             "(`preset: paper`: joint primal gradient, node dual, dual step 1), with the same run seed, layout, "
             "channel realisation and start. Team mean completion (%) over the trials that ran both, and the "
             "difference paper − project (points) with its 95 % t interval over units.", "",
             "| scenes | method, success rate | units | project's update (%) | paper's update (%) | "
             "paper − project [95 % interval] | per trial |", "|---|---|---|---|---|---|---|"]
    for (family, variant), rows in sorted(pairs.items(), key=lambda kv: (kv[0][0], kv[0][1].partition("_")[0],
                                                                         -rate_of(kv[0][1]))):
        units = [(t.family, t.seed) for t, _, _ in rows]
        iv = t_interval(nest([p - q for _, q, p in rows], units))
        span = _span(iv)
        method = method_label(variant)
        per = "; ".join(f"layout {t.layout}: {p - q:+.2f}" for t, q, p in rows)
        lines.append(f"| {family} | {method}, {rate_of(variant):g} % | {len(dict.fromkeys(units))} | "
                     f"{sum(q for _, q, _ in rows) / len(rows):.2f} | {sum(p for _, _, p in rows) / len(rows):.2f} | "
                     f"{iv.estimate:+.2f}{span} | {per} |")
    return lines


def _span(iv: Interval) -> str:
    """An interval's bounds as the page prints them after its estimate."""
    return f" [{iv.lo:+.2f}, {iv.hi:+.2f}]" if iv.defined else " (no interval: one unit)"


def _cell(ivs: Sequence[Interval], rules: Sequence[Rule]) -> str:
    """The estimate and interval of each rule, with its threshold (points)."""
    parts = []
    for r, iv in zip(rules, ivs):
        span = _span(iv)
        parts.append(f"{r.what}: {iv.estimate:+.2f}{span}, {r.side} {r.threshold:g} to hold")
    return "; ".join(parts)


def markdown(judged: Sequence[Judged], folders: Sequence[Path], notes: Sequence[tuple[str, str]],
             command: str, extra: Sequence[str] = ()) -> str:
    """The breadth page: what was judged and how, one row per claim and family, the per-trial
    numbers, and the runs not judged."""
    lines = ["# Beyond one house: Table I and Fig. 5 on new layouts, a second scene family and a noisy sensor",
             "", f"Made by `{command}` from " + ", ".join(f"`{f.as_posix()}`" for f in folders) + ". Each layout "
             "is its own independent unit: it ran with its own run seed (the sweep file's `trials`), so it met "
             "its own channel realisation, and the runs compared within it share common random numbers. Per "
             "trial the claim's quantity from the runs' team means (completion, %; differences in points); over "
             "the units its 95 % Student t interval (`evaluation/intervals.py`); **holds** when the interval "
             "clears the threshold, **fails** when it lies wholly on the wrong side, **inconclusive** when it "
             "straddles it or there is one unit. The thresholds are the project's readings of the paper's words, "
             "as in [claims.md](paper/claims.md). 300 simulated s at 0.05 m/s, final evaluation only; the "
             "project's C-ADMM update (`consensus.preset: ramensim`), except in the rows marked \"the paper's update\" "
             "(`preset: paper`, RAMEN's and DiNNO's runs; local and centralised run no consensus and are the trial's "
             "own).", "",
             "| claim | scenes | units | estimate [95 % interval over units] | verdict | per trial (✓: clears) |",
             "|---|---|---|---|---|---|"]
    for j in judged:
        ivs = j.intervals() if j.trials else []
        est = _cell(ivs, j.claim.rules) if j.trials else "—"
        per = "; ".join(
            f"seed {t.seed}, layout {t.layout}: {'✓' if all(r.clears(x) for r, x in zip(j.claim.rules, v)) else '✗'} "
            + " / ".join(f"{x:+.2f}" for x in v) for t, v in j.trials) or "—"
        lines.append(f"| {j.claim.name} | {j.scope} | {j.n_units()} | {est} | **{j.verdict()}** | {per} |")
    lines += list(extra)
    lines += ["", f"## Runs not judged: {len(notes)}", ""]
    if notes:
        lines += ["| run | why |", "|---|---|"] + [f"| {w} | {why} |" for w, why in notes]
    else:
        lines.append("None: every run in these folders is complete.")
    return "\n".join(lines) + "\n"



def report(folders: Sequence[str | Path], command: str = "ramensim breadth", figures: str | Path | None = None,
           page_dir: str | Path | None = None) -> tuple[str, list[Judged]]:
    """Load, judge and write the page for the breadth sweep ``folders`` (see the module docstring);
    with ``figures`` (a folder) also the figures of :func:`ramensim.sweep.breadth_figure.rate_figures`
    there, shown on the page by links relative to ``page_dir`` (default: ``figures``)."""
    notes: list[tuple[str, str]] = []
    trials: list[Trial] = []
    paths = [Path(f) for f in folders]
    for p in paths:
        trials += load_trials(p, notes)
    trials = merge_trials(trials)
    judged = judge(trials)
    extra = paper_update_section(trials)
    if figures is not None:
        from ramensim.sweep.breadth_figure import caption_lines, rate_figures

        drawn = rate_figures(trials, Path(figures))
        extra += caption_lines(drawn, Path(page_dir if page_dir is not None else figures))
    return markdown(judged, paths, notes, command, extra + gain_vs_own_coverage(trials)), judged
