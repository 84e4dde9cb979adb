"""The scenario schema: everything a run can set, with units and defaults.

Each package owns the settings of what it implements (channel, topology, world, map,
consensus, evaluation, recording); this module composes them and adds what belongs to
the simulation itself: agents, compute clocks, radio schedule and output.
"""
from __future__ import annotations

import math
from typing import Any, Iterator, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ramensim.agents.consensus import get_method, method_names
from ramensim.agents.consensus.registry import DEFAULT_METHOD
from ramensim.agents.consensus.config import ConsensusConfig
from ramensim.agents.map.config import MapConfig
from ramensim.channels.config import ChannelConfig, TopologyConfig
from ramensim.evaluation.config import EvalConfig
from ramensim.recording.config import RecordingConfig
from ramensim.world.config import WorldConfig


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)


class ComputeConfig(_Strict):
    """How much simulated time a mapping round costs on an agent's compute clock."""

    mode: Literal["model", "wall"] = "model"
    """'model': deterministic cost = iterations x seconds_per_iteration x speed factor; 'wall': measured wall time of the round x speed factor (not reproducible)."""
    seconds_per_iteration: float = Field(0.1, gt=0)
    """Simulated seconds one optimiser iteration costs at speed factor 1 (s)."""
    jitter: float = Field(0.0, ge=0, lt=1)
    """Relative seeded jitter of each round's cost: cost x U(1 - jitter, 1 + jitter) (fraction)."""


class AgentOverride(_Strict):
    """Settings of one agent that differ from the defaults."""

    speed_factor: float | None = Field(None, gt=0)
    """Multiplier on this agent's round cost (>1 = slower robot) (unitless)."""
    start_delay_s: float | None = Field(None, ge=0)
    """Simulated seconds before this agent starts capturing and mapping (s)."""


class AgentsConfig(_Strict):
    """The team of robots."""

    count: int = Field(3, ge=1, le=1000)
    """Number of agents (robots)."""
    speed_factor: float = Field(1.0, gt=0)
    """Default multiplier on every agent's round cost (unitless)."""
    start_delay_s: float = Field(0.0, ge=0)
    """Default simulated delay before an agent starts (s)."""
    overrides: dict[int, AgentOverride] = Field(default_factory=dict)
    """Per-agent overrides keyed by agent index (0-based)."""
    compute: ComputeConfig = Field(default_factory=ComputeConfig)
    """The compute-clock cost model shared by all agents."""

    def speed(self, agent: int) -> float:
        o = self.overrides.get(agent)
        return o.speed_factor if o is not None and o.speed_factor is not None else self.speed_factor

    def start_delay(self, agent: int) -> float:
        o = self.overrides.get(agent)
        return o.start_delay_s if o is not None and o.start_delay_s is not None else self.start_delay_s

    @model_validator(mode="after")
    def _overrides_exist(self) -> "AgentsConfig":
        bad = sorted(i for i in self.overrides if not 0 <= i < self.count)
        if bad:
            raise ValueError(f"overrides name agent(s) {bad} but agents.count is {self.count}, "
                             f"so valid indices are 0..{self.count - 1}")
        return self


class RadioConfig(_Strict):
    """When an agent sends its state (theta, visits) to its neighbours."""

    mode: Literal["every_round", "periodic"] = "every_round"
    """'every_round': after each mapping round; 'periodic': every period_s. Either way a link whose communication window is closed is skipped, and the latest state is sent when it opens."""
    period_s: float = Field(5.0, gt=0)
    """Seconds between sends in 'periodic' mode (s)."""


class OutputConfig(_Strict):
    """What a run writes into its folder."""

    dir: str = "runs"
    """Parent folder of run folders when --out is not given (path)."""
    save_meshes: bool = True
    """Write each agent's final mesh as PLY."""
    message_log: bool = True
    """Write the per-message log (messages.csv)."""
    flush_every_s: float | None = Field(10.0, gt=0)
    """Simulated seconds between atomic flushes of the results so far (metrics.json with status 'interrupted', messages.csv), so that a killed run loses at most this much; None = only at the end and after each periodic evaluation (s)."""


