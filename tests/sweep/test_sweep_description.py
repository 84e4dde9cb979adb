"""A sweep file's ``description`` reaches sweep.json (and so the captions of a paper-style report)."""
from __future__ import annotations

import pytest
import yaml

from ramensim.core.errors import InputError
from ramensim.sweep.spec import plan_sweep
from sweep_testfuncs import validate_dict


def test_description_is_kept_on_one_line_and_too_long_is_refused(tmp_path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump({"method": "ramen"}))
    f = tmp_path / "s.yaml"
    f.write_text("base: base.yaml\ndescription: >\n  RAMEN and DiNNO\n  on one air.\naxes: {seed: [0, 1]}\n")
    plan = plan_sweep(f, validate_fn=validate_dict)
    assert plan.to_json()["description"] == "RAMEN and DiNNO on one air."
    f.write_text("base: base.yaml\naxes: {seed: [0]}\n")
    assert "description" not in plan_sweep(f, validate_fn=validate_dict).to_json()
    f.write_text(yaml.safe_dump({"base": "base.yaml", "description": "x" * 5000, "axes": {"seed": [0]}}))
    with pytest.raises(InputError, match="description"):
        plan_sweep(f, validate_fn=validate_dict)
