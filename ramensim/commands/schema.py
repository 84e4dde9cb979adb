"""``ramensim schema``: print the JSON schema of scenario files.

``--plugin FILE_OR_MODULE`` (repeatable) loads plugins first: the schema then knows their
methods (``method``'s choices and the block ``consensus.<method>``), radio models (the block
``channel.<model>``) and scenes (``world.scene.name``'s choices), so an editor does not flag a
plugin's keys as errors.
"""
from __future__ import annotations

import argparse
import json
from typing import Any


def add_parser(sub) -> None:
    p = sub.add_parser("schema", help="print the scenario JSON schema", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="FILE_OR_MODULE",
                   help="load a plugin first, so the schema knows its method, radio model or scene (repeatable)")
    p.set_defaults(func=run)


def scenario_schema(plugins: list[str] | None = None) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of scenario files, with the settings blocks of every
    registered plugin method and radio model (after loading ``plugins``)."""
    from ramensim.plugins import load_plugins
    from ramensim.schema import Scenario

    load_plugins(plugins or [])
    schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", **Scenario.model_json_schema()}
    defs = schema.setdefault("$defs", {})
    _add_blocks(defs, "ConsensusConfig", _plugin_methods())
    _add_blocks(defs, "ChannelConfig", _plugin_radios())
    return schema


def _plugin_methods() -> dict[str, Any]:
    from ramensim.agents.consensus.config import ConsensusConfig
    from ramensim.agents.consensus.registry import _REGISTRY

    return {n: s.settings for n, s in _REGISTRY.items()
            if s.settings is not None and n not in ConsensusConfig.model_fields}


def _plugin_radios() -> dict[str, Any]:
    from ramensim.channels.config import ChannelConfig
    from ramensim.channels.radios import _REGISTRY

    return {n: s.settings for n, s in _REGISTRY.items()
            if s.settings is not None and n not in ChannelConfig.model_fields}


def _add_blocks(defs: dict[str, Any], owner: str, blocks: dict[str, Any]) -> None:
    """Each plugin block ``name`` as a property of ``defs[owner]``, its schema under $defs."""
    target = defs.get(owner)
    if target is None:
        return
    for name, settings in sorted(blocks.items()):
        sub = settings.model_json_schema(ref_template="#/$defs/{model}")
        for k, v in sub.pop("$defs", {}).items():
            defs.setdefault(k, v)
        key = f"{settings.__name__}"
        defs.setdefault(key, sub)
        target.setdefault("properties", {})[name] = {"$ref": f"#/$defs/{key}",
                                                      "description": f"settings of the plugin '{name}'"}


def run(args: argparse.Namespace) -> int:
    print(json.dumps(scenario_schema(args.plugins), indent=2))
    return 0
