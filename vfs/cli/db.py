"""Command-line interface of the database tools:
``vfs db validate|schema|convert|import-pcm|export-xosc|import-xosc``.

:func:`add_parsers` adds the command group to the main ``vfs`` parser; every
subcommand sets ``func``, a callable ``func(args) -> int`` returning the exit
code.  Data problems are printed, one per line.  Exit codes: ``validate`` returns 1 when the
database it checks has problems (its verdict); every other command returns 2
(:data:`USER_ERROR`, as every ``vfs`` command does for a user error) when its input cannot be
read, other user errors reach :func:`vfs.cli.main`, which prints them and returns 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from vfs.cli.common import add_input_option
from vfs.database.formats import DATABASE_FORMATS, formats_by_priority
from vfs.database.io import save_database
from vfs.database.pcm import import_pcm
from vfs.database.schema import TABLE_NAMES
from vfs.database.source import load_any, resolve_database_path
from vfs.errors import DataError, ParameterError

#: Exit code of a user error (unreadable input, bad value): the code of every ``vfs`` command.
USER_ERROR = 2


def _path(arg: str | Path) -> str:
    """A database argument as a folder (``default`` is the bundled database)."""
    return str(resolve_database_path(str(arg)))


def _print_problems(error: DataError) -> None:
    print(f"{len(error.problems)} problem(s):")
    for problem in error.problems:
        print(f"  - {problem}")


def cmd_validate(args: argparse.Namespace) -> int:
    """``vfs db validate DIR [--strict]``: print "OK: ..." or every problem (exit code 1).

    The checks are those every command makes on loading (:mod:`vfs.database.checks`);
    here the plausibility warnings are listed instead of printed one by one.
    """
    import warnings

    from vfs.database.checks import strict_input
    from vfs.errors import DataWarning

    try:
        with warnings.catch_warnings(record=True) as caught, strict_input(args.strict):
            warnings.simplefilter("always", DataWarning)
            db = load_any(_path(args.directory), validate=True)
    except DataError as error:
        _print_problems(error)
        return 1
    found = []
    for item in caught:
        if isinstance(item.message, DataWarning):
            found.append(item.message.problem)
        else:  # not ours: shown as usual
            warnings.showwarning(item.message, item.category, item.filename, item.lineno)
    if all(len(df) == 0 for df in db.tables().values()):  # loading accepts an empty selection
        print("1 problem(s):\n  - table 'cases', column 'case_id': the database is empty: "
              "every table has 0 rows")
        return 1
    if found:
        print(f"{len(found)} plausibility warning(s) (a real database can contain these; "
              f"--strict makes them errors):")
        for problem in found:
            print(f"  - {problem}")
    print(
        f"OK: {db.n_cases} cases, {len(db.participants)} participants, "
        f"{len(db.trajectories)} trajectory samples, {len(db.reconstruction)} "
        f"reconstructions (schema {db.meta.get('schema_version')})"
    )
    return 0


def runs_columns() -> list[str]:
    """The columns of a study's ``runs.parquet``, in file order: the study's own run of the
    built-in example case with the ``three-stage`` system (key columns, results, AEB events).
    """
    import numpy as np

    from vfs.adas import get_system
    from vfs.scenarios.examples import example_case_database
    from vfs.simulation import CaseBatch, SimulationParams
    from vfs.study.tasks import normalise_runs, run_batch

    db = example_case_database()
    batch = CaseBatch.from_database(db)
    table, _, _ = run_batch(batch, get_system("three-stage"), np.ones((batch.size, 2), bool),
                            SimulationParams(), np.random.default_rng(0))
    table.insert(0, "system", "three-stage")
    table["error"] = ""
    table["equipped1"] = table["equipped2"] = True
    return list(normalise_runs(table, db.cases).columns)


def _column_listing(table: str) -> tuple[str, dict[str, object]]:
    """Text (column, unit, description) and JSON of one table's columns."""
    from vfs.database.metadata import field_metadata
    from vfs.database.schema import TABLES

    columns = runs_columns() if table == "runs" else [c.name for c in TABLES[table].columns]
    meta = field_metadata(columns, table=None if table == "runs" else table,
                          stored=table != "runs")
    rows = [(c, meta.get(c, {}).get("unit", "?") or "-", meta.get(c, {}).get("description", ""))
            for c in columns]
    width = max(len(r[0]) for r in rows)
    units = max(len(r[1]) for r in rows)
    where = ("a study's runs.parquet, SI units (vfs.read_runs puts them in df.attrs)"
             if table == "runs" else f"the database table {table}, units as stored in its files")
    lines = [f"{table}: {where}", f"{'column':{width}}  {'unit':{units}}  description"]
    lines += [f"{c:{width}}  {u:{units}}  {d}" for c, u, d in rows]
    doc: dict[str, object] = {"table": table, "columns": [{"name": c, "unit": u, "description": d}
                                       for c, u, d in rows]}
    return "\n".join(lines) + "\n", doc


