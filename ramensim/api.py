"""The Python API: ``ramensim.run`` and ``ramensim.sweep`` (docs/API.md).

>>> import ramensim
>>> result = ramensim.run("scenarios/office_3agents.yaml", overrides={"channel.success_rate": 0.5})
>>> result.summary["completion_ratio_pct"].mean, result.paths["metrics"]

:func:`run` does what ``ramensim run`` does and returns a :class:`RunOutput`: the typed
``metrics.json`` (:class:`ramensim.core.results.RunResult`: per-agent metrics, coverage,
communication totals, the evaluation and consensus timelines) plus the run folder and the paths
of its artifacts. :func:`sweep` does what ``ramensim sweep`` does and returns a
:class:`SweepOutput` with one :class:`RunOutput` per point. Bad input raises
:class:`ramensim.errors.InputError` (one paragraph naming the file, key and value).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

from pydantic import Field

from ramensim.core.results import RunResult
from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

Overrides = Mapping[str, Any] | Iterable[str]
"""Dotted-key overrides: ``{"channel.success_rate": 0.5}`` or ``["channel.success_rate=0.5"]``."""


class RunOutput(RunResult):
    """A run's ``metrics.json`` (every field of :class:`RunResult`) plus where its files are.
    ``run_dir`` is not part of ``metrics.json`` (excluded from :meth:`write` and :meth:`to_dict`)."""

    run_dir: Path | None = Field(None, exclude=True)
    """The run folder."""

    @property
    def paths(self) -> dict[str, Path]:
        """The artifacts that exist in the run folder: ``scenario`` (resolved YAML), ``log``,
        ``messages`` (CSV), ``metrics`` (JSON), ``recording`` (.rrd) and ``mesh:<map>`` (PLY)."""
        if self.run_dir is None:
            return {}
        d = Path(self.run_dir)
        names = {"scenario": "scenario.yaml", "log": "run.log", "messages": "messages.csv",
                 "metrics": "metrics.json", "recording": "run.rrd"}
        out = {k: d / v for k, v in names.items() if (d / v).is_file()}
        for name in self.per_agent:
            mesh = d / f"mesh_{name}.ply"
            if mesh.is_file():
                out[f"mesh:{name}"] = mesh
        return out

    def metric(self, key: str) -> dict[str, float]:
        """One of the paper's metrics (e.g. ``completion_ratio_pct``) per map (NaN when missing)."""
        return {name: a.metric(key) for name, a in self.per_agent.items()}

    @classmethod
    def load(cls, run_dir: str | Path) -> "RunOutput":
        """Read a finished run folder (its ``metrics.json``)."""
        d = Path(run_dir)
        if d.is_file():
            d = d.parent
        if not (d / "metrics.json").is_file():
            raise InputError(f"{d}: no metrics.json; expected a run folder written by 'ramensim run' "
                             f"or ramensim.run().")
        try:
            result = RunResult.read(d / "metrics.json")
        except ValueError as exc:
            errors = getattr(exc, "errors", None)
            if callable(errors):  # pydantic: name the keys, not its multi-line report
                found = errors()
                why = "; ".join(f"key '{'.'.join(str(p) for p in e['loc']) or '(top level)'}': {e['msg']}"
                                for e in found[:3]) + (f"; and {len(found) - 3} more" if len(found) > 3 else "")
            else:
                why = " ".join(str(exc).split())[:300]
            raise InputError(f"{d / 'metrics.json'}: not a run's metrics.json ({why}); expected the file "
                             f"'ramensim run' writes.") from None
        return cls.of(result, d)

    @classmethod
    def of(cls, result: RunResult, run_dir: str | Path | None) -> "RunOutput":
        data = dict(result)
        return cls(**data, run_dir=Path(run_dir) if run_dir is not None else None)


def _scenario(scenario: Any, overrides: Overrides | None, base_dir: str | Path | None, plugins: Iterable[str] = ()):
    """(validated Scenario, folder that relative paths resolve against), through the one door
    (:func:`ramensim.config.load_scenario`)."""
    from ramensim.config import load_scenario, scenario_folder

    return (load_scenario(scenario, overrides or {}, base_dir=base_dir, plugins=plugins),
            scenario_folder(scenario, base_dir))


def run(scenario: str | Path | Mapping[str, Any] | Any, overrides: Overrides | None = None, *,
        out: str | Path | None = None, base_dir: str | Path | None = None, progress: bool | str = False,
        subscribers: list[Any] | None = None, overwrite: bool = False, plugins: Iterable[str] = ()) -> RunOutput:
    """Run one scenario end to end, like ``ramensim run``, and return its typed result.

    ``scenario``: a YAML file, a dict of scenario keys or a :class:`ramensim.schema.Scenario`;
    ``overrides``: dotted keys applied on top (as ``--set``); ``out``: the run folder (default:
    a new one under ``output.dir``, ``./runs``; an existing folder must be empty unless
    ``overwrite``, which replaces the previous run's files there); ``base_dir``: where relative paths in the
    scenario resolve (default: the file's folder, else the working directory); ``progress``:
    log a progress line every 30 s (or a mode of :class:`ramensim.progress.RunProgress`: "bar",
    "log", "off"; the CLI draws a bar); ``subscribers``: extra callables that
    receive every simulation event (:mod:`ramensim.core.events`); ``plugins``: plugin files
    (relative to the working directory) or modules loaded first, as ``--plugin``, beside the
    scenario's own ``plugins`` key (docs/EXTENDING.md).

    The status (``result.status``) is ``ok``, ``diverged``, ``interrupted`` or ``failed``; a
    failed run still returns what it mapped (see ``result.error``)."""
    from ramensim.core.native import prefer_passive_openmp

    prefer_passive_openmp()  # only takes effect when torch is not imported yet
    from ramensim.progress import RunProgress
    from ramensim.runfolder import new_run_dir, prepare_out_dir
    from ramensim.lifecycle import run_scenario

    sc, folder = _scenario(scenario, overrides, base_dir, plugins)
    if out is not None:
        prepare_out_dir(Path(out), overwrite, ("out", "overwrite=True"))
    run_dir = Path(out) if out is not None else new_run_dir(sc.output.dir, sc.name, sc.seed)
    subs = list(subscribers or [])
    mode = progress if isinstance(progress, str) else ("log" if progress else "off")
    with RunProgress(sc.duration, sc.name, mode) as prog:
        result = run_scenario(sc, run_dir, base_dir=folder, subscribers=[prog, *subs])
        prog.finish(result.wall_time_s, result.mean("completion_ratio_pct"))
    return RunOutput.of(result, run_dir)


