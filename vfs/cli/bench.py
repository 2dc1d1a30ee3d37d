"""``vfs bench``: throughput measurements."""

from __future__ import annotations

import argparse


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs bench``."""
    from vfs.bench import BENCHMARKS

    p = subparsers.add_parser(
        "bench", help="measure throughput (impacts/s, clipping, ...)",
        description="Run benchmarks and print their figures (never asserted in tests). "
        f"Benchmarks: {', '.join(BENCHMARKS)}.")
    p.add_argument("names", nargs="*", metavar="NAME",
                   help="benchmarks to run (default: all)")
    p.add_argument("--quick", action="store_true", help="smaller batches, fewer repetitions")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.set_defaults(func=cmd_bench)


def cmd_bench(args: argparse.Namespace) -> int:
    """Run ``vfs bench``."""
    from vfs.atomic import write_json
    from vfs.bench import format_results, run_benchmarks

    results = run_benchmarks(args.names or None, quick=args.quick)
    print(format_results(results))
    if args.json:
        write_json(args.json, results)
    return 0
