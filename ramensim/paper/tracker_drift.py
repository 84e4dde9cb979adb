"""DSGT's gradient-tracking invariant logged during a run (a cause study, docs/results/dsgt.md,
"DSGT and DSGD with unlimited bandwidth at 600 s"; ``ramensim paper tracker-drift``).

Gradient tracking (docs/CONSENSUS.md, DSGT) keeps ``sum_i y_i = sum_i g_i`` -- the trackers'
sum equal to the sum of the robots' latest gradients -- when every round's mixing matrix is
doubly stochastic. Renormalising a robot's row over the neighbours it heard keeps the rows
summing to 1 but not the columns, so lost messages should make the two sums part.
:func:`probe_run` runs one scenario with DSGT and, after every robot's round, records the team's
drift

    drift = || sum_i y_i - sum_i g_i || / || sum_i g_i ||      (dimensionless)

with ``y_i`` the robot's tracker after its round and ``g_i`` its gradient at its current
parameters (both in the map's gradient units), beside the gap ``|| sum_i y_i - sum_i g_i ||``,
``|| sum_i y_i ||`` and ``|| sum_i g_i ||`` (gradient units). Nothing of the run changes: the
method's round is wrapped to read its state after it returns, no generator is drawn from. A
record's time ``t`` is that of the latest simulation event before the round (s). Outputs:
``tracker_drift.json`` (every record) and ``tracker_drift.md`` (a row every ``every_s``
simulated seconds).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any


class DriftProbe:
    """Wraps ``DsgtMethod.round`` for one run: keeps every DSGT instance built and, after each
    round, the team's tracker and gradient sums (``records``: dicts of t, agent, drift, norms)."""

    def __init__(self) -> None:
        self.methods: list[Any] = []
        self.records: list[dict[str, float]] = []
        self.t = 0.0

    def event(self, event: Any) -> None:
        """A run subscriber: keeps the simulated time (s) of the latest event."""
        self.t = max(self.t, float(event.t))

    def install(self) -> Any:
        """Patch ``DsgtMethod`` to record every round; returns a callable that undoes it."""
        import torch
        from ramensim.agents.consensus.dsgt import DsgtMethod

        probe, init, rnd = self, DsgtMethod.__init__, DsgtMethod.round
        rounds: dict[int, int] = {}

        def __init__(m: Any, *a: Any, **k: Any) -> None:
            init(m, *a, **k)
            probe.methods.append(m)

        def round_(m: Any, learner: Any, copies: Any, n_neighbours: int) -> Any:
            out = rnd(m, learner, copies, n_neighbours)
            rounds[id(m)] = rounds.get(id(m), 0) + 1
            ages = [probe.t - c.stamp for c in copies]
            started = [x for x in probe.methods if x.started]
            with torch.no_grad():
                sy = torch.stack([x.y for x in started]).sum(0)
                sg = torch.stack([x.last_gradient for x in started]).sum(0)
                ny, ng = float(sy.norm()), float(sg.norm())
                diff = float((sy - sg).norm())
            done = {rounds.get(id(x), 0) for x in probe.methods}
            probe.records.append({"t": probe.t, "agent": float(probe.methods.index(m)),
                                  "robots": float(len(started)),
                                  "round": float(rounds[id(m)]), "team_round_done": float(len(done) == 1),
                                  "copies": float(len(ages)), "max_copy_age_s": max(ages, default=math.nan),
                                  "sum_y_norm": ny, "sum_g_norm": ng, "gap_norm": diff,
                                  "drift": diff / ng if ng > 0 else math.nan})
            return out

        DsgtMethod.__init__, DsgtMethod.round = __init__, round_

        def undo() -> None:
            DsgtMethod.__init__, DsgtMethod.round = init, rnd
        return undo


