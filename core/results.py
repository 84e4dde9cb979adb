"""Typed results: one mapping round, one agent's final metrics, one run.

``RunResult`` is what ``metrics.json`` holds, written and read only through
:meth:`RunResult.write` / :meth:`RunResult.read`, so ``ramensim run``, sweeps, reports and
the Python API share one serialisation. Units: centimetres for Artifacts/Holes, percent
for the completion ratio, seconds for times, bytes for sizes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from ramensim.core.files import atomic_write_json, read_json

Status = Literal["ok", "interrupted", "failed", "diverged"]
"""How a run ended (docs/RELIABILITY.md): ``ok`` (ran to its duration), ``interrupted`` (stopped
early by SIGINT/SIGTERM, metrics of what was mapped so far; also the status of the partial
metrics.json flushed while a run is going, so a killed run reads as interrupted), ``failed`` (an
error, or an agent stopped on one; see ``error``), ``diverged`` (ran to its duration but at least
one agent's map diverged)."""

METRIC_KEYS = ("artifacts_cm", "holes_cm", "completion_ratio_pct")
"""The paper's metrics (section V): Artifacts (cm), Holes (cm), Completion ratio (%)."""

COVERAGE_KEYS = ("own_coverage_pct", "completion_unseen_pct", "holes_unseen_cm")
"""What communication brings (``ramensim.evaluation.coverage``): the share of the evaluated
ground truth this agent's camera saw (%), and completion (%) / holes (cm) on the part only
its teammates saw."""

SUMMARY_KEYS = METRIC_KEYS + COVERAGE_KEYS
"""Per-agent numbers summarised (mean ± std) in metrics.json, tables and reports."""


@dataclass(slots=True)
class RoundResult:
    """What one mapping round of a consensus method did.

    ``grad_evals``: calls of the learner's ``loss_and_grad`` (the compute clock charges them);
    ``loss``: mean objective over the round's steps (NaN if non-finite); ``diverged``: the
    map, loss or dual became non-finite; ``scalars``: every named number of the round
    (losses, dual norm, residuals, weights; see docs/CONSENSUS.md) for the recorder."""

    loss: float
    grad_evals: int
    copies_used: int = 0
    diverged: bool = False
    scalars: dict[str, float] = field(default_factory=dict)
    nonfinite: tuple[str, ...] = ()
    """The deciding values that were non-finite (loss, theta_norm, a state key), named in the
    divergence reason."""

    @classmethod
    def from_scalars(cls, scalars: dict[str, float]) -> "RoundResult":
        """Build from a method's named scalars (keys ``loss``, ``grad_evals``, ``copies_used``,
        ``diverged``; all kept in ``scalars``)."""
        return cls(loss=float(scalars.get("loss", math.nan)), grad_evals=int(scalars.get("grad_evals", 1)),
                   copies_used=int(scalars.get("copies_used", 0)),
                   diverged=bool(scalars.get("diverged", 0.0)), scalars=scalars)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class AgentMetrics(_Model):
    """One agent's (or the centralised learner's) final state and the paper's metrics."""

    rounds: int = 0
    """Mapping rounds completed."""
    frames: int = 0
    """Frames its camera delivered."""
    busy_s: float = 0.0
    """Simulated seconds its compute clock was busy."""
    diverged: bool = False
    diverged_round: int | None = None
    diverged_reason: str | None = None
    failed_reason: str | None = None
    """Why this agent stopped on an error of its own (e.g. its frame reader failed: file and
    reason); its map is evaluated as it was then and the run's status is ``failed``."""
    artifacts_cm: float | None = None
    """Mean distance reconstruction -> ground truth (cm); None when not evaluated (see ``reason``)."""
    holes_cm: float | None = None
    """Mean distance ground truth -> reconstruction (cm)."""
    completion_ratio_pct: float | None = None
    """Share of ground-truth points within ``threshold_m`` of the reconstruction (%)."""
    threshold_m: float | None = None
    n_samples_gt: int | None = None
    n_samples_recon: int | None = None
    n_faces_gt: int | None = None
    n_faces_recon: int | None = None
    n_faces_mesh: int | None = None
    reason: str | None = None
    """Why the metrics are missing (no ground truth, empty mesh, diverged)."""
    own_coverage_pct: float | None = None
    """Share of the evaluated ground truth (culled to what any robot saw) that the cameras
    feeding this map saw (%)."""
    completion_own_pct: float | None = None
    """Completion ratio on that own part (%)."""
    holes_own_cm: float | None = None
    """Holes on that own part (cm)."""
    unseen_share_pct: float | None = None
    """Share of the evaluated ground truth that only teammates saw (%)."""
    completion_unseen_pct: float | None = None
    """Completion ratio on the part only teammates saw (%): what communication brought."""
    holes_unseen_cm: float | None = None
    """Holes on the part only teammates saw (cm)."""
    unseen_reason: str | None = None
    """Why the unseen-part metrics are missing (that part is empty)."""
    far_share_pct: float | None = None
    """Share of the evaluated ground truth that only robots beyond this map's neighbours on the
    communication graph saw (%): what reaches the map there crossed at least two links."""
    completion_far_pct: float | None = None
    """Completion ratio on that far part (%)."""
    holes_far_cm: float | None = None
    """Holes on that far part (cm)."""
    far_reason: str | None = None
    """Why the far-part metrics are missing (the part is empty, e.g. on a complete graph, or
    the graph changes with time)."""

    def metric(self, key: str) -> float:
        """A metric as a float (NaN when missing)."""
        value = getattr(self, key)
        return math.nan if value is None else float(value)


class MetricSummary(_Model):
    """Mean and population std over agents (and trials) of one metric, NaN entries excluded."""

    mean: float | None = None
    std: float | None = None
    min: float | None = None
    max: float | None = None
    n: int = 0
    n_nan: int = 0
    n_trials: int = 1


class RunResult(_Model):
    """Everything ``metrics.json`` holds about one run."""

    status: Status
    error: str | None = None
    scenario: str
    method: str
    seed: int
    n_agents: int
    success_rate: float
    sim_time_s: float
    """Simulated seconds reached."""
    wall_time_s: float
    """Wall-clock seconds of the run, from taking its folder (before building the simulation)
    to the end of the final evaluation: the one wall time the terminal, run.log and the sweep's
    ETA report (interpreter start-up and imports excluded; not reproducible, every other
    field is)."""
    per_agent: dict[str, AgentMetrics]
    summary: dict[str, MetricSummary]
    consensus_error: float | None
    """RMS over parameters of each map's distance to the mean map (Theta units)."""
    consensus_error_weighted: float | None = None
    """The same spread weighted per parameter by eq. 19's weights from the maps' visit counts
    (eq. CE-2 of docs/ALGORITHM.md; Theta units); None in runs made before it existed."""
    diverged_agents: list[str] = Field(default_factory=list)
    team_coverage_pct: float | None = None
    """Share of the whole ground-truth surface (area) that any robot's camera saw (%)."""
    communication: dict[str, Any] = Field(default_factory=dict)
    """Totals of the message log (sent, delivered, dropped by reason, bytes, latency, age)."""
    communication_links: dict[str, Any] = Field(default_factory=dict)
    """The same per directed link ``"i->j"``."""
    timeline: list[dict[str, Any]] = Field(default_factory=list)
    """Periodic evaluations: ``{t, agent, <metrics>}``."""
    consensus_timeline: list[dict[str, float]] = Field(default_factory=list)
    """Periodic probes ``{t, consensus_error, consensus_error_weighted, theta_rms}``: the maps'
    disagreement (RMS pairwise difference, unweighted CE-1 and weighted by eq. 19, CE-2) and
    their RMS magnitude, all in Theta units."""
    theta_bytes: int = 0
    """Size of one map's shared parameters (bytes, float32)."""
    build: dict[str, Any] | None = None
    """What computed the run (:func:`ramensim.observe.build_info`): CPU model, its widest SIMD
    (``avx512f``, ``avx2`` or ``baseline``), the kernels' ``-march`` target, torch's version
    and each map stage's backend (``c@1``: the C kernel on one thread). The kernels' vector
    width and the backends set the floating-point summation order, so two runs of one scenario
    and seed are identical bit for bit when these agree, and differ by rounding amplified over
    the run otherwise (docs/DESIGN.md, "Determinism"). From 2026-11-27 also the host (``cores``,
    ``gpu``, the ``host`` fingerprint) and the build (``commit``, ``dirty``, ``ramensim``, ``python``):
    ramensim/provenance.py lists them. None in runs made before 2026-11-25."""

    def messages_text(self) -> str:
        """The message totals in words: all sent, and how they ended (delivered, dropped, still
        in flight at the end); the delivered share is of those whose fate is known ('' when the
        run sent none)."""
        comm = self.communication
        done = int(comm.get("sent") or 0)  # the message log: messages whose fate is known
        flying = int(comm.get("in_flight") or 0)
        if not done and not flying:
            return ""
        delivered = int(comm.get("delivered") or 0)
        text = (f"{done + flying} sent: {delivered} delivered, {int(comm.get('dropped') or 0)} dropped"
                + (f", {flying} still in flight at the end" if flying else ""))
        return text + (f" ({100.0 * delivered / done:.1f} % of those whose fate is known delivered)" if done else "")

    def write(self, path: Path) -> None:
        """Atomic, deterministic JSON (sorted keys; NaN as null)."""
        atomic_write_json(Path(path), self.model_dump(mode="python"), sort_keys=True)

    @classmethod
    def read(cls, path: Path) -> "RunResult":
        """Parse a ``metrics.json``; ValueError naming the file if it is not one."""
        data = read_json(Path(path))
        if not isinstance(data, dict):
            raise ValueError(f"{path}: not a readable metrics.json (missing or not JSON).")
        return cls.model_validate(data)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready dict (what :meth:`write` writes)."""
        return self.model_dump(mode="json")

    def mean(self, key: str) -> float:
        """Mean over agents of one metric (NaN when none is finite)."""
        s = self.summary.get(key)
        return math.nan if s is None or s.mean is None else float(s.mean)
