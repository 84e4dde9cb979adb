"""A plugin's settings are first-class (issue 67, item 5): errors with the full key path, the
line and a did-you-mean, as a built-in block's; ``ramensim schema --plugin`` knows them."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from ramensim.cli import main

REPO = Path(__file__).resolve().parents[2]
STALE = REPO / "examples" / "stale_gossip.py"
RADIO = REPO / "examples" / "distance_loss_radio.py"


def _scenario(tmp_path: Path, extra: str) -> Path:
    p = tmp_path / "s.yaml"
    p.write_text(f"plugins: [{STALE}, {RADIO}]\nmethod: stale_gossip\n{extra}")
    return p


@pytest.mark.parametrize("extra, words", [
    ("consensus:\n  stale_gossip:\n    half_lfe_s: 3\n",
     ["unknown key 'consensus.stale_gossip.half_lfe_s' (line 5)", "did you mean 'consensus.stale_gossip.half_life_s'"]),
    ("consensus:\n  stale_gossip:\n    half_life_s: -3\n",
     ["key 'consensus.stale_gossip.half_life_s' (line 5) has value -3", "greater than 0"]),
    ("channel:\n  distance_loss:\n    exponnt: 3\n",
     ["unknown key 'channel.distance_loss.exponnt' (line 5)", "did you mean 'channel.distance_loss.exponent'"]),
    ("channel:\n  distance_loss:\n    exponent: 30\n",
     ["key 'channel.distance_loss.exponent' (line 5) has value 30", "less than or equal to 10"]),
])
def test_plugin_settings_errors_are_as_precise_as_builtins(tmp_path, capsys, extra, words):
    assert main(["validate", str(_scenario(tmp_path, extra))]) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err, err
    assert "Traceback" not in err and "{" not in err  # no dict dump, no raw pydantic report


def test_schema_knows_the_plugins_methods_radios_and_keys(tmp_path, capsys):
    jsonschema = pytest.importorskip("jsonschema")
    import yaml

    assert main(["schema", "--plugin", str(STALE), "--plugin", str(RADIO)]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert "stale_gossip" in schema["properties"]["method"]["enum"]
    good = yaml.safe_load(_scenario(tmp_path, "consensus:\n  stale_gossip: {half_life_s: 3}\n"
                                              "channel:\n  distance_loss: {exponent: 3}\n").read_text())
    jsonschema.validate(good, schema)
    bad = yaml.safe_load(_scenario(tmp_path, "consensus:\n  stale_gossip: {half_life_s: -3}\n").read_text())
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema)


@pytest.mark.parametrize("argv, words", [
    (["rnu", "x.yaml"], "did you mean 'run'?"),
    (["run", "x.yaml", "--seet", "a=1"], "did you mean '--set' for '--seet'?"),
    (["medium", "saturaton"], "did you mean 'saturation'?"),
])
def test_mistyped_commands_and_options_get_a_did_you_mean(capsys, argv, words):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2 and words in capsys.readouterr().err


def test_unknown_names_hint_at_plugins_and_help_has_no_markup(capsys):
    assert main(["world", "export", "pillar_hal", "--out", "x.ply"]) == 2
    err = capsys.readouterr().err
    assert "scene 'pillar_hal' is unknown" in err and "--plugin" in err
    assert main(["world", "export", "livng_room", "--out", "x.ply"]) == 2
    assert "did you mean 'living_room'?" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["view", "--help"])
    out = capsys.readouterr().out
    assert "``" not in out and ":mod:" not in out and "sim_time" in out and "drag the time cursor" in out
