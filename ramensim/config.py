"""Reading scenario files: YAML (safe and bounded, :mod:`ramensim.yamlsafe`), ``--set
dotted.key=value`` overrides, and validation into :class:`ramensim.schema.Scenario` with
one-paragraph error messages (at most :data:`MAX_PROBLEMS` problems listed)."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml
from pydantic import ValidationError

from ramensim.errors import InputError
from ramensim.yamlsafe import MAX_BYTES, YAMLLimitError, safe_load_bounded

_MISSING = object()
MAX_PROBLEMS = 20
"""Problems listed in one validation error; the rest are counted ("and N more")."""
_YAML11_WORDS = {"on", "off", "yes", "no", "y", "n"}


def load_yaml(path: str | Path) -> Any:
    """Parse a YAML file with ``yaml.safe_load``; syntax errors become an InputError naming
    the file, line and column."""
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
        return safe_load_bounded(text)
    except YAMLLimitError as exc:
        raise InputError(f"{p}: YAML refused: {exc.problem}.") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(f"{p}: YAML syntax error{where}: {problem}; fix the file so that it "
                         f"parses as YAML.") from None


def load_scenario_dict(path: str | Path) -> dict[str, Any]:
    """Read a scenario file into a plain dict (no validation yet)."""
    data = load_yaml(path)
    if data is None:
        raise InputError(f"{path}: the file is empty; expected a mapping of scenario keys "
                         f"(e.g. 'seed: 0', 'duration: 60', 'method: ramen').")
    if not isinstance(data, dict):
        raise InputError(f"{path}: the top level is a {type(data).__name__}, expected a mapping "
                         f"of scenario keys (e.g. 'seed: 0', 'method: ramen').")
    return data


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
    intermediate mappings as needed)."""
    out = _deep_copy(data)
    items = overrides.items() if isinstance(overrides, Mapping) else (parse_override(o) for o in overrides)
    for key, value in items:
        parts = key.split(".")
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


def _key_path(loc: tuple[Any, ...]) -> str:
    parts = [str(p) for p in loc if not (isinstance(p, str) and (p.startswith("function-") or "[" in p))]
    return _clip(".".join(parts)) if parts else "(top level)"


def format_validation_error(exc: ValidationError, source: str) -> str:
    """One paragraph: the file, each bad key path, the bad value and what was expected."""
    problems = []
    errors = exc.errors(include_url=False)
    unknown = [_key_path(tuple(e.get("loc", ()))) for e in errors if e.get("type") == "extra_forbidden"]
    if unknown:
        listed = ", ".join(f"'{k}'" for k in unknown[:MAX_PROBLEMS])
        more = f" and {len(unknown) - MAX_PROBLEMS} more" if len(unknown) > MAX_PROBLEMS else ""
        problems.append(f"unknown key{'s' if len(unknown) > 1 else ''} {listed}{more} (not scenario "
                        f"settings; check spelling and nesting, 'ramensim schema' lists every key)")
    errors = [e for e in errors if e.get("type") != "extra_forbidden"]
    for err in errors[:MAX_PROBLEMS]:
        path = _key_path(tuple(err.get("loc", ())))
        kind = err.get("type", "")
        msg = err.get("msg", "invalid value")
        if kind == "missing":
            problems.append(f"key '{path}' is required but missing")
            continue
        if not err.get("loc") and kind == "value_error":
            problems.append(_clip(msg.removeprefix("Value error, ").rstrip("."), 600))  # a cross-key check
            continue
        value = err.get("input", None)
        shown = repr(value)
        if len(shown) > 80:
            shown = shown[:77] + "..."
        msg = msg[0].lower() + msg[1:] if msg else msg
        if msg.startswith("value error, "):
            msg = msg[len("value error, "):]
        problems.append(f"key '{path}' has value {shown}; expected: {_clip(msg.rstrip('.'), 300)}")
    if len(errors) > MAX_PROBLEMS:
        problems.append(f"and {len(errors) - MAX_PROBLEMS} more")
    return f"{source}: invalid scenario: " + "; ".join(problems) + "."


def validate(data: Mapping[str, Any], source: str = "<scenario>"):
    """Validate a scenario dict into a :class:`ramensim.schema.Scenario`."""
    from ramensim.schema import Scenario

    try:
        return Scenario.model_validate(dict(data))
    except ValidationError as exc:
        raise InputError(format_validation_error(exc, source)) from None


def check_paths(scenario: Any, source: str | Path) -> None:
    """Files the scenario names that must exist before a run: ``map.decoders`` (relative to
    the scenario file's folder). Scene and dataset paths are checked by the world builder."""
    dec = scenario.map.decoders
    if dec is None:
        return
    p = Path(dec).expanduser()
    if not p.is_absolute():
        p = Path(source).parent / p
    if not p.is_file():
        raise InputError(f"{source}: key 'map.decoders' has value {_clip(repr(dec))}, but {_clip(str(p))} is not a "
                         f"file; expected a decoder file written by 'ramensim pretrain-decoders' (a path "
                         f"relative to the scenario file's folder, or absolute).")


def load_scenario(path: str | Path, overrides: Iterable[str] | Mapping[str, Any] = ()):
    """Read, override and validate a scenario file (and check the files it names)."""
    data = apply_overrides(load_scenario_dict(path), overrides)
    scenario = validate(data, str(path))
    check_paths(scenario, path)
    return scenario
