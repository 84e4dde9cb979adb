"""core/names.py: "did you mean" regardless of case and separators, for the registries of
methods, scenes and radio models; through the CLI a mistyped name gets the hint (issue 57:
``--set method=DiNNO`` and ``world.scene.name=ofice`` got none)."""
from __future__ import annotations

from pathlib import Path

import pytest

from ramensim.core.names import closest_name, did_you_mean, fold

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "office_3agents.yaml"


def test_fold_and_closest_name():
    known = ["ramen", "dinno", "dsgd", "dsgt", "local", "centralised"]
    assert fold("Living-Room") == fold("living_room") == "livingroom"
    assert closest_name("DiNNO", known) == "dinno" and closest_name("RAMEN", known) == "ramen"
    assert closest_name("dino", known) == "dinno"
    assert closest_name("LIVINGROOM", ["office", "living_room"]) == "living_room"
    assert closest_name("zzz", known) is None
    assert did_you_mean("ramen", known) == "" and did_you_mean("Ramen", known) == " (did you mean 'ramen'?)"


@pytest.mark.parametrize("override, hint", [
    ("method=DiNNO", "did you mean 'dinno'?"),
    ("method=CENTRALISED", "did you mean 'centralised'?"),
    ("world.scene.name=ofice", "did you mean 'office'?"),
    ("world.scene.name=Office", "did you mean 'office'?"),
    ("world.scene.name=LIVINGROOM", "did you mean 'living_room'?"),
])
def test_cli_names_the_closest_method_or_scene(override, hint, capsys):
    from ramensim.cli import main

    assert main(["validate", str(SCENARIO), "--set", override]) == 2
    err = capsys.readouterr().err
    assert hint in err and "Traceback" not in err and err.count("\n") == 1


def test_radio_models_get_the_hint_too():
    from ramensim.channels.radios import get_radio, radio_names

    name = radio_names()[0]
    with pytest.raises(ValueError, match=f"did you mean '{name}'"):
        get_radio(name.upper())


def test_keys_inside_a_tagged_union_are_named_as_the_file_writes_them(tmp_path, capsys):
    """pydantic names a built-in scene's name 'world.scene.builtin.name' (the union member's
    tag); the error names the key the user wrote, with its line (issue 57)."""
    from ramensim.cli import main

    path = tmp_path / "s.yaml"
    path.write_text("name: s\nworld:\n  scene:\n    name: Ofice\n  trajectory:\n    height: -1\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "key 'world.scene.name' (line 4)" in err and "did you mean 'office'?" in err
    assert "key 'world.trajectory.height' (line 6)" in err
    assert "builtin" not in err and "procedural" not in err