class RunConfig(_Strict):
    """How a run treats the robots' own faults."""

    on_robot_error: Literal["isolate", "stop"] = "isolate"
    """When one robot's round raises (a method's bug, a plugin's exception): mark that robot failed with its reason and let the others map to the end and be scored (isolate), or end the whole run as failed (stop)."""


class Scenario(_Strict):
    """A complete description of one simulation run."""

    name: str = "scenario"
    """A label for the run (used in the run folder's name)."""
    seed: int = Field(0, ge=0)
    """Root seed; every component draws its own generator from it."""
    duration: float = Field(60.0, gt=0)
    """Simulated seconds to run."""
    method: str = Field(DEFAULT_METHOD, json_schema_extra=lambda schema: schema.update(enum=list(method_names())))
    """Consensus method, any registered one: ramen, dinno, dsgd, dsgt, local (no communication) or centralised (one learner with all data) are built in; a plugin adds others."""
    plugins: list[str] = Field(default_factory=list, max_length=64)
    """Plugin files (.py, relative to the scenario file's folder) or module names, loaded before the scenario is checked: each registers a consensus method, a radio model (channel.<name>) or a scene (docs/EXTENDING.md)."""
    world: WorldConfig = Field(default_factory=WorldConfig)
    """Scene, trajectories and camera."""
    agents: AgentsConfig = Field(default_factory=AgentsConfig)
    """The robots and their compute clocks."""
    map: MapConfig = Field(default_factory=MapConfig)
    """The neural implicit map every agent trains."""
    consensus: ConsensusConfig = Field(default_factory=ConsensusConfig)
    """Hyperparameters of the consensus methods and the stale-copy policy."""
    channel: ChannelConfig = Field(default_factory=ChannelConfig)
    """The radio channel: loss, latency, bandwidth, windows, range."""
    topology: TopologyConfig = Field(default_factory=TopologyConfig)
    """The communication graph."""
    radio: RadioConfig = Field(default_factory=RadioConfig)
    """When agents send their state."""
    evaluation: EvalConfig = Field(default_factory=EvalConfig)
    """Mesh extraction and the paper's metrics."""
    recording: RecordingConfig = Field(default_factory=RecordingConfig)
    """Streaming to Rerun."""
    output: OutputConfig = Field(default_factory=OutputConfig)
    """What the run folder receives."""
    run: RunConfig = Field(default_factory=RunConfig)
    """How the run treats one robot's error (isolate | stop)."""

    @model_validator(mode="before")
    @classmethod
    def _raw_values_bounded(cls, data: Any) -> Any:
        """Every number finite and every integer bounded, every string bounded, before any
        sub-model sees the values (one mechanism for every key, see :func:`check_values`)."""
        problems = [p for p in (_value_problem(path, v) for path, v in _walk_raw(data)) if p]
        if problems:
            raise ValueError(_join(problems))
        return data

    @model_validator(mode="after")
    def _values_finite_and_in_range(self) -> "Scenario":
        """Validated values (strings like 'inf' turned into floats included) finite and within
        :data:`RANGES`; then the event budget (:mod:`ramensim.budget`)."""
        from ramensim.budget import check_budget

        problems = [p for p in (_value_problem(path, v) for path, v in _walk_model(self)) if p]
        for path, (lo, hi) in RANGES.items():
            value = _get(self, path)
            if value is not None and not (lo <= value <= hi):
                problems.append(f"key '{path}' has value {value!r}; expected a number in [{lo}, {hi}]")
        for low, high in ORDERED:
            a, b = _get(self, low), _get(self, high)
            if a is not None and b is not None and not a < b:
                problems.append(f"key '{low}' has value {a!r}, not below key '{high}' = {b!r}; expected "
                                f"{low} < {high}")
        if problems:
            raise ValueError(_join(problems))
        check_budget(self)
        return self

    @model_validator(mode="wrap")
    @classmethod
    def _no_booleans_as_numbers(cls, data: Any, handler: Any) -> "Scenario":
        """A YAML boolean (``true``, ``false``) where a number is expected is refused: pydantic
        would read it as 1 or 0 (``agents.count: true`` would mean one robot)."""
        model = handler(data)
        problems: list[str] = []
        _bools_as_numbers(data, model, "", problems)
        if problems:
            raise ValueError(_join(problems))
        return model

    @field_validator("method")
    @classmethod
    def _registered(cls, name: str) -> str:
        return get_method(name).name  # ValueError naming the registered methods; aliases resolved

    @model_validator(mode="after")
    def _wire_fits_the_method(self) -> "Scenario":
        """``consensus.wire`` names only arrays the method sends with these settings, each with
        a wire type of its kind (float: float32 / float16; integer: int32 / uint16 / uint8), and
        only with a dense encoding (``agents/encoding.py``)."""
        wire = self.consensus.wire
        if not wire:
            return self
        if self.consensus.encoding == "sparse":
            raise ValueError(f"key 'consensus.wire' has value {wire!r} with consensus.encoding 'sparse'; "
                             "expected no per-array wire types (sparse sends float32 / int32 values at its "
                             "index list) or consensus.encoding float32 or float16")
        spec = get_method(self.method)
        arrays = spec.message_arrays(self.consensus) if spec.message_arrays is not None else {}
        sent = ", ".join(f"{k} ({v})" for k, v in arrays.items()) or "none"
        for key, wt in wire.items():
            kind = arrays.get(key)
            if kind is None and not arrays:
                raise ValueError(f"key 'consensus.wire.{key}' has value {wt!r}, but method '{self.method}' "
                                 "sends no messages (or declares no message arrays); expected no consensus.wire")
            if kind is None:
                why = (f" (lam, this end's half of a link's dual, is sent only with consensus.dual_update "
                       f"'antisymmetric', not '{self.consensus.dual_update}')" if key == "lam" else "")
                raise ValueError(f"key 'consensus.wire.{key}' has value {wt!r}, but method '{self.method}' "
                                 f"sends no array {key!r}{why}; expected one of the arrays it sends: {sent}")
            allowed = ("float32", "float16") if kind == "float" else ("int32", "uint16", "uint8")
            if wt not in allowed:
                raise ValueError(f"key 'consensus.wire.{key}' has value {wt!r}, but {key!r} is "
                                 f"{'a float' if kind == 'float' else 'an integer'} array of method "
                                 f"'{self.method}'; expected one of {', '.join(allowed)}")
        return self

    @model_validator(mode="after")
    def _graph_fits_the_team(self) -> "Scenario":
        """Checks that need the number of agents: explicit edges and window schedules."""
        from ramensim.channels.topology import build_graph
        from ramensim.channels.windows import Windows

        if self.topology.kind != "disk":
            build_graph(self.topology, self.agents.count)  # ValueError names the bad edge
        Windows(self.channel.windows, self.agents.count)
        return self


