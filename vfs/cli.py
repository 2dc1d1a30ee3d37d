"""The ``vfs`` command line.

Sub-commands are added by small ``add_parsers(subparsers)`` functions, one
per module, collected in :data:`COMMAND_GROUPS`; each sub-parser sets
``func(args) -> int`` (the exit code).  User errors (:class:`vfs.errors.VfsError`)
are printed without a traceback and give exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence

from vfs.errors import VfsError


def _add_impact(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "impact", help="batch-solve a table of impact configurations (Parquet or CSV)",
        description="Solve every row of an impact table with the Kudlich-Slibar model. "
        "Columns and units: docs/data-format.md, section 'Impact tables'.",
    )
    p.add_argument("--input", required=True, help="input table (.parquet or .csv)")
    p.add_argument("--output", required=True, help="output table (.parquet or .csv)")
    p.add_argument("--on-error", choices=("raise", "record"), default="raise",
                   help="'raise': stop on the first bad table and list every bad row; "
                   "'record': write an error column and solve the valid rows")
    p.set_defaults(func=_run_impact)


def _run_impact(args: argparse.Namespace) -> int:
    from pathlib import Path

    from vfs.impact_table import read_table, solve_impact_table, write_table_atomic

    df = read_table(args.input)
    out = solve_impact_table(df, on_error=args.on_error, table=Path(args.input).name)
    write_table_atomic(out, args.output)
    counts = out["impact_type"].value_counts().to_dict()
    summary = ", ".join(f"{k}: {v}" for k, v in sorted(counts.items()))
    print(f"solved {len(out)} impacts ({summary}) -> {args.output}")
    return 0


def _add_bench(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("bench", help="measure throughput (impacts/s, clipping, ...)")
    p.add_argument("names", nargs="*", help="benchmarks to run (default: all)")
    p.add_argument("--quick", action="store_true", help="smaller batches, fewer repetitions")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.set_defaults(func=_run_bench)


def _run_bench(args: argparse.Namespace) -> int:
    from vfs.bench import format_results, run_benchmarks, write_json

    results = run_benchmarks(args.names or None, quick=args.quick)
    print(format_results(results))
    if args.json:
        write_json(results, args.json)
    return 0


def _optional(module: str) -> Callable[[argparse._SubParsersAction], None]:
    """Command group living in another module (``module.add_parsers``)."""

    def add(subparsers: argparse._SubParsersAction) -> None:
        importlib.import_module(module).add_parsers(subparsers)

    return add


#: Every command group of the CLI.
COMMAND_GROUPS: list[Callable[[argparse._SubParsersAction], None]] = [
    _add_impact,
    _add_bench,
    _optional("vfs.database.cli"),
]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered command."""
    from vfs import __version__

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
    """Entry point of the ``vfs`` console script."""
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
