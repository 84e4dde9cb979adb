"""CLI subcommands. Each module exports ``add_parser(subparsers)`` and ``run(args) -> int``."""