MAX_INT = 2 ** 63 - 1
"""Largest magnitude of any integer key (seeds included): it fits a signed 64-bit integer."""
MAX_FLOAT = 1e12
"""Largest magnitude of any real-valued key. In the schema's units (s, m, bit/s, dB, px, ...)
nothing a run can use needs more, and values far beyond it overflow float32 in the maps
(``map.near: 1e300`` ended a run with 'value cannot be converted to type float')."""
MAX_STR = 4096
"""Longest string value (names, paths, URLs), characters."""
RANGES: dict[str, tuple[float, float]] = {
    "world.trajectory.waypoints": (2, 10_000),
    "world.camera.keyframe_every": (1, 1_000_000),
    "map.min_current_rays": (0, 1_000_000),
    "map.chunk": (1024, 1 << 24),
    "recording.scalar_flush_rows": (1, 10_000_000),
    "topology.star_centre": (0, 63),
    "world.scene.crop_edge": (0, 10_000),
    "world.scene.stride": (1, 1_000_000),
}
"""Upper bounds of the counts whose own model leaves them open (inclusive)."""
ORDERED: tuple[tuple[str, str], ...] = (
    ("evaluation.near_m", "evaluation.far_m"),
)
"""Pairs of keys (low, high) that must satisfy low < high, where their own model does not check
it (``evaluation.near_m: 2e6`` passed validation and stopped the run at its first evaluation)."""