def cmd_schema(args: argparse.Namespace) -> int:
    """``vfs db schema [TABLE] [--format text|json|frictionless] [--out FILE]``."""
    import json

    from vfs.database.metadata import frictionless_schema, schema_json

    if args.table:
        listing, table_doc = _column_listing(args.table)
        fmt = args.format or "text"
        if fmt == "frictionless":
            raise ParameterError("--format frictionless describes the whole database; "
                                 "drop TABLE or use --format text|json")
        text = listing if fmt == "text" else json.dumps(table_doc, indent=2) + "\n"
    else:
        fmt = args.format or "json"
        if fmt == "text":
            raise ParameterError("--format text lists one table: name it (vfs db schema runs)")
        doc = frictionless_schema() if fmt == "frictionless" else schema_json()
        text = json.dumps(doc, indent=2, ensure_ascii=False) + "\n"
    args.format = fmt
    if args.out:
        from vfs.atomic import write_text

        write_text(args.out, text)
        print(f"schema ({args.format}) -> {args.out}")
    else:
        sys.stdout.write(text)
    return 0


def cmd_convert(args: argparse.Namespace) -> int:
    """``vfs db convert SRC DST --to FORMAT`` (a writable :data:`DATABASE_FORMATS` entry)."""
    try:
        db = load_any(_path(args.source), validate=True)
        writer = DATABASE_FORMATS.get(args.to).save
        if writer is None:
            raise ParameterError(f"--to {args.to}: this format is read only")
        out = writer(db, args.destination)
    except DataError as error:
        _print_problems(error)
        return USER_ERROR
    print(f"wrote {db.n_cases} cases to {out} ({args.to})")
    return 0


def cmd_import_pcm(args: argparse.Namespace) -> int:
    """``vfs db import-pcm SRC DST``: PCM CSV folder -> Parquet database."""
    try:
        db = import_pcm(args.source)
        out = save_database(db, args.destination)
    except DataError as error:
        _print_problems(error)
        return USER_ERROR
    report = db.meta.get("pcm_import", {})
    print(f"imported {db.n_cases} cases into {out}")
    if isinstance(report, dict):
        for column, text in report.get("defaults_used", {}).items():
            print(f"  default used for {column}: {text}")
        if report.get("skipped_cases"):
            print(f"  skipped cases (not exactly two participants): {report['skipped_cases']}")
    return 0


