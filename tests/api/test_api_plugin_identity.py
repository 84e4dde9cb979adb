"""A plugin file is one module however it is reached, a real clash names both files, and a run
records the plugin code it ran (issue 67, items 4 and 6)."""
from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from ramensim.core.errors import InputError
from ramensim.plugins import load_plugins

REPO = Path(__file__).resolve().parents[2]

METHOD = textwrap.dedent('''
    from ramensim.agents.consensus.registry import MethodSpec, register
    {extra}
    import gossip_avg as g
    register(MethodSpec(name="{name}", settings=g.GossipSettings, memory_vectors=(2, 2), description="test",
                        build=lambda s, cfg, ctx: g.GossipAveraging(ctx.n, cfg.primal_steps, s.mix)))
''')


def _files(tmp_path: Path, tag: str) -> tuple[Path, Path]:
    """``base_<tag>.py`` and ``derived_<tag>.py`` (which imports its sibling), beside gossip_avg.py."""
    (tmp_path / "gossip_avg.py").write_text((REPO / "examples" / "gossip_avg.py").read_text())
    base = tmp_path / f"base_{tag}.py"
    base.write_text(METHOD.format(extra="", name=f"base_{tag}"))
    derived = tmp_path / f"derived_{tag}.py"
    derived.write_text(METHOD.format(extra=f"import base_{tag}  # noqa: F401", name=f"derived_{tag}"))
    return base, derived


@pytest.mark.parametrize("order", ["derived_first", "base_first"])
def test_a_plugin_imported_by_another_is_one_module(tmp_path, order):
    base, derived = _files(tmp_path, order)
    entries = [str(derived), str(base)] if order == "derived_first" else [str(base), str(derived)]
    load_plugins(entries)  # no false clash in either order
    from ramensim.agents.consensus import method_names

    assert {f"base_{order}", f"derived_{order}"} <= set(method_names())


def test_a_real_clash_names_both_files(tmp_path):
    a, b = tmp_path / "one" / "clash_a.py", tmp_path / "two" / "clash_b.py"
    for f in (a, b):
        f.parent.mkdir()
        (f.parent / "gossip_avg.py").write_text((REPO / "examples" / "gossip_avg.py").read_text())
        f.write_text(METHOD.format(extra="", name="clash_name"))
    load_plugins([str(a)])
    with pytest.raises(InputError) as e:
        load_plugins([str(b)])
    text = str(e.value)
    assert str(a) in text and str(b) in text and "rename one of them" in text


def test_a_run_records_and_keeps_its_plugin_code_and_compare_warns(tmp_path, capsys):
    from ramensim.cli import main
    from tests.e2e.tiny_runs import SCENARIO, TINY

    plugin = tmp_path / "prov_gossip.py"
    src = (REPO / "examples" / "gossip_avg.py").read_text().replace('"gossip_avg"', '"prov_gossip"')
    plugin.write_text(src)
    sets = [x for kv in [*TINY, "duration=2", "method=prov_gossip", "evaluation.every_s=null"] for x in ("--set", kv)]
    assert main(["run", str(SCENARIO), "--plugin", str(plugin), "--out", str(tmp_path / "a"), *sets]) == 0
    m = json.loads((tmp_path / "a" / "metrics.json").read_text())
    mine = [p for p in m["build"]["plugins"] if p["path"] == str(plugin)]
    import hashlib

    assert mine and mine[0]["sha256"] == hashlib.sha256(plugin.read_bytes()).hexdigest()
    assert (tmp_path / "a" / "plugins" / "prov_gossip.py").read_text() == src
    # the same file edited: a second run's build says so, and compare warns
    plugin.write_text(src + "\n# tuned\n")
    b = json.loads((tmp_path / "a" / "metrics.json").read_text())
    b["build"]["plugins"] = [{"path": str(plugin), "sha256": hashlib.sha256(plugin.read_bytes()).hexdigest()}]
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "metrics.json").write_text(json.dumps(b))
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "a"), str(tmp_path / "b"), "--no-plot"]) == 0
    assert "different code of plugin prov_gossip.py" in capsys.readouterr().err
