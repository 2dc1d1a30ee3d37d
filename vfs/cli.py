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


def _add_run_case(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "run-case", help="simulate one case end to end and print the impact table",
        description="Re-simulate one case: pre-crash along the recorded paths (optionally "
        "with braking), contact, penetration, impact, run-out to rest. Without --db the "
        "built-in example (head-on with partial overlap in a bend) is used.",
    )
    p.add_argument("--db", help=("database folder (Parquet or CSV), or 'default' for the "
                                 "bundled synthetic database; default: built-in example"))
    p.add_argument("--case", help="case_id (default: the first case)")
    p.add_argument("--plot", metavar="FILE", help="write a top-view figure (PNG/SVG/PDF)")
    p.add_argument("--brake-at-s", type=float, metavar="T",
                   help="what-if: vehicle 1 brakes from T seconds after the record start")
    p.add_argument("--brake-deceleration", type=float, default=9.0, metavar="A",
                   help="demanded deceleration for --brake-at-s [m/s^2] (default 9.0)")
    p.add_argument("--penetration-ms", type=float, default=30.0,
                   help="penetration time after first contact [ms] (default 30)")
    p.set_defaults(func=_run_case)


def _run_case(args: argparse.Namespace) -> int:
    import numpy as np

    from vfs.errors import DataError, DataProblem
    from vfs.precrash import PrecrashParams, ScheduledBraking
    from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases

    if args.db:
        from vfs.database import load_any

        db = load_any(database_path(args.db))
    else:
        from scenarios.examples import example_case_database

        db = example_case_database()
    ids = db.case_ids
    if args.case is None:
        case_id = ids[0]
    else:
        matches = [c for c in ids if str(c) == str(args.case)]
        if not matches:
            raise DataError(DataProblem("cases", "case_id", None, args.case,
                                        f"no such case; the database has {len(ids)} cases "
                                        f"(first: {list(ids[:5])})"))
        case_id = matches[0]
    batch = CaseBatch.from_database(db, [case_id])
    controller = None
    if args.brake_at_s is not None:
        controller = ScheduledBraking([[args.brake_at_s, np.nan]],
                                      [[args.brake_deceleration, 0.0]])
    params = SimulationParams(precrash=PrecrashParams(penetration_time=args.penetration_ms / 1e3))
    res = simulate_cases(batch, controller=controller, params=params)
    print(format_case_report(results_table(batch, res).iloc[0]))
    if args.plot:
        from vfs.plotting import plot_case_topview

        plot_case_topview(batch, res, 0, args.plot)
        print(f"top view -> {args.plot}")
    return 0


def database_path(text: str) -> str:
    """A ``--db`` argument as a folder: ``default`` is the bundled synthetic database."""
    if text == "default":
        from scenarios.generator import bundled_database_path

        return str(bundled_database_path())
    return text


def format_case_report(row: object) -> str:
    """The impact table of one case for people (km/h, degrees)."""
    import math

    r = row  # a pandas Series from vfs.simulation.results_table
    kmh = 3.6
    lines = [f"case {r['case_id']}"]
    if not r["collided"]:
        lines.append(f"  no collision (avoided): closest approach {r['min_distance']:.2f} m at "
                     f"t = {r['time_closest']:.2f} s")
        return "\n".join(lines)
    lines += [
        f"  first contact t = {r['contact_time']:.4f} s, impact t = {r['impact_time']:.4f} s",
        f"  impact type     {r['impact_type']} (eps = {r['restitution']:.2f}, "
        f"mu = {r['contact_friction']:.2f}), closing speed {r['closing_speed'] * kmh:.1f} km/h",
        f"  POI             ({r['poi_x']:.3f}, {r['poi_y']:.3f}) m, contact plane "
        f"{math.degrees(r['cp_angle']):.1f} deg, overlap {r['overlap_area']:.3f} m^2",
        "",
        f"  {'':28s}{'vehicle 1':>12s}{'vehicle 2':>12s}",
    ]

    def row_of(label: str, key: str, scale: float = 1.0, fmt: str = "{:12.2f}") -> str:
        return f"  {label:28s}" + "".join(fmt.format(r[f"{key}{i}"] * scale) for i in (1, 2))

    lines += [
        row_of("impact speed [km/h]", "impact_speed", kmh),
        row_of("yaw rate at impact [rad/s]", "yaw_rate", 1.0, "{:12.3f}"),
        row_of("delta-v [km/h]", "delta_v", kmh),
        row_of("EES [km/h]", "ees", kmh),
        row_of("PDOF [deg]", "pdof", 180.0 / math.pi, "{:12.1f}"),
        row_of("velocity angle change [deg]", "velocity_angle_change", 180.0 / math.pi,
               "{:12.1f}"),
        row_of("rest x [m]", "rest_x"),
        row_of("rest y [m]", "rest_y"),
        row_of("rest yaw [deg]", "rest_yaw", 180.0 / math.pi, "{:12.1f}"),
        row_of("run-out distance [m]", "runout_distance"),
        row_of("time to rest [s]", "time_to_rest"),
        f"  energy loss {r['energy_loss'] / 1e3:.1f} kJ; secondary collision: "
        f"{'yes' if r['secondary_collision'] else 'no'}",
    ]
    return "\n".join(lines)


def _optional(module: str) -> Callable[[argparse._SubParsersAction], None]:
    """Command group living in another module (``module.add_parsers``)."""

    def add(subparsers: argparse._SubParsersAction) -> None:
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name == module:  # command group not (yet) part of this installation
                return
            raise
        mod.add_parsers(subparsers)

    return add


#: Every command group of the CLI.
COMMAND_GROUPS: list[Callable[[argparse._SubParsersAction], None]] = [
    _add_impact,
    _add_run_case,
    _add_bench,
    _optional("vfs.database.cli"),
    _optional("scenarios.cli"),
    _optional("vfs.study_cli"),
    _optional("vfs.compare_cli"),
    _optional("vfs.diagnose_cli"),
    _optional("vfs.uncertainty_cli"),
    _optional("adas.gym_cli"),
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
