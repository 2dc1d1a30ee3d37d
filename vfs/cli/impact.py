"""``vfs impact``: batch-solve a table of impact configurations."""

from __future__ import annotations

import argparse

from vfs.cli.common import add_input_option


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs impact``."""
    p = subparsers.add_parser(
        "impact", help="batch-solve a table of impact configurations (Parquet or CSV)",
        description="Solve every row of an impact table with the Kudlich-Slibar model. "
        "Columns and units: docs/data-format.md, section 'Impact tables'.",
    )
    add_input_option(p, "--input", help="input table (.parquet or .csv)")  # reads a table
    p.add_argument("--output", required=True, help="output table (.parquet or .csv)")
    p.add_argument("--on-error", choices=("raise", "record"), default="raise",
                   help="'raise': stop on the first bad table and list every bad row; "
                   "'record': write an error column and solve the valid rows (default raise)")
    p.set_defaults(func=cmd_impact)


def cmd_impact(args: argparse.Namespace) -> int:
    """Run ``vfs impact``: record batches in, solved record batches out (memory bounded)."""
    from vfs.database.impact_table import solve_impact_file

    counts = solve_impact_file(args.input, args.output, on_error=args.on_error)
    summary = ", ".join(f"{k}: {v}" for k, v in sorted(counts.items()))
    print(f"solved {sum(counts.values())} impacts ({summary}) -> {args.output}")
    return 0