class MatchedLag:
    """A counterfactual DSGT tracker for runs whose robots are in step and lose nothing: each
    robot mixes its neighbours' trackers with *its own tracker of the same round* and adds the
    gradient change since that round,

        y_i(k+1) = a_ii y_i(k-d) + sum_j a_ij y_j(k-d) + g_i(k+1) - g_i(k-d)      (gradient units)

    where k-d is the round the copies were taken at (their ``stamp``). With doubly stochastic
    mixing this keeps ``sum_i y_i = sum_i g_i`` exactly although the copies are old (two
    interleaved tracking chains when d = 1), where the method as built mixes its *newest* own
    tracker with the older copies and subtracts only the last round's gradient. The parameters
    are mixed and stepped as the method does. It tests whether that mismatch is what keeps DSGT
    below the other methods with every message delivered; a run where the copies of one round
    carry different stamps, or a stamp the robot has no own state for, is refused (it needs
    the robots in step: ``agents.compute.jitter=0`` and ``channel.success_rate=1``)."""

    KEEP = 2
    """Own (y, g) states kept per robot: the last two (in step the copies are one round old)."""

    def __init__(self, clock: "DriftProbe") -> None:
        self.clock = clock
        self.history: dict[int, dict[float, tuple[Any, Any]]] = {}

    def install(self) -> Any:
        """Patch ``DsgtMethod.round`` with the counterfactual; returns a callable that undoes it."""
        from ramensim.agents.consensus.base import check_copy, check_theta, mixing_weights
        from ramensim.agents.consensus.dsgt import DsgtMethod

        lag, rnd = self, DsgtMethod.round

        def round_(m: Any, learner: Any, copies: Any, n_neighbours: int) -> Any:
            hist = lag.history.setdefault(id(m), {})
            now = round(lag.clock.t, 6)
            if m.started:
                hist[now] = (m.y.clone(), m.last_gradient.clone())  # own state after the round that ended now
                for old in sorted(hist)[:-lag.KEEP]:
                    del hist[old]
            if not copies:
                return rnd(m, learner, copies, n_neighbours)  # nothing to match: the round as built
            evals = 1 + m.ensure_started(learner)
            stamps = {round(float(c.stamp), 6) for c in copies}
            kept = sorted(hist)
            previous = kept[-2] if len(kept) > 1 else None  # when the round before the last one ended
            if stamps != {previous}:
                raise RuntimeError(f"matched-lag DSGT: robot copies stamped {sorted(stamps)} s at t = {now} s; "
                                   f"expected every copy from the round before this robot's last ({previous} s): "
                                   "the counterfactual needs the robots in step and nothing lost "
                                   "(agents.compute.jitter=0, channel.success_rate=1).")
            y_self, g_self = hist[next(iter(stamps))]
            theta = check_theta(learner, m.n, m.name)
            for c in copies:
                check_copy(c, m.n, m.name, ("theta", "y"))
            m.degree = int(n_neighbours)
            a_ii, a_j = mixing_weights(copies, n_neighbours, m.mixing, m.name)
            return m.mix_and_track(learner, theta, copies, a_ii, a_j, y_self, g_self, evals)

        DsgtMethod.round = round_

        def undo() -> None:
            DsgtMethod.round = rnd
        return undo


def table(records: list[dict[str, float]], every_s: float) -> str:
    """A markdown row for the last record in each ``every_s`` window of simulated time at which
    every robot has made the same number of rounds (the invariant's own instants)."""
    last = {}
    for r in records:
        if r["team_round_done"]:
            last[math.floor(r["t"] / every_s)] = r
    lines = ["| t (s) | round | drift | ||sum y - sum g|| | ||sum y|| | ||sum g|| | oldest copy used (s) |",
             "|---:|---:|---:|---:|---:|---:|---:|"]
    for k in sorted(last):
        r = last[k]
        lines.append(f"| {r['t']:.1f} | {r['round']:.0f} | {r['drift']:.4g} | {r['gap_norm']:.4g} | {r['sum_y_norm']:.4g} | "
                     f"{r['sum_g_norm']:.4g} | {r['max_copy_age_s']:.3g} |")
    return "\n".join(lines) + "\n"


def _num(v: Any, digits: int) -> str:
    """``v`` with ``digits`` decimals, or 'n/a' where a short run has no value."""
    return "n/a" if v is None or v != v else f"{v:.{digits}f}"


def probe_run(scenario: Path, sets: list[str], run_dir: Path, matched_lag: bool = False) -> tuple[Any, DriftProbe]:
    """Run ``scenario`` with DSGT and the ``sets`` (``KEY=VALUE`` overrides) into ``run_dir`` with the
    probe installed (and, with ``matched_lag``, the :class:`MatchedLag` counterfactual); returns the
    run's result and the probe with its records. The rounds run inline, one at a time, at their
    start (the team engine's one-worker order; same results), since the probe reads every robot's
    tracker when one robot's round runs. :class:`~ramensim.errors.InputError` for a bad scenario."""
    import ramensim
    from ramensim.agents.team import WORKERS_ENV

    saved = os.environ.get(WORKERS_ENV)
    os.environ[WORKERS_ENV] = "1"
    probe = DriftProbe()
    undo_lag = MatchedLag(probe).install() if matched_lag else (lambda: None)
    undo = probe.install()  # after the counterfactual, so that the probe reads the round it makes
    try:
        result = ramensim.run(scenario, overrides=["method=dsgt", *sets], out=run_dir, overwrite=True,
                              subscribers=[probe.event])
    finally:
        undo()
        undo_lag()
        if saved is None:
            os.environ.pop(WORKERS_ENV, None)
        else:
            os.environ[WORKERS_ENV] = saved
    return result, probe


def heading(result: Any, scenario: Path, sets: list[str], matched_lag: bool) -> str:
    """The page's first line: the run's status, messages sent, share delivered and completion (%)."""
    completion = result.summary.get("completion_ratio_pct")
    return (f"DSGT{' (matched-lag tracker)' if matched_lag else ''} tracker drift, {scenario} {' '.join(sets)}: "
            f"status {result.status}, {result.communication.get('sent')} messages, "
            f"{_num(result.communication.get('delivered_fraction'), 3)} delivered, completion "
            f"{_num(completion.mean if completion else None, 1)} %\n\n")
