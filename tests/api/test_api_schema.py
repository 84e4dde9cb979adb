"""``ramensim schema`` is a JSON Schema (draft 2020-12) that editors can use: every shipped
scenario file validates against it, and a wrong key or value does not."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from ramensim.cli import main

jsonschema = pytest.importorskip("jsonschema")
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def validator(tmp_path_factory):
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["schema"]) == 0
    schema = json.loads(buf.getvalue())
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


class _Yaml12(yaml.SafeLoader):
    """PyYAML reads YAML 1.1, where '100.0e6' (no exponent sign) is a string that pydantic later
    coerces; editors read YAML 1.2, where it is a number. Load as an editor does."""


_Yaml12.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?$|^[-+]?\.(inf|Inf|INF)$|^\.(nan|NaN|NAN)$"),
    list("-+0123456789."))


def _as_editor_sees(path: Path):
    data = yaml.load(path.read_text(), Loader=_Yaml12)
    return json.loads(json.dumps(data))  # mapping keys become strings, as in JSON


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("*.yaml")), ids=lambda p: p.name)
def test_shipped_scenarios_validate(validator, path: Path) -> None:
    errors = [e.message for e in validator.iter_errors(_as_editor_sees(path))]
    assert not errors, errors


def test_wrong_keys_and_values_are_flagged(validator) -> None:
    assert list(validator.iter_errors({"methd": "ramen"}))
    assert list(validator.iter_errors({"channel": {"success_rate": "often"}}))
    assert not list(validator.iter_errors({"method": "ramen", "channel": {"success_rate": 0.5}}))
