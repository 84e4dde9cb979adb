"""Reading scenario files: YAML (safe and bounded, :mod:`ramensim.yamlsafe`), ``--set
dotted.key=value`` overrides, and validation into :class:`ramensim.schema.Scenario` with
one-paragraph error messages (at most :data:`MAX_PROBLEMS` problems listed)."""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml
from pydantic import ValidationError

from ramensim.core.errors import InputError
from ramensim.yamlsafe import MAX_BYTES, YAMLLimitError, safe_load_bounded

_MISSING = object()
MAX_PROBLEMS = 20
"""Problems listed in one validation error; the rest are counted ("and N more")."""
_YAML11_WORDS = {"on", "off", "yes", "no", "y", "n"}


class ScenarioDoc(dict):
    """A scenario document read from a file: a plain dict that also knows the line of every
    key (``lines``: path of keys as strings -> 1-based line, :func:`ramensim.yamlsafe.node_lines`)
    and which keys an override replaced (``overridden``: path -> '--set' for the command line's
    ``key=value`` strings, 'override' for a mapping such as a sweep point's), so validation
    errors can name the line or the override."""

    def __init__(self, data: Mapping[str, Any] = (), lines: dict[tuple[str, ...], int] | None = None,
                 overridden: dict[tuple[str, ...], str] | None = None) -> None:
        super().__init__(data)
        self.lines = dict(lines or {})
        self.overridden = dict(overridden or {})

    def __reduce__(self):  # pickles (sweep workers) as a ScenarioDoc with its lines
        return (ScenarioDoc, (dict(self), self.lines, self.overridden))

    def where(self, parts: Iterable[Any]) -> str | None:
        """'line N' of the key ``parts`` (a pydantic loc or a key path; parts that name no key,
        such as union tags, are skipped), the override's origin ('--set', 'override') when one
        gave it, None when the file does not write that key."""
        given = {o[:i] for o in self.overridden for i in range(1, len(o) + 1)}
        path: tuple[str, ...] = ()
        matched = False
        for part in parts:
            cand = path + (str(part),)
            matched = cand in self.lines or cand in given
            if matched:
                path = cand
        for i in range(len(path), 0, -1):  # inside a value an override gave
            if path[:i] in self.overridden:
                return self.overridden[path[:i]]
        if not path or not matched:  # the key itself is not written in the file (a default)
            return None
        if path in self.lines:
            return f"line {self.lines[path]}"
        if path in given:  # a section only an override created
            return next(v for k, v in self.overridden.items() if k[:len(path)] == path)
        return None


yaml.SafeDumper.add_representer(ScenarioDoc, yaml.representer.SafeRepresenter.represent_dict)  # dumps as a mapping


def load_yaml(path: str | Path, lines: dict[tuple[str, ...], int] | None = None) -> Any:
    """Parse a YAML file with ``yaml.safe_load``; syntax errors become an InputError naming
    the file, line and column. ``lines`` receives the line of every key."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:  # at most MAX_BYTES + 1: /dev/zero or a huge file never fills memory
            raw = fh.read(MAX_BYTES + 1)
        if len(raw) > MAX_BYTES:
            raise InputError(f"{p}: the file is longer than {MAX_BYTES} bytes; a scenario file is expected "
                             f"to be at most {MAX_BYTES} bytes.")
        text = raw.decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"{p}: file not found; expected a YAML scenario file.") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: cannot be read ({exc}); expected a UTF-8 YAML file.") from None
    try:
        return safe_load_bounded(text, lines=lines)
    except YAMLLimitError as exc:
        raise InputError(f"{p}: YAML refused: {exc.problem}.") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(f"{p}: YAML syntax error{where}: {problem}; fix the file so that it "
                         f"parses as YAML.") from None


def load_scenario_dict(path: str | Path) -> ScenarioDoc:
    """Read a scenario file into a dict (no validation yet) that knows its keys' lines."""
    lines: dict[tuple[str, ...], int] = {}
    data = load_yaml(path, lines)
    if data is None:
        raise InputError(f"{path}: the file is empty; expected a mapping of scenario keys "
                         f"(e.g. 'seed: 0', 'duration: 60', 'method: ramen').")
    if not isinstance(data, dict):
        raise InputError(f"{path}: the top level is a {type(data).__name__}, expected a mapping "
                         f"of scenario keys (e.g. 'seed: 0', 'method: ramen').")
    return ScenarioDoc(data, lines)


