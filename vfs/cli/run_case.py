"""``vfs run-case``: one case end to end, printed as an impact table."""

from __future__ import annotations

import argparse
import math
from typing import Any

from vfs.cli.common import add_figure_options, add_input_option
from vfs.physics.precrash import PrecrashParams
from vfs.units import KMH_PER_MS


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs run-case``."""
    p = subparsers.add_parser(
        "run-case", help="simulate one case end to end and print the impact table",
        description="Re-simulate one case: pre-crash along the recorded paths (optionally "
        "with braking), contact, penetration, impact, run-out to rest. Without --db the "
        "built-in example (head-on with partial overlap in a bend) is used.",
    )
    add_figure_options(p)  # draws figures
    add_input_option(p, required=False, help=(  # reads a database
        "database folder (Parquet or CSV), or 'default' for the bundled synthetic database; "
        "default: built-in example"))
    p.add_argument("--case", help="case_id (default: the first case)")
    p.add_argument("--plot", metavar="FILE", help="write a top-view figure (PNG/SVG/PDF)")
    p.add_argument("--brake-at-s", type=float, metavar="T",
                   help="what-if: vehicle 1 brakes from T seconds after the record start")
    p.add_argument("--brake-deceleration", type=float, default=9.0, metavar="A",
                   help="demanded deceleration for --brake-at-s [m/s^2] (default 9.0)")
    p.add_argument("--penetration-ms", type=float, metavar="MS",
                   help="penetration time after first contact [ms] (default: the model's, "
                   f"{PrecrashParams().penetration_time * 1e3:g} ms)")
    p.add_argument("--animate", metavar="FILE",
                   help="write an animation (.gif, or .mp4 with ffmpeg) of the case in the AEB "
                   "environment: the recorded behaviour and with --system side by side, the "
                   "drawing of the environment's rgb_array render mode")
    p.add_argument("--system", default="three-stage",
                   help="AEB system of --animate (default three-stage; vfs study --help "
                   "lists them)")
    p.add_argument("--fps", type=float, default=20.0,
                   help="frames per second of --animate (one frame per 50 ms; default 20)")
    p.set_defaults(func=cmd_run_case)


def cmd_run_case(args: argparse.Namespace) -> int:
    """Run ``vfs run-case``."""
    import dataclasses

    import numpy as np

    from vfs.errors import DataError, DataProblem
    from vfs.physics.precrash import ScheduledBraking
    from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases

    if args.db:
        from vfs.database import open_database

        db = open_database(args.db)
    else:
        from vfs.scenarios.examples import example_case_database

        db = example_case_database()
    ids = db.case_ids
    if args.case is None:
        case_id = ids[0]
    else:
        matches = [c for c in ids if str(c) == str(args.case)]
        if not matches:
            raise DataError(DataProblem("cases", "case_id", None, args.case,
                                        f"no such case; the database has {len(ids)} cases "
                                        f"(first: {[c.item() for c in ids[:5]]})"))
        case_id = matches[0]
    batch = CaseBatch.from_database(db, [case_id])
    controller = None
    if args.brake_at_s is not None:
        controller = ScheduledBraking([[args.brake_at_s, np.nan]],
                                      [[args.brake_deceleration, 0.0]])
    params = SimulationParams()
    if args.penetration_ms is not None:
        params = dataclasses.replace(params, precrash=dataclasses.replace(
            params.precrash, penetration_time=args.penetration_ms / 1e3))
    res = simulate_cases(batch, controller=controller, params=params)
    print(format_case_report(results_table(batch, res).iloc[0]))
    if args.plot:
        from vfs.report.figures import plot_case_topview

        plot_case_topview(batch, res, 0, args.plot)
        print(f"top view -> {args.plot}")
    if args.animate:
        if not args.db:
            raise DataError(DataProblem("cases", "case_id", None, args.case,
                                        "--animate needs --db (the AEB environment's cases)"))
        from vfs.gym.animation import animate_traces, play_traces

        base, treated = play_traces(args.db, case_id, args.system)
        n = animate_traces([base, treated], [f"case {case_id}: recorded behaviour",
                                             f"case {case_id}: with {args.system}"],
                           args.animate, fps=args.fps)
        print(f"animation -> {args.animate} ({n} frames at {args.fps:g} fps; "
              f"{base.outcome or 'running'} | {treated.outcome or 'running'})")
    return 0


def format_case_report(r: Any) -> str:
    """The impact table of one case for people (km/h, degrees).

    Parameters
    ----------
    r : pandas.Series
        A row of :func:`vfs.simulation.results_table` (SI units).
    """
    kmh = KMH_PER_MS
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
    deg = math.degrees(1.0)

    def row_of(label: str, key: str, scale: float = 1.0, fmt: str = "{:12.2f}") -> str:
        return f"  {label:28s}" + "".join(fmt.format(r[f"{key}{i}"] * scale) for i in (1, 2))

    lines += [
        row_of("impact speed [km/h]", "impact_speed", kmh),
        row_of("yaw rate at impact [rad/s]", "yaw_rate", 1.0, "{:12.3f}"),
        row_of("delta-v [km/h]", "delta_v", kmh),
        row_of("EES [km/h]", "ees", kmh),
        row_of("PDOF [deg]", "pdof", deg, "{:12.1f}"),
        row_of("velocity angle change [deg]", "velocity_angle_change", deg, "{:12.1f}"),
        row_of("rest x [m]", "rest_x"),
        row_of("rest y [m]", "rest_y"),
        row_of("rest yaw [deg]", "rest_yaw", deg, "{:12.1f}"),
        row_of("run-out distance [m]", "runout_distance"),
        row_of("time to rest [s]", "time_to_rest"),
        f"  energy loss {r['energy_loss'] / 1e3:.1f} kJ; secondary collision: "
        f"{'yes' if r['secondary_collision'] else 'no'}",
    ]
    return "\n".join(lines)