def _bools_as_numbers(raw: Any, value: Any, path: str, problems: list[str], depth: int = 0) -> None:
    """Paths where the document gave a boolean and the validated value is a number."""
    if depth > 64:
        return
    if isinstance(raw, bool):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            problems.append(f"key '{_short(path)}' has value {raw!r}; expected a number, not a boolean")
        return
    if isinstance(raw, dict):
        for k, v in raw.items():
            if isinstance(value, BaseModel):
                sub = getattr(value, k, None) if isinstance(k, str) and k in type(value).model_fields else None
            elif isinstance(value, dict):
                sub = value.get(k, value.get(int(k)) if isinstance(k, str) and k.isdigit() else None)
            else:
                continue
            _bools_as_numbers(v, sub, f"{path}.{k}" if path else str(k), problems, depth + 1)
    elif isinstance(raw, (list, tuple)) and isinstance(value, (list, tuple)):
        for i, (r, v) in enumerate(zip(raw, value)):
            _bools_as_numbers(r, v, f"{path}[{i}]", problems, depth + 1)


def _walk_raw(data: Any, path: str = "", depth: int = 0) -> Iterator[tuple[str, Any]]:
    if depth > 64:
        return
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _walk_raw(v, f"{path}.{k}" if path else str(k), depth + 1)
    elif isinstance(data, (list, tuple)):
        for i, v in enumerate(data):
            yield from _walk_raw(v, f"{path}[{i}]", depth + 1)
    else:
        yield path, data


def _walk_model(value: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(value, BaseModel):
        for name in type(value).model_fields:
            yield from _walk_model(getattr(value, name), f"{path}.{name}" if path else name)
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _walk_model(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from _walk_model(v, f"{path}[{i}]")
    else:
        yield path, value


def _short(text: str, n: int = 80) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _value_problem(path: str, value: Any) -> str | None:
    """Why ``value`` at ``path`` is refused whatever the key (None: fine)."""
    key = _short(path or "(top level)")
    if isinstance(value, bool):
        return None
    if isinstance(value, float) and not math.isfinite(value):
        return f"key '{key}' has value {value!r}; expected a finite number"
    if isinstance(value, float) and abs(value) > MAX_FLOAT:
        return f"key '{key}' has value {value!r}; expected a number of magnitude at most {MAX_FLOAT:g}"
    if isinstance(value, int) and abs(value) > MAX_INT:
        return f"key '{key}' has an integer of {len(str(abs(value)))} digits; expected at most {MAX_INT}"
    if isinstance(value, str):
        if len(value) > MAX_STR:
            return f"key '{key}' has a string of {len(value)} characters; expected at most {MAX_STR}"
        if "\x00" in value:
            return f"key '{key}' has value {_short(repr(value))}; expected text without NUL characters"
    return None


def _join(problems: list[str], limit: int = 20) -> str:
    extra = f"; and {len(problems) - limit} more" if len(problems) > limit else ""
    return "; ".join(problems[:limit]) + extra


def _get(model: Any, path: str) -> Any:
    for part in path.split("."):
        model = getattr(model, part, None)
        if model is None:
            return None
    return model
