"""Fig. 5's claims: RAMEN's drop from 100 to 20 % success (at most 5 points, less than DiNNO's),
every RAMEN robot above every local robot at 1 %, RAMEN's spread against DiNNO's at each success
rate, and (issue 25 item 5, beyond the paper) RAMEN at 5 % and 1 % against DiNNO, the paper's update
and local; completion in %, differences in points, on the archives ``paper_fig5``,
``paper_fig5_paper_update`` and Table I's local runs."""
from __future__ import annotations

from ramensim.paper.archive import Archive
from ramensim.paper.rules import (ABOVE_LOCAL, RAMEN_DROP, RATES, TRIALS, Claim, Test, Unjudgeable, completion_drop,
                                  label, robots, robots_above, team)
from ramensim.paper.spread import pooled_std, std_cause, within_run_std
from ramensim.paper.trials import Judging, host_marks


def fig5_claims(judging: Judging, f5: Archive, t1: Archive) -> list[Claim]:
    """Fig. 5's claims on ``f5`` (``paper_fig5``: RAMEN and DiNNO at each of :data:`RATES`), with
    Table I's local run of each trial (``t1``) for the 1 % claim."""
    per_trial = judging.per_trial

    def drop(s: int, l: int):
        got = [f5.run(s, l, method=m, channel__success_rate=p) for m in ("ramen", "dinno") for p in (1.0, 0.2)]
        if any(g is None for g in got):
            return None
        (dr, ramen), (dd, dinno) = completion_drop(got[0], got[1]), completion_drop(got[2], got[3])
        return (dr, dd - dr), f"RAMEN {ramen}, DiNNO {dinno}"

    def one_pct(s: int, l: int):
        r, lo = f5.run(s, l, method="ramen", channel__success_rate=0.01), t1.run(s, l, method="local")
        if r is None or lo is None:
            return None
        gap, text = robots_above(r, lo)
        return (gap,), text

    n = len(TRIALS)
    claims = [
        per_trial(Claim("Fig. 5: RAMEN loses ≤ 5 points from 100 to 20 %, less than DiNNO", "team completion at 100 "
                        "% minus at 20 %: RAMEN's ≤ 5 and < DiNNO's", n,
                        [RAMEN_DROP, Test("DiNNO's drop − RAMEN's (points)", 0.0, ">")]),
                  drop),
        per_trial(Claim("Fig. 5: at 1 % RAMEN above local", "each RAMEN robot at 1 % above each local robot "
                        "(Table I's local run of the trial)", n,
                        [ABOVE_LOCAL]), one_pct),
    ]
    for p in RATES:
        pairs, units, used, labels = [], [], [], []
        for s, l in TRIALS:
            r, d = (f5.run(s, l, method=m, channel__success_rate=p) for m in ("ramen", "dinno"))
            if r is not None and d is not None:
                try:
                    pairs.append((robots(r), robots(d)))
                    units.append(s)
                    used += [r, d]
                    labels.append(label(s, l) + host_marks([r, d]))
                except Unjudgeable as exc:
                    judging.skipped.append((f"Fig. 5 std at {p * 100:g} %, {label(s, l)}", str(exc)))
        c = pooled_std(judging, f"Fig. 5 at {p * 100:g} % success: RAMEN's std smaller than DiNNO's (the paper: \"much "
                       "smaller standard deviations\")", "population std of completion over every robot of every "
                       "trial with both runs at this rate", pairs, n, units, used)
        if pairs:
            c.cause = std_cause(c, pairs)
        claims.append(c)
        claims.append(within_run_std(f"Fig. 5 at {p * 100:g} % success: RAMEN's std smaller than DiNNO's, within "
                                     "a run (the paper's reading)", pairs, n, units, labels))
    return claims


def low_rate_claims(judging: Judging, f5: Archive, pu: Archive, t1: Archive) -> list[Claim]:
    """Issue 25 item 5 (beyond the paper): at 5 % and 1 % success RAMEN with the default update
    against DiNNO (Fig. 5's runs), the paper's update (``consensus.preset: paper``, the archive
    ``paper_fig5_paper_update``) and local (Table I's local run of the trial), by team completion."""
    def judge(p: float):
        def inner(s: int, l: int):
            r, d = (f5.run(s, l, method=m, channel__success_rate=p) for m in ("ramen", "dinno"))
            pap, lo = pu.run(s, l, method="ramen", channel__success_rate=p), t1.run(s, l, method="local")
            if r is None or d is None or pap is None or lo is None:
                return None
            ours, others = team(r), {"DiNNO": team(d), "paper's update": team(pap), "local": team(lo)}
            return (ours - max(others.values()),), \
                f"RAMEN {ours:.1f} vs " + ", ".join(f"{k} {v:.1f}" for k, v in others.items())
        return inner

    return [judging.per_trial(Claim(f"At {p * 100:g} % success: default RAMEN above DiNNO, the paper's update and "
                                    "local", "team completion of RAMEN (default update) > DiNNO's, the paper's "
                                    "update's and local's (Table I's local run of the trial)", len(TRIALS),
                                    [Test("RAMEN − the best of the three (points)", 0.0, ">")]), judge(p))
            for p in (0.05, 0.01)]