def parse_override(text: str) -> tuple[str, Any]:
    """Split ``dotted.key=value``; the value is parsed as YAML (``0.5`` -> float,
    ``[1, 2]`` -> list, ``true`` -> bool, ``null`` -> None)."""
    if "=" not in text:
        raise InputError(f"--set {text!r}: expected the form dotted.key=value, "
                         f"e.g. --set channel.success_rate=0.5.")
    key, raw = text.split("=", 1)
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise InputError(f"--set {text!r}: the key {key!r} is not a dotted key like channel.success_rate.")
    if raw.strip().lower() in _YAML11_WORDS:
        return key, raw.strip()  # 'off', 'on', 'yes', 'no' are words here, not YAML 1.1 booleans
    try:
        value = safe_load_bounded(raw) if raw.strip() else ""
    except YAMLLimitError as exc:
        raise InputError(f"--set {_clip(text)}: the value is refused: {exc.problem}.") from None
    except yaml.YAMLError:
        value = raw
    return key, value


def apply_overrides(data: Mapping[str, Any],
                    overrides: Iterable[str] | Mapping[str, Any] = ()) -> dict[str, Any]:
    """Return a deep copy of ``data`` with dotted-key overrides applied (creating
    intermediate mappings as needed); a :class:`ScenarioDoc` keeps its lines and records the
    overridden keys."""
    out = _deep_copy(data)
    if isinstance(data, ScenarioDoc):
        out = ScenarioDoc(out, data.lines, data.overridden)
    items = overrides.items() if isinstance(overrides, Mapping) else (parse_override(o) for o in overrides)
    origin = "override" if isinstance(overrides, Mapping) else "--set"
    for key, value in items:
        parts = key.split(".")
        if isinstance(out, ScenarioDoc):
            out.overridden[tuple(parts)] = origin
        node: Any = out
        for i, part in enumerate(parts[:-1]):
            nxt = node.get(part, _MISSING) if isinstance(node, dict) else _MISSING
            if nxt is _MISSING or nxt is None:
                nxt = {}
                node[part] = nxt
            elif not isinstance(nxt, dict):
                raise InputError(f"--set {key}: '{'.'.join(parts[:i + 1])}' holds a "
                                 f"{type(nxt).__name__}, not a mapping, so it has no key '{parts[i + 1]}'.")
            node = nxt
        node[parts[-1]] = _deep_copy(value)
    return out


def _deep_copy(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _deep_copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_deep_copy(v) for v in value]
    return value


def _clip(text: str, n: int = 80) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _loc_parts(loc: tuple[Any, ...]) -> list[str]:
    """The key path of a validation error's location as the user writes it: without pydantic's
    validator names and without the tag of a tagged union (``world.scene.builtin.name`` is the
    key ``world.scene.name`` of a built-in scene)."""
    parts = [str(p) for p in loc if not (isinstance(p, str) and (p.startswith("function-") or "[" in p))]
    return _without_union_tags(parts)


def _union_members(ann: Any) -> tuple[Any, dict[str, Any]]:
    """(the one model an annotation holds, or None; {tag: model} of a tagged union's members)."""
    import typing

    from pydantic import BaseModel

    origin = typing.get_origin(ann)
    if origin is typing.Annotated:
        return _union_members(typing.get_args(ann)[0])
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann, {}
    tags: dict[str, Any] = {}
    models = []
    for member in typing.get_args(ann) if origin is not None else ():
        inner, meta = member, ()
        if typing.get_origin(member) is typing.Annotated:
            inner, *meta = typing.get_args(member)
        for m in meta:
            if type(m).__name__ == "Tag" and isinstance(getattr(m, "tag", None), str):
                tags[m.tag] = inner
        if isinstance(inner, type) and issubclass(inner, BaseModel):
            models.append(inner)
    return (models[0] if len(models) == 1 and not tags else None), tags


def _without_union_tags(parts: list[str]) -> list[str]:
    """``parts`` with every tag of a tagged union the schema walk meets removed."""
    from ramensim.schema import Scenario

    model: Any = Scenario
    tags: dict[str, Any] = {}
    out: list[str] = []
    for part in parts:
        if part in tags:  # pydantic's name of the union member, not a key of the file
            model, tags = tags[part], {}
            continue
        out.append(part)
        fields = getattr(model, "model_fields", None)
        if not fields or part not in fields:
            model, tags = None, {}
            continue
        model, tags = _union_members(fields[part].annotation)
    return out


def _key_path(loc: tuple[Any, ...]) -> str:
    parts = _loc_parts(loc)
    return _clip(".".join(parts)) if parts else "(top level)"


_KEY_IN_TEXT = re.compile(r"key '([^']+)'")


