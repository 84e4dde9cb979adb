"""Sweep files: a base scenario, fixed overrides and axes whose cartesian product is the set
of runs (the paper's Fig. 5 / Fig. 7 / Table I experiments are each one sweep).

A sweep file is YAML::

    name: comm_rate                      # optional; defaults to the file's stem
    base: ../office_3agents.yaml         # relative to this sweep file
    set: {duration: 60}                  # fixed dotted-key overrides for every point
    axes:                                # dotted key -> list of values; product over all axes
      method: [ramen, dinno]
      channel.success_rate: [1.0, 0.5, 0.2]
      seed: [0, 1, 2]
    variants:                            # optional: named groups of overrides, one more axis
      ramen: {method: ramen}             # ('variant', the last and fastest) whose values are
      dinno: {method: dinno}             # the names; a group sets several keys at once
    trials:                              # optional: replicate keys advanced together (zipped),
      - {seed: 10, world.scene.seed: 10} # the slowest; each entry one independent trial, crossed
      - {seed: 11, world.scene.seed: 11} # with the axes (not with each other)

A trial is one combination of the replicate keys (keys whose last part is ``seed``). Crossing a
``seed`` axis with a ``world.scene.seed`` axis gives trials that share their channel realisation
(the channel is keyed by the run seed); ``trials`` gives each layout its own run seed, hence its
own channel, while the methods of one trial keep common random numbers.

Every point is validated against the scenario schema before anything runs.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ramensim.core.errors import InputError

_KEY_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$")
_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")
MAX_NAME_LEN = 180
"""Longest point folder name (characters) before it is shortened with a hash suffix."""


class SweepSpec(BaseModel):
    """The content of a sweep file (see the module docstring)."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, populate_by_name=True)

    name: str | None = Field(None, min_length=1, max_length=100)
    """Name of the sweep (free text, used for the default output folder); default: the sweep file's stem."""
    description: str | None = Field(None, min_length=1, max_length=4000)
    """What the sweep is, in a sentence or two (free text): the captions of 'ramensim report --style paper' open with it; default: the file's leading comment block."""
    base: str = ""
    """Path of the base scenario YAML, relative to the sweep file (path); required."""
    fixed: dict[str, Any] = Field(default_factory=dict, alias="set")
    """Overrides applied to every point, dotted key -> value (units of the scenario key)."""
    axes: dict[str, list[Any]] = Field(default_factory=dict)
    """Swept keys, dotted key -> list of values (units of the scenario key); points are their cartesian product."""
    plugins: list[str] = Field(default_factory=list, max_length=64)
    """Plugin files (.py, relative to the sweep file) or module names every point loads, beside the base scenario's own (docs/EXTENDING.md)."""
    variants: dict[str, dict[str, Any]] = Field(default_factory=dict)
    """Named groups of overrides, variant name -> {dotted key: value}: one more axis, 'variant', the last (fastest), whose values are the names; each point applies its group after 'set' and the axes, so one condition can set several keys together (e.g. RAMEN, RAMEN at DiNNO's bytes, DiNNO)."""
    trials: list[dict[str, Any]] = Field(default_factory=list, max_length=10_000)
    """Independent trials, each a mapping of replicate keys (keys ending in 'seed') to values, all entries naming the same keys: the keys advance together (zipped, not crossed), slowest of all, and every trial is crossed with the axes; e.g. [{seed: 10, world.scene.seed: 10}, {seed: 11, world.scene.seed: 11}] gives each layout its own run seed, hence its own channel realisation."""

    @field_validator("base")
    @classmethod
    def _base_given(cls, v: str) -> str:
        if not v.strip():
            raise ValueError("a path to the base scenario YAML (relative to the sweep file), "
                             "e.g. 'base: ../office_3agents.yaml'")
        return v

    @field_validator("fixed", "axes")
    @classmethod
    def _dotted_keys(cls, v: dict[str, Any]) -> dict[str, Any]:
        for key in v:
            if not _KEY_RE.match(key):
                raise ValueError(f"dotted scenario keys like 'channel.success_rate', got {key!r}")
        return v

    @field_validator("axes")
    @classmethod
    def _axis_values(cls, v: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in v.items():
            if not values:
                raise ValueError(f"axis {key!r} to list at least one value")
            seen: set[str] = set()
            for value in values:
                canon = _canonical(value)
                if canon in seen:
                    raise ValueError(f"axis {key!r} to list distinct values, but {value!r} appears twice")
                seen.add(canon)
        return v


    @field_validator("trials")
    @classmethod
    def _trial_entries(cls, v: list[dict[str, Any]]) -> list[dict[str, Any]]:
        if not v:
            return v
        keys = list(v[0])
        seen: set[str] = set()
        for i, entry in enumerate(v):
            if not entry:
                raise ValueError(f"trial {i} to name at least one replicate key, e.g. {{seed: 10}}")
            bad = [k for k in entry if not _KEY_RE.match(k) or not is_replicate_axis(k)]
            if bad:
                raise ValueError(f"trial {i} to name replicate keys only (dotted keys whose last part is "
                                 f"'seed', e.g. 'seed', 'world.scene.seed'), got {bad[0]!r}")
            if list(entry) != keys:
                raise ValueError(f"every trial to name the same keys in the same order as the first "
                                 f"({', '.join(keys)}); trial {i} names {', '.join(entry)}")
            canon = _canonical(entry)
            if canon in seen:
                raise ValueError(f"distinct trials, but trial {i} ({entry}) appears twice")
            seen.add(canon)
        return v

    @field_validator("variants")
    @classmethod
    def _variant_groups(cls, v: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        for name, group in v.items():
            if not _VARIANT_RE.match(str(name)):
                raise ValueError(f"variant names of letters, digits and '_', '-', '.', '+' (a folder name), "
                                 f"got {name!r}")
            for key in group:
                if not _KEY_RE.match(key):
                    raise ValueError(f"variant {name!r} to map dotted scenario keys like 'consensus.wire', "
                                     f"got {key!r}")
        return v


VARIANT_AXIS = "variant"
"""The axis a sweep file's ``variants`` form (values: the variant names)."""
_VARIANT_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,59}$")


def is_replicate_axis(key: str) -> bool:
    """Axes whose last dotted component is ``seed`` are repetitions, not conditions:
    aggregation pools them (mean +- std over agents and seeds)."""
    return key.rsplit(".", 1)[-1] == "seed"


@dataclass(frozen=True)
class SweepPoint:
    """One run of a sweep."""

    name: str
    """Folder name, e.g. ``method=ramen__channel.success_rate=0.5__seed=0``."""
    axes: dict[str, Any]
    """This point's value of every axis, in axis order."""
    data: dict[str, Any] = field(repr=False)
    """The resolved scenario dict (base + set + axes), not yet validated."""
    fingerprint: str = ""
    """sha256 (hex, 16 chars) of the resolved scenario; a stored result with another one is stale."""


@dataclass(frozen=True)
class SweepPlan:
    """A loaded, expanded and validated sweep."""

    source: Path
    """The sweep file."""
    name: str
    """Sweep name."""
    base: Path
    """Absolute path of the base scenario."""
    fixed: dict[str, Any]
    """The ``set`` overrides."""
    axes: dict[str, list[Any]]
    """The axes, in file order."""
    points: list[SweepPoint]
    """The cartesian product, first axis slowest."""
    overrides: dict[str, Any] = field(default_factory=dict)
    """``--set`` overrides given on the command line (or ``overrides=`` in the API), applied to
    every point after the file's ``set``; also part of ``fixed``."""
    variants: dict[str, dict[str, Any]] = field(default_factory=dict)
    """The file's ``variants``: name -> the overrides a point of that ``variant`` applies."""
    description: str | None = None
    """The file's ``description`` (captions of a paper-style report), None when it has none."""
    trials: list[dict[str, Any]] = field(default_factory=list)
    """The file's ``trials`` (zipped replicate keys, slowest); their keys are also in ``axes``
    (values in trial order), but the points hold only the listed combinations of them."""

    @property
    def folder_name(self) -> str:
        """The default output folder's name: the sweep's name, plus the ``--set`` overrides when
        there are any (``paper_fig5__duration=10``), so that a shortened sweep never makes the
        full sweep's stored results stale."""
        return self.name if not self.overrides else f"{self.name}__{point_name(self.overrides)}"

    def to_json(self) -> dict[str, Any]:
        """The plan as JSON-able data (``sweep.json`` in the output folder; ``ramensim report`` reads it)."""
        return {
            "name": self.name,
            "source": str(self.source),
            "base": str(self.base),
            "set": self.fixed,
            "overrides": self.overrides,
            "axes": self.axes,
            **({"variants": self.variants} if self.variants else {}),
            **({"description": self.description} if self.description else {}),
            **({"trials": self.trials} if self.trials else {}),
            "points": [{"name": p.name, "axes": p.axes, "fingerprint": p.fingerprint} for p in self.points],
        }


def _canonical(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=str, separators=(",", ":"))


def fingerprint(data: Mapping[str, Any]) -> str:
    """sha256 of the canonical JSON of a resolved scenario dict (first 16 hex chars)."""
    return hashlib.sha256(_canonical(data).encode("utf-8")).hexdigest()[:16]


def format_value(value: Any) -> str:
    """A readable, filesystem-safe rendering of one axis value (``0.5``, ``true``, ``ramen``)."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif value is None:
        text = "null"
    elif isinstance(value, float):
        text = repr(value) if math.isfinite(value) else str(value)  # 1.0 stays '1.0'
    elif isinstance(value, (int, str)):
        text = str(value)
    else:
        text = _canonical(value)
    text = _UNSAFE.sub("-", text).strip("-.") or "_"
    return text


def point_name(axes: Mapping[str, Any]) -> str:
    """Stable, readable folder name of a point: ``key=value`` joined by ``__`` in axis order;
    too long names keep a prefix plus a hash of the full values."""
    if not axes:
        return "base"
    name = "__".join(f"{k}={format_value(v)}" for k, v in axes.items())
    if len(name) > MAX_NAME_LEN:
        digest = hashlib.sha256(_canonical(dict(axes)).encode()).hexdigest()[:10]
        name = name[: MAX_NAME_LEN - 12].rstrip("_-.") + "__" + digest
    return name


def expand(axes: Mapping[str, list[Any]]) -> list[dict[str, Any]]:
    """Cartesian product of the axes (first axis slowest); no axes -> one empty point."""
    keys = list(axes)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(axes[k] for k in keys))]


def _unique_names(combos: list[dict[str, Any]]) -> list[str]:
    names = [point_name(c) for c in combos]
    counts: dict[str, int] = {}
    for n in names:
        counts[n] = counts.get(n, 0) + 1
    out = []
    for n, c in zip(names, combos):
        if counts[n] > 1:  # two values sanitise alike (e.g. 'a/b' and 'a-b'): disambiguate by hash
            n = f"{n}__{hashlib.sha256(_canonical(c).encode()).hexdigest()[:8]}"
        out.append(n)
    return out


def load_spec(path: str | Path) -> SweepSpec:
    """Read and check a sweep file; any problem is an InputError naming the file and key."""
    from ramensim.config import load_yaml

    p = Path(path)
    raw = load_yaml(p)
    if not isinstance(raw, dict):
        raise InputError(f"{p}: the top level is a {type(raw).__name__}, expected a sweep mapping with "
                         f"keys 'base' (scenario path), optional 'name', 'set' and 'axes'.")
    try:
        spec = SweepSpec.model_validate(raw)
    except ValidationError as exc:
        problems = []
        for err in exc.errors(include_url=False):
            loc = ".".join(str(x) for x in err.get("loc", ())) or "(top level)"
            kind = err.get("type", "")
            if kind == "extra_forbidden":
                problems.append(f"unknown key '{loc}' (a sweep file has 'name', 'description', 'base', "
                                f"'set', 'axes', 'variants', 'trials' and 'plugins')")
            elif kind == "missing":
                problems.append(f"key '{loc}' is required but missing")
            else:
                msg = err.get("msg", "invalid value")
                if msg.startswith("Value error, "):
                    msg = msg[len("Value error, "):]
                shown = repr(err.get("input"))
                shown = shown if len(shown) <= 80 else shown[:77] + "..."
                problems.append(f"key '{loc}' has value {shown}; expected {msg}")
        raise InputError(f"{p}: invalid sweep file: " + "; ".join(problems) + ".") from None
    if "base" not in raw:
        raise InputError(f"{p}: invalid sweep file: key 'base' is required but missing; expected the path "
                         f"of the base scenario YAML relative to the sweep file, e.g. 'base: ../office.yaml'.")
    both = sorted(set(spec.fixed) & set(spec.axes))
    if both:
        raise InputError(f"{p}: key {both[0]!r} is both under 'set' and under 'axes'; a key is either fixed "
                         f"for every point or swept, not both.")
    if spec.variants and VARIANT_AXIS in spec.axes:
        raise InputError(f"{p}: key 'axes.{VARIANT_AXIS}': '{VARIANT_AXIS}' is the axis the file's 'variants' "
                         f"form; name the scenario key swept there differently or drop 'variants'.")
    trial_keys = list(spec.trials[0]) if spec.trials else []
    for key in trial_keys:
        where = "'set'" if key in spec.fixed else "'axes'" if key in spec.axes else \
            next((f"'variants.{n}'" for n, g in spec.variants.items() if key in g), None)
        if where:
            raise InputError(f"{p}: key 'trials' names {key!r}, which is also under {where}; a replicate key is "
                             f"either advanced by the trials or fixed/swept elsewhere, not both.")
    for name, group in spec.variants.items():
        clash = sorted(set(group) & (set(spec.fixed) | set(spec.axes)))
        if clash:
            where = "'set'" if clash[0] in spec.fixed else "'axes'"
            raise InputError(f"{p}: key 'variants.{name}.{clash[0]}' is also under {where}; a key is fixed, "
                             f"swept or set by the variants, one of the three.")
    return spec


def plan_sweep(path: str | Path, *, validate_fn: Callable[[dict[str, Any], str], Any] | None = None,
               load_fn: Callable[[Path], dict[str, Any]] | None = None, plugins: Iterable[str] = (),
               overrides: Iterable[str] | Mapping[str, Any] = ()) -> SweepPlan:
    """Load a sweep file, expand its axes and validate every point's scenario up front.

    ``validate_fn(data, source)`` defaults to :func:`ramensim.config.validate` and ``load_fn``
    to :func:`ramensim.config.load_scenario_dict`; both are injectable for tests. Raises
    InputError naming the sweep file, the first bad point and the scenario problem.
    ``overrides`` (``--set KEY=V`` strings or a mapping) apply to every point after the file's
    ``set`` (replacing its value of a key); a key that is an axis is refused.
    ``plugins`` (``--plugin``: files relative to the working directory, or modules) join the
    sweep file's ``plugins`` and the base scenario's: every point's resolved scenario lists
    them all as absolute paths, so each worker loads the same ones before it runs the point.
    """
    from ramensim import config

    p = Path(path)
    spec = load_spec(p)
    validate_fn = validate_fn or config.validate
    load_fn = load_fn or config.load_scenario_dict
    base = (p.parent / spec.base).resolve()
    if not base.is_file():
        raise InputError(f"{p}: key 'base' is {spec.base!r}, which resolves to {base}, and no such file "
                         f"exists; expected a scenario YAML path relative to the sweep file.")
    base_data = load_fn(base)
    base_data, shared = _resolve_plugins(p, spec, base, base_data, plugins)
    overrides = overrides if isinstance(overrides, Mapping) else [str(o) for o in overrides]
    extra = _cli_overrides(p, spec, overrides)
    try:
        fixed_data = config.apply_overrides(base_data, spec.fixed)
    except InputError as exc:
        raise InputError(f"{p}: key 'set' cannot be applied to {base}: {exc}") from None
    if extra:  # strings as given, so that an error names the key as '(--set)'
        fixed_data = config.apply_overrides(fixed_data, overrides if not isinstance(overrides, Mapping) else extra)
    axes = {**spec.axes, **({VARIANT_AXIS: list(spec.variants)} if spec.variants else {})}
    combos = expand(axes)
    if spec.trials:  # zipped replicate keys, slowest: each trial crossed with the axes
        combos = [{**trial, **combo} for trial in spec.trials for combo in combos]
        trial_axes: dict[str, list[Any]] = {}
        for trial in spec.trials:
            for k, v in trial.items():
                if _canonical(v) not in {_canonical(x) for x in trial_axes.setdefault(k, [])}:
                    trial_axes[k].append(v)
        axes = {**trial_axes, **axes}
    names = _unique_names(combos)
    points: list[SweepPoint] = []
    bad: list[tuple[str, str]] = []
    for name, combo in zip(names, combos):
        try:
            swept = {k: v for k, v in combo.items() if not (spec.variants and k == VARIANT_AXIS)}
            data = config.apply_overrides(fixed_data, swept)
            if spec.variants:
                data = config.apply_overrides(data, spec.variants[combo[VARIANT_AXIS]])
            data = _point_plugins(p, data, shared)
            validate_fn(data, str(base))
        except InputError as exc:
            bad.append((name, str(exc)))
            continue
        points.append(SweepPoint(name=name, axes=combo, data=data, fingerprint=fingerprint(data)))
    if bad:
        first_name, first_msg = bad[0]
        more = f" ({len(bad) - 1} more of {len(combos)} points are invalid too)" if len(bad) > 1 else ""
        raise InputError(f"{p}: sweep point '{first_name}' (base {base} with 'set' and these axis values) "
                         f"is not a valid scenario{more}: {first_msg}")
    return SweepPlan(source=p.resolve(), name=spec.name or p.stem, base=base, fixed={**spec.fixed, **extra},
                     axes={k: list(v) for k, v in axes.items()}, points=points, overrides=extra,
                     variants={k: dict(v) for k, v in spec.variants.items()},
                     description=" ".join(spec.description.split()) if spec.description else None,
                     trials=[dict(t) for t in spec.trials])


def _cli_overrides(p: Path, spec: SweepSpec, overrides: Iterable[str] | Mapping[str, Any]) -> dict[str, Any]:
    """``--set`` overrides as a dict (values parsed as YAML); InputError for a swept key."""
    from ramensim.config import parse_override

    items = dict(overrides) if isinstance(overrides, Mapping) else dict(parse_override(o) for o in overrides)
    for key in items:
        setters = [name for name, group in spec.variants.items()
                   if any(key == g or key.startswith(g + ".") or g.startswith(key + ".") for g in group)]
        if setters:
            raise InputError(f"{p}: --set {key}=...: {key!r} is set by the variant(s) "
                             f"{', '.join(setters)} of this sweep; --set fixes a key for every point, "
                             f"--only {VARIANT_AXIS}=NAME runs the points of some variants.")
        if spec.trials and key in spec.trials[0]:
            raise InputError(f"{p}: --set {key}=...: {key!r} is advanced by this sweep's 'trials'; --set "
                             f"fixes a key for every point, --only {key}=V runs the points of some trials.")
        if key in spec.axes:
            raise InputError(f"{p}: --set {key}=...: {key!r} is an axis of this sweep (values "
                             f"{', '.join(format_value(v) for v in spec.axes[key])}); --set fixes a key for every "
                             f"point, --only {key}=V runs the points of some of its values.")
    return items


def _resolve_plugins(p: Path, spec: SweepSpec, base: Path, base_data: Any,
                     extra: Iterable[str]) -> tuple[Any, list[str]]:
    """(base scenario with its plugin files absolute, the plugins every point adds: the sweep
    file's and ``--plugin``'s, absolute), after loading them all (InputError naming the file)."""
    from ramensim import plugins as plug
    from ramensim.config import ScenarioDoc

    if isinstance(base_data, dict) and base_data.get("plugins") is not None:
        resolved = plug.resolve(base_data["plugins"], base.parent, str(base))
        if isinstance(base_data, ScenarioDoc):
            base_data = ScenarioDoc({**base_data, "plugins": resolved}, base_data.lines, base_data.overridden)
        else:
            base_data = {**base_data, "plugins": resolved}
        plug.load_plugins(resolved, None, f"{base} (key 'plugins')")
    shared = plug.load_plugins(spec.plugins, p.parent, f"{p} (key 'plugins')")
    for entry in plug.load_plugins(list(extra), None, "--plugin", "--plugin"):
        if entry not in shared:
            shared.append(entry)
    return base_data, shared


def _point_plugins(p: Path, data: Any, shared: list[str]) -> Any:
    """A point's scenario with the shared plugins added; plugin files a ``set`` or an axis
    gave resolve against the sweep file's folder (the base scenario's are absolute already)."""
    own = data.get("plugins")
    if own is None and not shared:
        return data
    from ramensim import plugins as plug
    from ramensim.config import apply_overrides

    listed = plug.resolve(own or [], p.parent, str(p))
    merged = listed + [e for e in shared if e not in listed]
    return data if merged == own else apply_overrides(data, {"plugins": merged})


def _same_axis_value(axis_value: Any, given: Any) -> bool:
    """Whether ``given`` (from ``--only``: usually text) names ``axis_value``: equal, written as
    in the point's folder name, or, for a numeric axis value, the same number however it is
    written (``1.0e-6``, ``1e-6`` and ``0.000001`` all name ``1e-06``)."""
    if axis_value == given or format_value(axis_value) == format_value(given):
        return True
    if isinstance(axis_value, (int, float)) and not isinstance(axis_value, bool) and isinstance(given, str):
        try:
            return float(given) == float(axis_value)
        except ValueError:
            return False
    return False


def select_points(plan: SweepPlan, only: Mapping[str, Any] | list[str] | tuple[str, ...] | None) -> set[str]:
    """Names of the points whose axis values match ``only`` (``ramensim sweep --only``): a
    mapping axis -> value or list of values, or ``AXIS=V1,V2`` strings; a point matches when,
    for every axis named, its value is one of those given (a value matches an axis value equal
    to it, written as in the point's folder name: ``channel.success_rate=1.0``, or the same number
    written otherwise: ``beta_l=1.0e-6`` for ``1e-06``). Axes not
    named are not restricted; no ``only``: every point. The plan itself stays whole, so the
    sweep's report counts the points not run yet. Raises InputError naming the sweep file for
    an axis it does not have or a value not on the axis."""
    if not only:
        return {p.name for p in plan.points}
    wanted: dict[str, list[Any]] = {}
    if isinstance(only, Mapping):
        for key, val in only.items():
            wanted.setdefault(str(key), []).extend(val if isinstance(val, (list, tuple)) else [val])
    else:
        for text in only:
            key, sep, raw = str(text).partition("=")
            if not sep or not key.strip() or not raw.strip():
                raise InputError(f"--only {text!r}: expected AXIS=VALUE[,VALUE...], e.g. --only seed=0,1 "
                                 f"(axes of {plan.source.name}: {', '.join(plan.axes) or 'none'}).")
            wanted.setdefault(key.strip(), []).extend(v.strip() for v in raw.split(","))
    keep: dict[str, list[Any]] = {}
    for key, vals in wanted.items():
        if key not in plan.axes:
            raise InputError(f"{plan.source}: --only names the axis {key!r}, which the sweep does not have; "
                             f"its axes are {', '.join(plan.axes) or 'none (a single point)'}.")
        axis = plan.axes[key]
        chosen = []
        for v in vals:
            hits = [a for a in axis if _same_axis_value(a, v)]
            if not hits:
                raise InputError(f"{plan.source}: --only {key}={v}: not a value of the axis {key!r}; its values "
                                 f"are {', '.join(format_value(a) for a in axis)}.")
            chosen.extend(hits)
        keep[key] = chosen
    return {p.name for p in plan.points
            if all(any(p.axes[k] == c and type(p.axes[k]) is type(c) for c in cs) for k, cs in keep.items())}