def cmd_export_xosc(args: argparse.Namespace) -> int:
    """``vfs db export-xosc --db DIR --case ID [...] [--run STUDY] [--system NAME] --out DIR``."""
    from vfs.database import open_database
    from vfs.interop.motion import simulated_motion, study_motion
    from vfs.interop.openscenario import export_case

    if args.run and not args.system:
        raise ParameterError("--run needs --system NAME (one of the study's systems)")
    db = open_database(args.db)
    for case in args.case:
        motion = None
        if args.run:
            motion = study_motion(args.run, args.db, case, args.system)
        elif args.system:
            motion = simulated_motion(db, case, args.system, equip=args.equip, seed=args.seed)
        result = export_case(db, case, args.out, motion=motion, road=args.road,
                             lane_width=args.lane_width_m, validate=args.validate)
        roads = result.roads
        m = result.motion
        ending = (f"collision at t = {m.impact_time:.3f} s" if m.collided and
                  m.impact_time == m.impact_time else "collision" if m.collided
                  else "no collision")
        print(f"case {m.case_id} ({m.source}, {ending}) -> {result.xosc}")
        print(f"  road -> {result.xodr}: {len(roads.roads)} road(s), {roads.mode}"
              + (f", largest lateral distance of a lane centre from the fitted reference "
                 f"line {roads.fit_error:.2f} m" if roads.mode == "path" else ""))
        for note in (*m.notes, *roads.notes):
            print(f"  {note}")
        if args.validate:
            print("  both files validate against the ASAM schemas (OpenSCENARIO 1.3.1, "
                  "OpenDRIVE 1.7)")
    return 0


def cmd_import_xosc(args: argparse.Namespace) -> int:
    """``vfs db import-xosc FILE.xosc [...] --out DIR``: OpenSCENARIO -> Parquet database."""
    from vfs.interop.scenario_import import import_xosc

    try:
        db = import_xosc(args.files, name=args.name or "")
        out = save_database(db, args.out)
    except DataError as error:
        _print_problems(error)
        return USER_ERROR
    print(f"imported {db.n_cases} case(s) from {len(args.files)} file(s) into {out}")
    notes = db.meta.get("import_notes", [])
    for note in notes if isinstance(notes, list) else []:
        print(f"  {note}")
    return 0


