"""The spread claims: RAMEN's standard deviation of completion against DiNNO's (points), pooled over
every robot of every trial as the paper's tables pool it (a bootstrap over whole units), and read
within a run (the paper ran one sequence per scene; t over the units), with where each method's
spread comes from."""
from __future__ import annotations

from statistics import fmean, pstdev
from typing import Any, Sequence

from ramensim.paper.archive import RunValues
from ramensim.paper.rules import Claim, Test
from ramensim.paper.trials import Judging

def pooled_std(judging: Judging, name: str, rule: str, pairs: list[tuple[list[float], list[float]]], planned: int,
               units: Sequence[Any], used: Sequence[RunValues] = (),
               labels: tuple[str, str] = ("RAMEN", "DiNNO")) -> Claim:
    """The spread claim pooled, as the paper's tables pool it: the population std of completion
    over every robot of every trial in ``pairs`` (per trial: the first method's robots, the
    second's), first minus second (points), judged by a bootstrap over whole units (``units``:
    each pair's run seed); ``≤`` or ``<`` as ``name`` says. ``used``: the runs compared (their hosts
    are marked, :meth:`Judging.note_hosts`)."""
    c = Claim(name, rule, planned, [Test(f"{labels[0]} std − {labels[1]} std (points)", 0.0,
                                         "<=" if "≤" in name else "<", "pooled std")])
    if pairs:
        a = [x for p in pairs for x in p[0]]
        b = [x for p in pairs for x in p[1]]
        sa, sb = pstdev(a), pstdev(b)
        c.pooled = f"{len(pairs)} trial{'s' if len(pairs) > 1 else ''} run"
        c.samples = [(p,) for p in pairs]
        c.units = list(units)
        marks = judging.note_hosts(list(used))
        c.judged.append((f"{len(pairs)} trials pooled{marks}", sa <= sb if "≤" in name else sa < sb,
                         f"{labels[0]} {fmean(a):.1f} ± {sa:.2f}, {labels[1]} {fmean(b):.1f} ± {sb:.2f}"))
    return c


def within_run_std(name: str, pairs: list[tuple[list[float], list[float]]], planned: int,
                   units: Sequence[Any], labels: Sequence[str] = ()) -> Claim:
    """The spread claim read within a run (the paper ran one sequence per scene): per trial, the
    population std of RAMEN's robots' completion minus DiNNO's (points), t over the units."""
    c = Claim(name, "per trial, population std of completion over the run's robots: RAMEN's minus DiNNO's",
              planned, [Test("RAMEN std − DiNNO std within a run (points)", 0.0, "<=" if "≤" in name else "<")])
    for i, ((a, b), u) in enumerate(zip(pairs, units)):
        d = pstdev(a) - pstdev(b)
        c.samples.append((d,))
        c.units.append(u)
        c.judged.append((labels[i] if i < len(labels) else f"seed {u}", c.tests[0].clears(d), f"RAMEN {pstdev(a):.2f} vs DiNNO {pstdev(b):.2f} "
                                                            f"({d:+.2f})"))
    return c


def _spread_cause(pairs: list[tuple[list[float], list[float]]]) -> str:
    """Where each method's spread comes from: between trials (std of the trial means) and within
    a trial (mean over trials of the std over its robots), points."""
    def parts(i: int) -> tuple[float, float]:
        return pstdev([fmean(p[i]) for p in pairs]), fmean([pstdev(p[i]) for p in pairs])
    (rb, rw), (db, dw) = parts(0), parts(1)
    return f"between trials {rb:.2f} vs {db:.2f}, within a trial {rw:.2f} vs {dw:.2f}"


def std_cause(c: Claim, pairs: list[tuple[list[float], list[float]]]) -> str:
    """The difference of the pooled stds, whether it is inside the noise, and where each method's
    spread comes from (:func:`_spread_cause`)."""
    noise = ", inside the trial-to-trial noise" if c.verdict() == "inconclusive" else ""
    return (f"RAMEN − DiNNO {c.intervals()[0].estimate:+.2f} points{noise}; RAMEN vs DiNNO "
            f"{_spread_cause(pairs)} points")
