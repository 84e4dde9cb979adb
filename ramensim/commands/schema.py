"""``ramensim schema``: print the JSON schema of scenario files."""
from __future__ import annotations

import argparse
import json


def add_parser(sub) -> None:
    p = sub.add_parser("schema", help="print the scenario JSON schema", description=__doc__)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ramensim.schema import Scenario

    print(json.dumps(Scenario.model_json_schema(), indent=2))
    return 0
