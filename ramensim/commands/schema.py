"""``ramensim schema``: print the JSON schema of scenario files."""
from __future__ import annotations

import argparse
import json


def add_parser(sub) -> None:
    p = sub.add_parser("schema", help="print the scenario JSON schema", description=__doc__)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ramensim.schema import Scenario

    # A JSON Schema (draft 2020-12) that editors can use for scenario YAML files (README).
    schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", **Scenario.model_json_schema()}
    print(json.dumps(schema, indent=2))
    return 0