@dataclass
class SweepOutput:
    """What :func:`sweep` ran and found: one :class:`RunOutput` per point with a result."""

    out_dir: Path
    """The sweep folder (``runs/<point>/``, ``tables/``, ``plots/``)."""
    ok: list[str]
    diverged: list[str]
    failed: dict[str, str]
    """Point name -> one-line error."""
    skipped: int
    """Points that already had a result (resumed sweep)."""
    elsewhere: list[str] = field(default_factory=list)
    """Points left to another sweep of the same plan running in the same folder."""
    axes: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Point name -> its value of every axis."""
    runs: dict[str, RunOutput] = field(default_factory=dict)
    """Point name -> its result (points with a readable metrics.json)."""
    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)

    def where(self, **axes: Any) -> dict[str, RunOutput]:
        """The runs whose axis values match, e.g. ``where(method="ramen")`` (dotted axis keys
        with ``__`` for the dots: ``where(channel__success_rate=0.5)``)."""
        want = {k.replace("__", "."): v for k, v in axes.items()}
        return {n: r for n, r in self.runs.items()
                if all(self.axes.get(n, {}).get(k) == v for k, v in want.items())}


def sweep(file: str | Path, out: str | Path | None = None, *, workers: int | None = None,
          executor: str = "local", address: str | None = None, threads: int | None = None,
          retry_failed: bool = True, report: bool = True, progress: bool | str = False,
          storage: str | Path | None = None, only: Mapping[str, Any] | list[str] | None = None,
          device: str | None = None, plugins: Iterable[str] = (),
          overrides: Overrides | None = None) -> SweepOutput:
    """Run a sweep file (docs/SWEEPS.md), like ``ramensim sweep``: every point without a
    result, resumable, on local worker processes or Ray; then its tables and plots.

    Local workers are spawned processes: a script that calls this must guard its top level
    with ``if __name__ == "__main__":``. On Ray (``executor="ray"``, ``address`` of a
    cluster), finished runs come back to ``out`` through Ray, or through ``storage``, a folder
    mounted at the same path on every node (docs/SWEEPS.md). ``only`` runs a subset of the
    points, e.g. ``{"seed": 0, "channel.success_rate": [1.0, 0.2]}`` (as ``--only``;
    :func:`ramensim.sweep.spec.select_points`); the report still counts every planned point.
    ``device`` (``cpu``, ``cuda``, ``auto``; as ``--device``) puts every run's maps on that torch
    device without making the runs other points (:func:`ramensim.sweep.runner.run_sweep`).
    ``plugins`` (files relative to the working directory, or modules; as ``--plugin``) join the
    sweep's and the base scenario's ``plugins``; every worker loads them before its point.
    ``overrides`` (``{"duration": 10}`` or ``["duration=10"]``; as ``--set``) apply to every
    point after the file's ``set``; without ``out`` the folder is then
    ``runs/sweeps/NAME__KEY=V`` (:attr:`ramensim.sweep.spec.SweepPlan.folder_name`), so a
    shortened sweep never makes the full sweep's results stale."""
    from ramensim.core.native import prefer_passive_openmp

    prefer_passive_openmp()  # before torch is imported: the workers inherit it
    from ramensim.progress import SweepProgress, point_durations
    from ramensim.sweep.report import make_report
    from ramensim.sweep.runner import run_sweep
    from ramensim.sweep.spec import plan_sweep, select_points
    from ramensim.sweep.store import default_out

    plan = plan_sweep(file, plugins=plugins, overrides=overrides or ())
    selected = select_points(plan, only) if only else None
    folder = Path(out) if out is not None else default_out(plan.folder_name)
    mode = progress if isinstance(progress, str) else ("log" if progress else "off")
    durations = {n: d for n, d in point_durations(plan).items() if selected is None or n in selected}
    with SweepProgress(folder, durations, f"sweep {plan.name}", mode):
        outcome = run_sweep(plan, folder, workers=workers, executor=executor, address=address,  # type: ignore[arg-type]
                            threads=threads, retry_failed=retry_failed, progress=False, storage=storage,
                            only=selected, device=device)
    result = SweepOutput(folder, list(outcome.ok), list(outcome.diverged), dict(outcome.failed), outcome.skipped,
                         list(outcome.elsewhere), axes={p.name: dict(p.axes) for p in plan.points})
    for p in plan.points:
        d = folder / "runs" / p.name
        if (d / "metrics.json").is_file():
            try:
                result.runs[p.name] = RunOutput.load(d)
            except InputError as exc:
                log.warning("sweep point %s: %s", p.name, exc)
    if report:
        rep = make_report(folder)
        result.tables, result.figures = list(rep.tables), list(rep.figures)
    return result
