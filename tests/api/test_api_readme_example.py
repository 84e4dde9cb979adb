"""The scenario examples shown in README.md validate against the schema (docs stay true)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from ramensim.config import load_scenario

README = Path(__file__).resolve().parents[2] / "README.md"
BLOCKS = re.findall(r"```yaml\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


def test_the_readme_shows_a_scenario():
    assert BLOCKS, "README.md has no ```yaml scenario block"


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_scenario_block_validates(tmp_path, index):
    doc = yaml.safe_load(BLOCKS[index])
    path = tmp_path / f"readme_{index}.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    sc = load_scenario(str(path), [])
    assert sc.consensus.dual_step == doc.get("consensus", {}).get("dual_step", sc.consensus.dual_step)