def _add_lines(text: str, doc: ScenarioDoc | None) -> str:
    """``key 'a.b[1].c'`` -> ``key 'a.b[1].c' (line N)`` wherever the document knows the line."""
    if doc is None:
        return text

    def repl(m: re.Match) -> str:
        where = doc.where(re.findall(r"[^.\[\]]+", m.group(1)))
        return f"{m.group(0)} ({where})" if where else m.group(0)
    return _KEY_IN_TEXT.sub(repl, text)


def _sibling_keys(loc: tuple[Any, ...]) -> list[str]:
    """The keys a scenario accepts beside the last part of ``loc`` (the fields of the settings
    block it sits in), for 'did you mean'; [] where the block is not a plain settings model."""
    import typing

    from pydantic import BaseModel

    from ramensim.schema import Scenario

    model: Any = Scenario
    for i, part in enumerate(loc[:-1]):
        fields = getattr(model, "model_fields", None)
        plugin = _plugin_block_settings(str(loc[i - 1]), str(part)) if i == 1 and isinstance(part, str) else None
        if plugin is not None:
            model = plugin
            continue
        if not isinstance(part, str) or fields is None or part not in fields:
            return []
        ann = fields[part].annotation
        candidates = [a for a in (typing.get_args(ann) or (ann,)) if isinstance(a, type) and issubclass(a, BaseModel)]
        if not candidates:
            return []
        model = candidates[0]
    return list(getattr(model, "model_fields", {}))


def _did_you_mean(loc: tuple[Any, ...]) -> str:
    import difflib

    if not loc or not isinstance(loc[-1], str):
        return ""
    close = difflib.get_close_matches(loc[-1], _sibling_keys(loc), n=1, cutoff=0.7)
    return f", did you mean '{_key_path(loc[:-1] + (close[0],))}'?" if close else ""


