"""``ramensim validate FILE...``: check scenario files without running them."""
from __future__ import annotations

import argparse
import sys

from ramensim.config import load_scenario
from ramensim.errors import InputError


def add_parser(sub) -> None:
    p = sub.add_parser("validate", help="check scenario files", description=__doc__)
    p.add_argument("files", nargs="+", help="scenario YAML files")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a field by dotted key (repeatable)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    failed = 0
    for path in args.files:
        try:
            load_scenario(path, args.overrides)
        except InputError as exc:
            failed += 1
            print(f"error: {exc}", file=sys.stderr)
        else:
            print(f"{path}: ok")
    return 2 if failed else 0
