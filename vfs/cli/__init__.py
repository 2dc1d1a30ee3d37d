"""The ``vfs`` command line: one entry point, one module per command group.

Each module of this package has ``add_parsers(subparsers)``; the sub-parsers
set ``func(args) -> int`` (the exit code).  User errors
(:class:`vfs.errors.VfsError`) are printed as one line without a traceback and
give exit code 2.  Heavy imports happen inside the commands, so ``vfs --help``
stays fast.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from vfs.cli import (
    bench,
    compare,
    db,
    diagnose,
    generate,
    gym,
    impact,
    learn,
    run_case,
    study,
    uncertainty,
)
from vfs.errors import VfsError

#: Every command group of the CLI, in the order of ``vfs --help``.
COMMAND_GROUPS: tuple[Callable[[argparse._SubParsersAction], object], ...] = (
    impact.add_parsers,
    run_case.add_parsers,
    bench.add_parsers,
    db.add_parsers,
    generate.add_parsers,
    study.add_parsers,
    compare.add_parsers,
    diagnose.add_parsers,
    learn.add_parsers,
    uncertainty.add_parsers,
    gym.add_parsers,
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every command."""
    from vfs.version import __version__

    parser = argparse.ArgumentParser(
        prog="vfs",
        description="Virtual forward simulation of real accidents for the assessment of ADAS.",
    )
    parser.add_argument("--version", action="version", version=f"vfs {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in COMMAND_GROUPS:
        add(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vfs`` console script (and ``python -m vfs``)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    try:
        return int(args.func(args))
    except VfsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


__all__ = ["COMMAND_GROUPS", "build_parser", "main"]
