"""Bad scenario files get one clear paragraph (file, key, value, expectation), exit 2, no traceback."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ramensim.cli import main
from ramensim.config import apply_overrides, load_scenario, parse_override
from ramensim.core.errors import InputError

CASES = {
    # name: (file text, fragments the message must contain)
    "unknown_key": ("seed: 1\nduraton: 10\n", ["duraton", "unknown key"]),
    "wrong_type": ("duration: ten\n", ["duration", "'ten'"]),
    "negative_rate": ("channel:\n  bandwidth_bps: -5\n", ["channel.bandwidth_bps", "-5"]),
    "success_above_one": ("channel:\n  success_rate: 1.5\n", ["channel.success_rate", "1.5"]),
    "override_missing_agent": ("agents:\n  count: 2\n  overrides:\n    5:\n      speed_factor: 2\n",
                               ["agents", "5", "0..1"]),
    "unknown_method": ("method: admm\n", ["method", "'admm'", "ramen"]),
    "unknown_topology": ("topology:\n  kind: hypercube\n", ["topology.kind", "hypercube"]),
    "empty_file": ("", ["empty"]),
    "not_mapping": ("- 1\n- 2\n", ["list", "mapping"]),
    "yaml_syntax": ("seed: [1, 2\nmethod: ramen\n", ["YAML syntax error", "line"]),
    "negative_duration": ("duration: -3\n", ["duration", "-3"]),
    "bad_seed_type": ("seed: [1]\n", ["seed"]),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_scenario_message_and_exit_code(name: str, tmp_path: Path, capsys) -> None:
    text, fragments = CASES[name]
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message
    assert "\n" not in message.strip(), "one paragraph"
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    # through the CLI: exit 2, no traceback
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err and str(path) in err


def test_cli_subprocess_has_no_traceback(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("method: nope\n")
    proc = subprocess.run([sys.executable, "-m", "ramensim", "validate", str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert "method" in proc.stderr


def test_missing_file() -> None:
    with pytest.raises(InputError, match="not found"):
        load_scenario("/nonexistent/scenario.yaml")


def test_minimal_scenario_and_overrides(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent("""
        seed: 3
        method: dinno
    """))
    sc = load_scenario(path, ["channel.success_rate=0.5", "agents.count=4", "method=ramen"])
    assert sc.seed == 3 and sc.method == "ramen"
    assert sc.channel.success_rate == 0.5 and sc.agents.count == 4


def test_override_parsing() -> None:
    assert parse_override("a.b=0.5") == ("a.b", 0.5)
    assert parse_override("a=[1, 2]") == ("a", [1, 2])
    data = apply_overrides({"a": {"b": 1}}, ["a.c.d=true"])
    assert data == {"a": {"b": 1, "c": {"d": True}}}
    with pytest.raises(InputError):
        parse_override("novalue")
    with pytest.raises(InputError):
        apply_overrides({"a": 1}, ["a.b=2"])


def test_schema_command(capsys) -> None:
    assert main(["schema"]) == 0
    out = capsys.readouterr().out
    assert '"success_rate"' in out and '"method"' in out


@pytest.mark.parametrize("overrides, fragment", [
    (["topology.kind=explicit", "topology.edges=[[0, 5]]"], "agent 5"),
    (["channel.windows.kind=schedule", 'channel.windows.schedule={"0-7": [[0, 5]]}'], "'0-7'"),
])
def test_checks_that_need_the_agent_count(overrides, fragment, tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text("agents: {count: 3}\n")
    with pytest.raises(InputError) as info:
        load_scenario(path, overrides)
    assert fragment in str(info.value) and str(path) in str(info.value)


def test_one_door_checks_paths_for_every_kind_of_source(tmp_path):
    """config.load_scenario assembles files, dicts and Scenario objects alike: a missing file
    the scenario names is an InputError naming the key, before any run, through the API too."""
    import ramensim

    root = Path(__file__).resolve().parents[2]
    sc = load_scenario(root / "scenarios" / "office_3agents.yaml")
    data = sc.model_dump(mode="json")
    data["map"]["decoders"] = "no_such_decoders.pt"
    for source in (data, sc.model_copy(update={"map": sc.map.model_copy(update={"decoders": "nope.pt"})})):
        with pytest.raises(InputError, match="map.decoders"):
            load_scenario(source, base_dir=tmp_path)
    with pytest.raises(InputError, match="map.decoders"):
        ramensim.run(data, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("override, hint", [
    ("channel.sucess_rate=0.3", "did you mean 'channel.success_rate'?"),
    ("sed=3", "did you mean 'seed'?"),
    ("method=ramne", "did you mean 'ramen'?"),
])
def test_misspelled_keys_and_methods_get_a_suggestion(override: str, hint: str) -> None:
    root = Path(__file__).resolve().parents[2]
    with pytest.raises(InputError) as err:
        load_scenario(root / "scenarios" / "office_3agents.yaml", [override])
    assert hint in str(err.value)


def test_american_spelling_of_centralised_is_accepted() -> None:
    root = Path(__file__).resolve().parents[2]
    assert load_scenario(root / "scenarios" / "office_3agents.yaml", ["method=centralized"]).method == "centralised"