def _closest_choice(err: Mapping[str, Any]) -> str:
    """' (did you mean X?)' for a string that misses one of a key's allowed values by a typo."""
    import difflib
    import re

    if err.get("type") != "literal_error" or not isinstance(err.get("input"), str):
        return ""
    choices = re.findall(r"'([^']*)'", str((err.get("ctx") or {}).get("expected", "")))
    close = difflib.get_close_matches(err["input"], choices, n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def format_validation_error(exc: ValidationError, source: str, doc: ScenarioDoc | None = None) -> str:
    """One paragraph: the file, each bad key path with its line (when ``doc`` knows it), the
    bad value and what was expected."""
    problems = []
    errors = exc.errors(include_url=False)

    def at(loc: tuple[Any, ...]) -> str:
        where = doc.where(_loc_parts(loc)) if doc is not None else None
        return f" ({where})" if where else ""
    extra = [tuple(e.get("loc", ())) for e in errors if e.get("type") == "extra_forbidden"]
    # lines and suggestions only for the keys listed: a file of 5,000 unknown keys costs 20 look-ups
    unknown = [f"'{_key_path(loc)}'{at(loc)}{_did_you_mean(loc)}" for loc in extra[:MAX_PROBLEMS]]
    if unknown:
        listed = ", ".join(unknown)
        more = f" and {len(extra) - MAX_PROBLEMS} more" if len(extra) > MAX_PROBLEMS else ""
        problems.append(f"unknown key{'s' if len(extra) > 1 else ''} {listed}{more} (not scenario "
                        f"settings; check spelling and nesting, 'ramensim schema' lists every key)")
    errors = [e for e in errors if e.get("type") != "extra_forbidden"]
    for err in errors[:MAX_PROBLEMS]:
        loc = tuple(err.get("loc", ()))
        path = _key_path(loc)
        kind = err.get("type", "")
        msg = err.get("msg", "invalid value")
        if kind == "missing":
            problems.append(f"key '{path}'{at(loc[:-1])} is required but missing")
            continue
        if not loc and kind == "value_error":  # a cross-key check, naming its keys in the text
            problems.append(_add_lines(_clip(msg.removeprefix("Value error, ").rstrip("."), 600), doc))
            continue
        value = err.get("input", None)
        shown = repr(value)
        if len(shown) > 80:
            shown = shown[:77] + "..."
        msg = msg[0].lower() + msg[1:] if msg else msg
        if msg.startswith("value error, "):
            msg = msg[len("value error, "):]
        problems.append(f"key '{path}'{at(loc)} has value {shown}; expected: {_clip(msg.rstrip('.'), 300)}"
                        f"{_closest_choice(err)}")
    if len(errors) > MAX_PROBLEMS:
        problems.append(f"and {len(errors) - MAX_PROBLEMS} more")
    return f"{source}: invalid scenario: " + "; ".join(problems) + "."


def validate(data: Mapping[str, Any], source: str = "<scenario>", base_dir: str | Path | None = None):
    """Validate a scenario dict into a :class:`ramensim.schema.Scenario`; errors name the
    lines when ``data`` is a :class:`ScenarioDoc` read from a file. First the installed
    plugins and those the scenario's ``plugins`` key lists are loaded (:func:`load_plugins`,
    files relative to ``base_dir``, default the folder of ``source`` when it is a file), so
    that the names they register are valid; the Scenario holds those files as absolute paths."""
    from ramensim.schema import Scenario

    data = load_plugins(data, source, base_dir)
    try:
        _check_plugin_blocks(data)
        return Scenario.model_validate(dict(data))
    except ValidationError as exc:
        doc = data if isinstance(data, ScenarioDoc) else None
        raise InputError(format_validation_error(exc, source, doc)) from None


def _plugin_block_settings(block: str, key: str) -> Any:
    """The settings class of a plugin's block ``<block>.<key>`` (a method's ``consensus.<name>``,
    a radio model's ``channel.<name>``), None when ``key`` names no such plugin."""
    if block == "consensus":
        from ramensim.agents.consensus.config import ConsensusConfig
        from ramensim.agents.consensus.registry import get_method

        if key in ConsensusConfig.model_fields:
            return None
        try:
            return get_method(key).settings
        except ValueError:
            return None
    if block == "channel":
        from ramensim.channels.config import ChannelConfig
        from ramensim.channels.radios import get_radio, is_radio

        if key in ChannelConfig.model_fields or not is_radio(key):
            return None
        return get_radio(key).settings
    return None


def _check_plugin_blocks(data: Mapping[str, Any]) -> None:
    """Validate the settings blocks of plugin methods and radio models with their classes first,
    so their errors carry the full key path (``consensus.<method>.<key>``), the line and a 'did
    you mean' exactly as a built-in block's do (pydantic would report them under the parent)."""
    from pydantic_core import InitErrorDetails

    errors: list[InitErrorDetails] = []
    for block in ("consensus", "channel"):
        section = data.get(block) if isinstance(data, Mapping) else None
        if not isinstance(section, Mapping):
            continue
        for key, value in section.items():
            settings = _plugin_block_settings(block, str(key))
            if settings is None:
                continue
            try:
                settings.model_validate(value if value is not None else {})
            except ValidationError as exc:
                for e in exc.errors(include_url=False):
                    detail: dict[str, Any] = {"type": e["type"], "loc": (block, key, *e["loc"]),
                                              "input": e.get("input")}
                    if e.get("ctx"):
                        detail["ctx"] = e["ctx"]
                    errors.append(detail)  # type: ignore[arg-type]
    if errors:
        raise ValidationError.from_exception_data("Scenario", errors)


def load_plugins(data: Mapping[str, Any], source: str = "<scenario>",
                 base_dir: str | Path | None = None) -> Mapping[str, Any]:
    """Load the installed plugins and those of ``data['plugins']`` (:mod:`ramensim.plugins`;
    files relative to ``base_dir``, else the folder of ``source`` when it is a file, else the
    working directory). Returns ``data`` with its plugin files made absolute (a copy, a
    :class:`ScenarioDoc` kept as one); InputError naming the file, the key and the plugin."""
    from ramensim import plugins

    raw = data.get("plugins") if isinstance(data, Mapping) else None
    if raw is None:
        plugins.load_installed()
        return data
    if base_dir is None and isinstance(source, (str, Path)) and Path(source).is_file():
        base_dir = Path(source).parent
    doc = data if isinstance(data, ScenarioDoc) else None
    where = doc.where(("plugins",)) if doc is not None else None
    resolved = plugins.load_plugins(raw, Path(base_dir) if base_dir is not None else None,
                                    f"{source} (key 'plugins'{', ' + where if where else ''})")
    if doc is not None:
        out: Mapping[str, Any] = ScenarioDoc({**doc, "plugins": resolved}, doc.lines, doc.overridden)
    else:
        out = {**data, "plugins": resolved}
    return out


def _scenario_files(scenario: Any) -> list[tuple[str, str, str]]:
    """(key, path as written, 'file' | 'folder') of every path the scenario names."""
    out: list[tuple[str, str, str]] = []
    if scenario.map.decoders is not None:
        out.append(("map.decoders", scenario.map.decoders, "file"))
    scene = scenario.world.scene
    if scene.kind == "mesh":
        out.append(("world.scene.path", scene.path, "file"))
    elif scene.kind != "builtin":
        out.append(("world.scene.path", scene.path, "folder"))
        if scene.mesh is not None:
            out.append(("world.scene.mesh", scene.mesh, "file"))
    traj = scenario.world.trajectory
    if traj.kind == "file":
        out += [(f"world.trajectory.paths[{i}]", p, "file") for i, p in enumerate(traj.paths)]
    if scenario.channel.trace.path is not None:
        out.append(("channel.trace.path", scenario.channel.trace.path, "file"))
    return out


_EXPECTED = {
    "map.decoders": "a decoder file written by 'ramensim pretrain-decoders'",
    "world.scene.path/file": "a triangle mesh file (PLY, OBJ, GLB, ...)",
    "world.scene.path/folder": "the dataset sequence's folder (docs/DATASETS.md says where to get it)",
    "world.scene.mesh": "the dataset's ground-truth mesh file",
    "channel.trace.path": "a CSV trace with the columns time,from,to,delivered,latency (docs/RADIO.md)",
}


def check_paths(scenario: Any, source: str | Path, doc: ScenarioDoc | None = None,
                base: Path | None = None) -> None:
    """Every file and folder the scenario names must exist before a run (paths relative to
    ``base``, default the scenario file's folder): ``map.decoders``, the scene's mesh or dataset
    folder, trajectory files and the radio trace, which is also read and checked row by row
    (:func:`ramensim.channels.trace.read_trace`). An InputError names the file, the key (with
    its line when ``doc`` knows it), the value and what was expected."""
    base = Path(source).parent if base is None else base
    for key, value, kind in _scenario_files(scenario):
        p = Path(value).expanduser()
        if not p.is_absolute():
            p = base / p
        ok = p.is_file() if kind == "file" else p.is_dir()
        if not ok:
            expected = _EXPECTED.get(key, _EXPECTED.get(f"{key}/{kind}", "a trajectory file (TUM or 4x4 matrix lines)"))
            raise InputError(_add_lines(
                f"{source}: key '{key}' has value {_clip(repr(value))}, but {_clip(str(p))} is not a {kind}; "
                f"expected {expected} (a path relative to the scenario file's folder, or absolute).", doc))
        if key == "channel.trace.path":
            from ramensim.channels.trace import read_trace

            try:
                read_trace(p, scenario.agents.count)
            except ValueError as exc:
                raise InputError(f"{source}: {exc}") from None


def scenario_folder(source: Any, base_dir: str | Path | None = None) -> Path | None:
    """The folder a scenario's relative paths resolve against: ``base_dir`` if given, else the
    scenario file's folder; None (the working directory) for a dict or a Scenario object."""
    if base_dir is not None:
        return Path(base_dir)
    return Path(source).parent if isinstance(source, (str, Path)) else None


def load_scenario(source: Any, overrides: Iterable[str] | Mapping[str, Any] = (), *,
                  base_dir: str | Path | None = None, plugins: Iterable[str] = ()):
    """The one way a scenario is assembled (the CLI, the Python API, sweeps' checks): read a
    YAML file, or take a dict of scenario keys or a :class:`ramensim.schema.Scenario`; apply
    the dotted-key ``overrides`` (``key=value`` strings or a mapping); add ``plugins`` (``--plugin``:
    files relative to the working directory, or module names) to its ``plugins`` key; validate
    (loading the plugins first); check that every file it names exists (:func:`check_paths`,
    relative to :func:`scenario_folder`).
    Returns the Scenario; InputError names the file, the key and what was expected."""
    from ramensim.schema import Scenario

    if isinstance(overrides, str):
        raise InputError(f"overrides={overrides!r}: expected a mapping like {{'channel.success_rate': 0.5}} "
                         f"or a list of 'key=value' strings, not one string.")
    if isinstance(source, Scenario):
        data, name = source.model_dump(mode="json"), "<Scenario>"
    elif isinstance(source, Mapping):
        data, name = dict(source), "<dict>"
    elif isinstance(source, (str, Path)):
        data, name = load_scenario_dict(source), str(source)
    else:
        raise InputError(f"scenario={_clip(repr(source))}: expected a scenario file path, a dict of scenario keys "
                         f"or a ramensim.schema.Scenario.")
    data = apply_overrides(data, overrides or ())
    folder = scenario_folder(source, base_dir)
    if plugins:
        from ramensim import plugins as plug

        extra = plug.load_plugins(list(plugins), None, "--plugin", "--plugin")  # errors name --plugin
        given = plug.resolve(data.get("plugins") or [], folder, name)
        data = apply_overrides(data, {"plugins": list(given) + [e for e in extra if e not in given]})
    scenario = validate(data, name, base_dir=folder)
    check_paths(scenario, name, data if isinstance(data, ScenarioDoc) else None,
                base=folder if folder is not None else Path.cwd())
    return scenario
