"""``ramensim validate FILE...``: check scenario files without running them."""
from __future__ import annotations

import argparse
import sys

from ramensim.config import load_scenario
from ramensim.core.errors import InputError


def add_parser(sub) -> None:
    p = sub.add_parser("validate", help="check scenario files", description=__doc__)
    p.add_argument("files", nargs="+", help="scenario YAML files")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a field by dotted key (repeatable)")
    p.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="FILE_OR_MODULE",
                   help="load a plugin first: a .py file (relative to the working directory) or a module that "
                        "registers a method, radio model or scene (repeatable; docs/EXTENDING.md)")
    p.set_defaults(func=run)


def _not_a_sweep_file(path: str) -> None:
    """A sweep file given to validate gets pointed to the check made for those."""
    from ramensim.config import load_scenario_dict

    try:
        data = load_scenario_dict(path)
    except InputError:
        return  # load_scenario reports it
    if isinstance(data, dict) and "base" in data and "axes" in data:
        raise InputError(f"{path}: this is a sweep file (it has 'base' and 'axes'), not a scenario; check it with "
                         f"'ramensim sweep {path} --dry-run', which validates every point it expands to.")


def run(args: argparse.Namespace) -> int:
    failed = 0
    for path in args.files:
        try:
            _not_a_sweep_file(path)
            load_scenario(path, args.overrides, plugins=args.plugins)
        except InputError as exc:
            failed += 1
            print(f"error: {exc}", file=sys.stderr)
        else:
            print(f"{path}: ok")
    return 2 if failed else 0
