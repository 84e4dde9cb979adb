"""Reading archived sweeps: the complete runs of one sweep folder by their settings
(:class:`Archive`; ``sweep.json`` and ``runs/``, as ``tools/archive_sweep.py`` keeps them), a run's
values with where it lies and the machine it ran on (:class:`RunValues`), and the runs of an
archive that are not judged, with why (planned but not run, not complete, unreadable, made from
other settings than its plan point)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable

NOT_RUN = "planned, not run"
"""Why an :class:`Archive` names a point of its plan that has no run folder."""
TRIAL_AXES = ("seed", "world.scene.seed")
"""The axes that name a trial: run seed and house layout."""


class RunValues(dict):
    """A complete run's values (metric -> list, ``ramensim.sweep.aggregate.run_values``), with where
    it lies (``where``: ``archive/run``), its metrics.json (read when needed) and its machine."""

    def __init__(self, values: dict[str, list[float]], where: str, folder: Path) -> None:
        super().__init__(values)
        self.where, self.folder = where, folder
        self._metrics: dict[str, Any] | None = None

    @property
    def metrics(self) -> dict[str, Any]:
        """The run's metrics.json (an empty dict when it is not a JSON object)."""
        if self._metrics is None:
            from ramensim.sweep import store

            data = store.read_json(self.folder / store.METRICS)
            self._metrics = data if isinstance(data, dict) else {}
        return self._metrics

    @property
    def build(self) -> dict[str, Any] | None:
        """The run's metrics.json ``build`` record (host and build), None if it has none."""
        build = self.metrics.get("build")
        return build if isinstance(build, dict) and build else None

    @property
    def machine(self) -> str | None:
        """The host the run computed on, in words (CPU model, SIMD level, torch device, and the host
        fingerprint where recorded), None if unrecorded."""
        b = self.build
        if b is None:
            return None
        words = ", ".join(str(b[k]) for k in ("cpu", "simd", "device") if b.get(k))
        return words + (f", host {b['host']}" if b.get("host") else "")


class Archive:
    """The complete runs of one archived sweep, by their settings, and the runs not judged.
    ``on_read`` is told of every run :meth:`run` hands out (the judging pass notes which runs a
    trial compared, :class:`ramensim.paper.trials.Judging`)."""

    def __init__(self, folder: Path, on_read: Callable[[RunValues], None] | None = None) -> None:
        from ramensim.sweep import store
        from ramensim.sweep.aggregate import load_plan, load_runs

        from ramensim.core.errors import InputError

        self.folder, self.on_read = folder, on_read
        self.problems: list[tuple[str, str]] = []
        """(run, why it is not judged), for the notes of the claims file."""
        self.present = (folder / store.PLAN).is_file() or (folder / store.RUNS).is_dir()
        try:
            plan, records = load_runs(folder) if self.present else ({}, [])
        except InputError as exc:  # e.g. an unreadable sweep.json and no runs/: named, the rest judged
            self.problems.append(("(the archive)", str(exc)))
            self.present, plan, records = False, {}, []
        fingerprints = {p["name"]: p.get("fingerprint") for p in ((load_plan(folder) or {}).get("points") or [])
                        if isinstance(p, dict) and "name" in p} if self.present else {}
        planned_axes = {p["name"]: dict(p.get("axes") or {}) for p in (plan or {}).get("points", [])
                        if isinstance(p, dict) and "name" in p}
        self.records = []
        for r in records:
            if not all(k in r.axes for k in TRIAL_AXES) and all(k in planned_axes.get(r.name, {}) for k in TRIAL_AXES):
                r.axes = planned_axes[r.name]   # a status.json without its axes: the plan's point has them
            if r.status not in store.COMPLETE:
                self.problems.append((r.name, f"status {r.status!r}" + (f" ({r.error})" if r.error else "")))
                continue
            status = store.read_status(folder / store.RUNS / r.name) or {}
            want, got = fingerprints.get(r.name), status.get("fingerprint")
            if want and got and want != got:
                self.problems.append((r.name, f"made from other settings than its plan point (fingerprint {got}, "
                                              f"plan {want})"))
                continue
            if not all(k in r.axes for k in TRIAL_AXES):
                self.problems.append((r.name, "its status.json names no run seed and layout (and no plan point does)"))
                continue
            self.records.append(r)
        done = {r.name for r in records}
        self.planned: list[dict[str, Any]] = [dict(p.get("axes") or {}) for p in (plan or {}).get("points", [])
                                              if isinstance(p, dict)]
        """The axes of every point of the archived plan (empty without ``sweep.json``)."""
        self.problems += [(p["name"], NOT_RUN) for p in (plan or {}).get("points", [])
                          if isinstance(p, dict) and "name" in p and p["name"] not in done]

    def run(self, seed: int, layout: int, **axes: Any) -> RunValues | None:
        """The values of the complete run with these settings (None if not done)."""
        for r in self.records:
            if r.axes.get("seed") == seed and r.axes.get("world.scene.seed") == layout and \
                    all(same(r.axes.get(k.replace("__", ".")), v) for k, v in axes.items()):
                got = RunValues(r.values, f"{self.folder.name}/{r.name}", self.folder / "runs" / r.name)
                if self.on_read is not None:
                    self.on_read(got)
                return got
        return None


def same(a: Any, b: Any) -> bool:
    """Whether two axis values are the same setting (numbers compared with ``math.isclose``)."""
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(float(a), float(b))
    return a == b
