"""Readers of the cause studies (``docs/results/cause/``, ``--causes``): their complete runs with
the settings each is matched by (run seed, layout, robots, method, eq. 19's floor ``beta_l``,
duration), and the sentences the claims quote from them: the floor's trade-off on Table I and
DSGT's completion with every message delivered."""
from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from ramensim.paper.archive import Archive, RunValues
from ramensim.paper.rules import Unjudgeable, label, team
from ramensim.paper.trials import Judging

log = logging.getLogger(__name__)


def cause_runs(judging: Judging, causes: Path | None, pattern: str) -> list[tuple[str, dict[str, Any], RunValues]]:
    """Every complete run of the cause archives matching ``pattern`` under ``causes``, with its
    resolved settings (the run's ``scenario.yaml``: seed, layout, robots, ``beta_l``, duration); an
    archive or run that cannot be read is named in ``judging.skipped``."""
    from ramensim.sweep import store
    from ramensim.sweep.aggregate import load_runs
    from ramensim.core.errors import InputError

    out: list[tuple[str, dict[str, Any], RunValues]] = []
    if causes is None or not causes.is_dir():
        return out
    for folder in sorted(p for p in causes.glob(pattern) if p.is_dir()):
        try:
            _, records = load_runs(folder)
        except InputError as exc:
            judging.skipped.append((f"cause archive {folder.name}", str(exc)))
            continue
        for r in records:
            where = f"{folder.name}/{r.name}"
            if r.status not in store.COMPLETE:
                judging.skipped.append((f"cause run {where}", f"status {r.status!r}"))
                continue
            sc = _scenario(folder / store.RUNS / r.name / "scenario.yaml")
            if sc is None:
                judging.skipped.append((f"cause run {where}", "no readable scenario.yaml"))
                continue
            out.append((where, sc, RunValues(r.values, where, folder / store.RUNS / r.name)))
    return out


def _scenario(path: Path) -> dict[str, Any] | None:
    """The settings a cause run is matched by, from its resolved scenario.yaml (None if unreadable)."""
    from ramensim.yamlsafe import safe_load_bounded

    try:
        doc = safe_load_bounded(path.read_text(encoding="utf-8"))
        return {"seed": int(doc["seed"]), "layout": int(doc["world"]["scene"]["seed"]),
                "count": int(doc["agents"]["count"]), "method": str(doc["method"]),
                "beta_l": float(doc["consensus"]["ramen"]["beta_l"]), "duration": float(doc["duration"])}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        log.debug("%s: %s", path, exc)
        return None
    except Exception as exc:  # yaml.YAMLError and its bounded-loader subclasses
        log.debug("%s: %s", path, exc)
        return None


def floor_tradeoff(judging: Judging, causes: Path | None, t1: Archive | None) -> str:
    """The same floor on Table I's first trial: RAMEN's team completion with the default floor
    (the archived Table I run) and with ``beta_l`` 1e-5 (``cause/ramen_weights_600``)."""
    if t1 is None:
        return ""
    for where, sc, v in cause_runs(judging, causes, "ramen_weights_600"):
        if sc["count"] == 3 and math.isclose(sc["beta_l"], 1e-5):
            base = t1.run(sc["seed"], sc["layout"], method="ramen")
            if base is None:
                return ""
            try:
                return (f"a trade-off, not an isolated cause: the same floor lowers Table I's RAMEN from "
                        f"{team(base):.1f} to {team(v):.1f} % ({label(sc['seed'], sc['layout'])}, one 600-s run, "
                        f"{where.split('/')[0]})")
            except Unjudgeable:
                return ""
    return ""


def dsgt_loss(causes: Path | None) -> str:
    """DSGT with every message delivered against 50 % (``cause/dsgt_stale``, one 150-s run each)."""
    from ramensim.sweep.aggregate import load_runs
    from ramensim.sweep import store
    from ramensim.core.errors import InputError

    if causes is None or not (causes / "dsgt_stale").is_dir():
        return ""
    try:
        _, records = load_runs(causes / "dsgt_stale")
    except InputError:
        return ""
    got: dict[float, float] = {}
    for r in records:
        rate = r.axes.get("channel.success_rate")
        if r.status in store.COMPLETE and r.axes.get("consensus.stale_policy") == "latest" and rate is not None:
            try:
                got[float(rate)] = team(r.values)
            except Unjudgeable:
                pass
    if 1.0 not in got or 0.5 not in got:
        return ""
    return (f"with every message delivered DSGT in step reaches {got[1.0]:.1f} % at 150 s against {got[0.5]:.1f} % "
            f"at 50 % success (docs/results/cause/dsgt_stale, one run each)")