def add_parsers(
    subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
) -> argparse.ArgumentParser:
    """Add the ``db`` command group to a subparsers object.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        Result of ``parser.add_subparsers()`` of the main CLI.

    Returns
    -------
    argparse.ArgumentParser
        The ``db`` parser.
    """
    db = subparsers.add_parser("db", help="accident-case databases: validate, convert, import, "
                               "exchange with OpenSCENARIO",
                               description="Accident-case databases: validate a folder against the "
                               "schema, convert between Parquet, CSV and PreCrash-Matrix folders, "
                               "import PreCrash-Matrix data, export cases as OpenSCENARIO/"
                               "OpenDRIVE files and import such files. Format: "
                               "docs/data-format.md; OpenSCENARIO: docs/interop.md.")
    commands = db.add_subparsers(dest="db_command", metavar="COMMAND", required=True)

    validate = commands.add_parser("validate", help="check a database against the schema")
    validate.add_argument("directory", type=Path, help="Parquet, CSV or PCM folder, or 'default'")
    validate.add_argument("--strict", action="store_true",
                          help="plausibility warnings (speeds vs positions, yaw vs direction "
                          "of travel, limits of road vehicles) count as errors (exit code 1)")
    validate.set_defaults(func=cmd_validate)

    schema = commands.add_parser(
        "schema", help="print the database schema (JSON or a Frictionless Table Schema)",
        description="Print the schema of the database tables: per column its type, unit (as "
        "stored in the files), description and allowed values. --format frictionless gives "
        "a Frictionless Data Package (Table Schema per table, the unit as the custom field "
        "property 'unit'). The same units and descriptions are in the field metadata of "
        "every Parquet file vfs writes.")
    schema.add_argument("table", nargs="?", choices=("runs", *TABLE_NAMES),
                        help="list one table's columns with unit and description: 'runs' "
                        "(a study's runs.parquet, SI) or a database table")
    schema.add_argument("--format", choices=("text", "json", "frictionless"), default=None,
                        help="output format (default: json for the whole schema, text for one "
                        "table)")
    schema.add_argument("--out", type=Path, help="write to this file instead of stdout")
    schema.set_defaults(func=cmd_schema)

    convert = commands.add_parser("convert", help="convert between database formats")
    convert.add_argument("source", type=Path, help="Parquet, CSV or PCM folder")
    convert.add_argument("destination", type=Path, help="output folder (replaced)")
    writable = [f.name for f in formats_by_priority() if f.save is not None]
    convert.add_argument("--to", choices=writable, required=True,
                         help="output format: " + "; ".join(
                             f"{f.name}: {f.doc}" for f in formats_by_priority()
                             if f.save is not None))
    convert.set_defaults(func=cmd_convert)

    pcm = commands.add_parser("import-pcm", help="PreCrash-Matrix CSV folder -> Parquet")
    pcm.add_argument("source", type=Path, help="folder with participant_data.csv, ...")
    pcm.add_argument("destination", type=Path, help="output database folder (replaced)")
    pcm.set_defaults(func=cmd_import_pcm)

    from vfs.study.layout import Equip

    export = commands.add_parser(
        "export-xosc", help="cases -> OpenSCENARIO (.xosc) + OpenDRIVE (.xodr) files",
        description="Write each case as an OpenSCENARIO 1.3 scenario and an OpenDRIVE 1.7 "
        "road: both vehicles (rear-axle reference point, dimensions, mass, axles) with their "
        "trajectories as timed polylines, a two-lane road (straight, or fitted to the "
        "recorded paths). With --system the motion is re-simulated with that AEB system; "
        "with --run STUDY exactly as that study simulated it. Needs the optional extra: "
        'pip install "vfs-accident[xosc]". Run a file with: esmini --window 60 60 800 400 --osc '
        "case_1.xosc. See docs/interop.md.")
    add_input_option(export, help="database folder, or 'default'")  # reads a database
    export.add_argument("--case", required=True, nargs="+", metavar="ID", help="case id(s)")
    export.add_argument("--out", required=True, type=Path, help="output folder")
    export.add_argument("--run", metavar="STUDY", type=Path,
                        help="study folder: export the motion with --system as the study "
                        "simulated it (same chunk, seed and equip rule)")
    export.add_argument("--system", metavar="NAME",
                        help="AEB system: export the motion with the system instead of the "
                        "recorded one (vfs study --help lists the systems)")
    export.add_argument("--equip", choices=[m.value for m in Equip], default=Equip.BOTH.value,
                        help="vehicles carrying --system without --run (default both)")
    export.add_argument("--seed", type=int, default=0,
                        help="seed of --system without --run (default 0)")
    export.add_argument("--road", choices=("auto", "straight", "path"), default="auto",
                        help="road: straight along participant 1's initial heading, or "
                        "fitted to the recorded paths (lines, arcs, spirals); auto = "
                        "straight where the case's road curvature is 0 (default)")
    export.add_argument("--lane-width-m", type=float, default=3.5, metavar="W",
                        help="width of each of the two lanes [m] (default 3.5)")
    export.add_argument("--validate", action="store_true",
                        help="validate the files against the ASAM XSD schemas (xmlschema)")
    export.set_defaults(func=cmd_export_xosc)

    imp = commands.add_parser(
        "import-xosc", help="OpenSCENARIO files (two vehicles, polylines) -> database",
        description="Read OpenSCENARIO 1.x files, one case each, into a Parquet database: "
        "two entities (Vehicle or MiscObject: dimensions, mass, axles) and their "
        "FollowTrajectoryAction polylines of timed WorldPosition vertices (reference point "
        "converted to the CG); friction and curvature from the OpenDRIVE road where the "
        "file has no vfs properties. Needs no extra. See docs/interop.md.")
    imp.add_argument("files", nargs="+", type=Path, metavar="FILE.xosc")
    imp.add_argument("--out", required=True, type=Path,
                     help="output database folder (replaced)")
    imp.add_argument("--name", help="database name in meta.json")
    imp.set_defaults(func=cmd_import_xosc)
    return db
