"""Fig. 1's claims: with two robots, every RAMEN robot at least local + 15 and within 5 points of
centralised, its completion of what only its teammate saw at least 70 %, and every DiNNO robot
below every RAMEN robot; completion in %, differences in points, on the archive ``paper_fig1``."""
from __future__ import annotations

from typing import Any, Callable, Sequence

from ramensim.paper.archive import Archive, RunValues
from ramensim.paper.rules import TRIALS, UNSEEN, Claim, Test, pairs_min, per_robot, robots, robots_above
from ramensim.paper.trials import Judging


def fig1_claims(judging: Judging, f1: Archive) -> list[Claim]:
    """Fig. 1's claims on ``f1`` (``paper_fig1``: RAMEN, local, centralised and DiNNO per trial);
    a trial is judged once all four runs are done."""
    per_trial = judging.per_trial

    def judge(rule: Callable[[RunValues, RunValues, RunValues, RunValues], tuple[Sequence[Any], str]]):
        def inner(s: int, l: int):
            got = [f1.run(s, l, method=m) for m in ("ramen", "local", "centralised", "dinno")]
            return None if any(g is None for g in got) else rule(*got)
        return inner

    def above_local(r, lo, c, d):
        gap, text = robots_above(r, lo)
        return (gap,), text

    def near_central(r, lo, c, d):
        gap = min(robots(r)) - robots(c)[0]
        return (gap,), f"{per_robot(robots(r))} vs {robots(c)[0]:.1f} ({gap:+.1f})"

    def unseen(r, lo, c, d):
        return (min(robots(r, UNSEEN)),), per_robot(robots(r, UNSEEN))

    def dinno_below(r, lo, c, d):
        gap = pairs_min(robots(r), robots(d))
        return (gap,), f"DiNNO {per_robot(robots(d))}, every robot ≥ {gap:.1f} below"

    n = len(TRIALS)
    return [
        per_trial(Claim("Fig. 1: every robot ≥ local + 15", "each RAMEN robot ≥ each local robot + 15", n,
                        [Test("smallest RAMEN robot − largest local robot (points)", 15.0, ">=")]),
                  judge(above_local)),
        per_trial(Claim("Fig. 1: every robot within 5 of centralised", "each RAMEN robot ≥ centralised - 5", n,
                        [Test("smallest RAMEN robot − centralised (points)", -5.0, ">=")]), judge(near_central)),
        per_trial(Claim("Fig. 1: unseen-part completion ≥ 70 %", "each RAMEN robot's completion on what only its "
                        "teammate saw ≥ 70 %", n, [Test("smallest RAMEN robot's unseen-part completion (%)", 70.0,
                                                         ">=")]), judge(unseen)),
        per_trial(Claim("Fig. 1: DiNNO clearly below RAMEN", "each DiNNO robot below each RAMEN robot (the "
                        "margin is shown)", n, [Test("smallest RAMEN robot − largest DiNNO robot (points)", 0.0,
                                                     ">")]), judge(dinno_below)),
    ]
