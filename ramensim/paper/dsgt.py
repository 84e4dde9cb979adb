"""The asynchrony claims (``paper_dsgt_async``: unlimited bandwidth, clocks in step or drifting
±50 %): DSGT and DSGD below local with drifting clocks, whether the drift is DSGT's cause (in step
against drifting), and RAMEN's consensus-error falls in the paper's setting (clocks in step);
completion in %, differences in points."""
from __future__ import annotations

from pathlib import Path

from ramensim.paper.archive import Archive
from ramensim.paper.causes import dsgt_loss
from ramensim.paper.falls import ce_pair
from ramensim.paper.rules import TRIALS, Claim, Test, alive, team
from ramensim.paper.trials import Judging


def dsgt_claims(judging: Judging, da: Archive, t1: Archive, causes: Path | None = None) -> list[Claim]:
    """The asynchrony claims on ``da`` (``paper_dsgt_async``), against Table I's local run of each
    trial (``t1``); the cause of DSGT's failure quotes ``cause/dsgt_stale`` under ``causes``."""
    per_trial = judging.per_trial

    def below_local(method: str):
        def judge(s: int, l: int):
            m = da.run(s, l, method=method, agents__compute__jitter=0.5)
            lo = t1.run(s, l, method="local")
            if m is None or lo is None:
                return None
            inst = da.run(s, l, method=method, agents__compute__jitter=0.0)
            in_step = f"; in step {alive(inst)}" if inst is not None else ""
            return (team(m) - team(lo),), f"{alive(m)} vs local {team(lo):.1f}{in_step}"
        return judge

    def asynchrony(s: int, l: int):
        drift, inst = (da.run(s, l, method="dsgt", agents__compute__jitter=j) for j in (0.5, 0.0))
        lo = t1.run(s, l, method="local")
        if drift is None or inst is None or lo is None:
            return None
        return (team(inst) - team(lo), team(drift) - team(inst)), \
            f"in step {alive(inst)}, drifting {alive(drift)}, local {team(lo):.1f}"

    n = len(TRIALS)
    dsgt = per_trial(Claim("DSGT below local with drifting clocks (unlimited bandwidth, clocks ±50 %)", "team "
                           "completion below local's (Table I's local run of the trial)", n,
                           [Test("DSGT drifting − local (points)", 0.0, "<")]), below_local("dsgt"))
    cause = per_trial(Claim("DSGT fails under asynchrony (the paper: \"DSGT fails to converge ... under asynchronous "
                            "communication\"), asynchrony read as drifting clocks", "if the clocks' drift were the "
                            "cause, DSGT in step would not be below local, and drifting clocks would lower it", n,
                            [Test("DSGT in step − local (points)", 0.0, ">="),
                             Test("DSGT drifting − in step (points)", 0.0, "<")]), asynchrony)
    if cause.samples:
        ivs = cause.intervals()
        loss = dsgt_loss(causes)
        cause.cause = (f"it fails from the loss, not from asynchrony: drifting clocks change DSGT by "
                       f"{ivs[1].estimate:+.2f} [{ivs[1].lo:+.2f}, {ivs[1].hi:+.2f}] points, and in step it is "
                       f"{-ivs[0].estimate:.1f} points below local" + (f"; {loss}" if loss else ""))
        dsgt.cause = "the loss, not the drifting clocks (next row)"
    return [
        dsgt, cause,
        per_trial(Claim("DSGD under asynchrony (unlimited bandwidth, clocks ±50 %; reported)", "team completion "
                        "below local's", n, [Test("DSGD drifting − local (points)", 0.0, "<")]),
                  below_local("dsgd")),
        *ce_pair(judging, "RAMEN's consensus error falls ≥ 10x with unlimited bandwidth (the paper's setting, "
                 "clocks in step)", "weighted by eq. 19 (CE-2)", da, "consensus_error_weighted", method="ramen",
                 agents__compute__jitter=0.0),
        *ce_pair(judging, "RAMEN's unweighted consensus error with unlimited bandwidth (reported)",
                 "unweighted (CE-1)", da, "consensus_error", method="ramen", agents__compute__jitter=0.0),
    ]

