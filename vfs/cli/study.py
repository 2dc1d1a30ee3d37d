"""Command line of AEB studies: ``vfs study`` and ``vfs report effectiveness``.

:func:`add_parsers` adds both to the main ``vfs`` parser (:mod:`vfs.cli`).
``report`` is a command group that other modules may extend: its
sub-parsers are looked up with :func:`report_subparsers` and created only
once.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from vfs.cli.common import (
    WHERE_HELP,
    add_figure_options,
    add_impact_parameters_option,
    add_input_option,
    out_option,
)
from vfs.errors import ParameterError, VfsError
from vfs.settings import Setting, cli_kwargs, declared


def _optional_help(s: Setting) -> str:
    """The help of an optional setting without a default: its doc and what absent means."""
    return f"{s.doc} (default {s.optional_doc})" if s.optional_doc else s.doc


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 1")
    return value


def _default_equip(db: str) -> str:
    """``meta["equip"]`` of the database (the Euro NCAP matrix equips the VUT: "1"), else
    :attr:`Equip.BOTH`.
    """
    from vfs.database import database_location
    from vfs.database.io import read_meta

    try:
        meta, _ = read_meta(database_location(db))
    except (OSError, VfsError):  # unreadable here: run_study reports it properly
        return "both"
    from vfs.study.layout import EQUIP_RULES, Equip

    equip = str(meta.get("equip", Equip.BOTH))
    return equip if equip in EQUIP_RULES else Equip.BOTH.value


def cmd_study(args: argparse.Namespace) -> int:
    """``vfs study``: run or resume a study and print its summary."""
    from vfs.cli.common import load_plugins, out_folder, path_label
    from vfs.study import StudySpec, run_study
    from vfs.study.spec import Equip
    from vfs.study.systems import split_systems

    load_plugins(args.plugin)
    systems = [str(s) for s in split_systems(args.systems)]
    if not systems:
        raise ParameterError("--systems: name at least one system, e.g. three-stage,ideal")
    from vfs.study.faults import (
        EXIT_FAILED_CASES,
        EXIT_TERMINATED,
        Terminated,
        failed_runs,
        stop_on_signals,
    )

    out_folder(args, "study", args.db, "+".join(path_label(s) for s in systems))
    spec = StudySpec(
        args.db, tuple(systems), args.out, engine=args.engine, workers=args.workers,
        scheduler=args.scheduler, chunk_size=args.chunk_size, task_cases=args.task_cases,
        seed=args.seed, where=args.where, equip=Equip(args.equip or _default_equip(args.db)),
        resume=args.resume, overwrite=args.overwrite,
        impact_parameters=args.impact_parameters, dashboard=args.dashboard)
    # SIGINT and SIGTERM are handled here, once (the workers ignore them): the study
    # stops, kills its workers, writes its manifest, and this says how to resume
    with stop_on_signals():
        try:
            result = run_study(spec)
        except KeyboardInterrupt as exc:
            what = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"
            if (Path(args.out) / "study.json").exists():
                print(f"{what}; the manifest says 'interrupted'; finished chunks are kept in "
                      f"{args.out}; continue with the same command and --resume",
                      file=sys.stderr, flush=True)
            else:
                print(f"{what} before the study started; nothing was written to {args.out}",
                      file=sys.stderr, flush=True)
            return EXIT_TERMINATED if isinstance(exc, Terminated) else 130
    print(result.summary())
    if result.complete:
        print(f"runs -> {result.path / 'runs.parquet'}")
        failed = failed_runs(result.manifest)
        if failed and not args.allow_failed:
            print(f"error: {failed} run(s) failed inside the simulation (their rows in "
                  f"runs.parquet hold the error and NaN outcomes); --allow-failed accepts them "
                  f"(exit code {EXIT_FAILED_CASES})", file=sys.stderr)
            return EXIT_FAILED_CASES
        return 0
    from vfs.study.run import EXIT_INCOMPLETE

    print(f"the study is incomplete; continue it with the same command and --resume "
          f"(exit code {EXIT_INCOMPLETE})", file=sys.stderr)
    return EXIT_INCOMPLETE


def cmd_report_effectiveness(args: argparse.Namespace) -> int:
    """``vfs report effectiveness STUDY``: write report.md, report.html and figures."""
    from vfs.report.effectiveness import write_effectiveness_report

    started = time.perf_counter()
    from vfs.cli.common import say

    report = write_effectiveness_report(args.study, risk_curves=args.risk_curve or None,
                                        n_boot=args.bootstrap, seed=args.seed,
                                        confidence=args.confidence,
                                        case_pages=args.case_pages, list_cases=args.list_cases,
                                        say=say)
    print(f"report -> {report} ({time.perf_counter() - started:.1f} s)")
    return 0


def report_subparsers(subparsers: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """The sub-parsers of ``vfs report`` (created on first use, shared by modules)."""
    report = subparsers.choices.get("report")
    if report is None:
        report = subparsers.add_parser(
            "report", help="reports on finished studies (effectiveness, ...)",
            description="Write reports on the results of a study folder.")

        def show_help(args: argparse.Namespace) -> int:
            report.print_help()
            return 1

        report.set_defaults(func=show_help)
    for action in report._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action
    return report.add_subparsers(dest="report", metavar="REPORT")


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs study`` and ``vfs report effectiveness``."""
    p = subparsers.add_parser(
        "study", help="AEB effectiveness study: baseline and treatment runs of every case",
        description="Re-simulate every selected case of a database without a system "
        "(baseline) and with each AEB system on the equipped vehicle(s), in chunks written to "
        "OUT/chunks, combined into OUT/runs.parquet. See docs/study.md.",
    )
    from vfs.adas import SYSTEMS
    from vfs.study import EXECUTORS
    from vfs.study.spec import StudySpec

    add_input_option(p)  # reads a database
    p.add_argument("--systems", required=True, metavar="NAMES",
                   help="comma-separated AEB systems: names or definition files, e.g. "
                   "three-stage,adas/my-aeb.toml; a name is looked up in ./adas/NAME.toml "
                   f"first, then among the built-ins: {', '.join(SYSTEMS)} (adas/README.md, "
                   "docs/aeb.md)")
    p.add_argument("--plugin", action="append", default=None, metavar="MODULE",
                   help="import a module or .py file first that registers systems with "
                   "vfs.adas.register_system (e.g. adas/example_controller.py); repeatable")
    out_option(p, "study folder", "study-<db>-<systems>")
    p.add_argument("--where", metavar="SQL", help=WHERE_HELP)
    spec = declared(StudySpec)  # each setting declared once (vfs.study.spec)
    p.add_argument("--equip", **cli_kwargs(spec["equip"], default=None)
                   | {"help": spec["equip"].doc + " (default the database's meta 'equip', "
                      "else both; euro-ncap-c2c: 1, the VUT)"})
    p.add_argument("--engine", **cli_kwargs(spec["engine"]) | {"choices": EXECUTORS.names()})
    p.add_argument("--workers", type=_positive_int, help=_optional_help(spec["workers"]))
    p.add_argument("--scheduler", metavar="ADDRESS", help=_optional_help(spec["scheduler"]))
    p.add_argument("--dashboard", metavar="ADDRESS", help=_optional_help(spec["dashboard"]))
    p.add_argument("--chunk-size", type=_positive_int, **cli_kwargs(spec["chunk_size"]))
    p.add_argument("--task-cases", type=_positive_int, metavar="N",
                   **cli_kwargs(spec["task_cases"]))
    p.add_argument("--seed", type=int, **cli_kwargs(spec["seed"]))
    add_impact_parameters_option(p, spec["impact_parameters"].default,
                                 "'defaults' is accepted too, with a warning")
    p.add_argument("--allow-failed", action="store_true",
                   help="exit 0 although runs failed inside the simulation (default: exit "
                   "code 4 when any run failed; the rows hold the error either way)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--resume", action="store_true", help=spec["resume"].doc)
    group.add_argument("--overwrite", action="store_true", help=spec["overwrite"].doc)
    p.set_defaults(func=cmd_study)

    report = report_subparsers(subparsers)
    r = report.add_parser(
        "effectiveness", help="effectiveness of the systems of a study versus the baseline",
        description="Crashes avoided, impact-speed and delta-v reduction, impact types and "
        "injury risk per system and accident type, with confidence intervals (Wilson for "
        "shares, BCa bootstrap for ratios); "
        "writes STUDY/report/report.md, report.html and PNG figures.",
    )
    add_figure_options(r)  # draws figures
    r.add_argument("study", help="study folder (results/NAME)")
    r.add_argument("--risk-curve", action="append", metavar="NAME",
                   help="injury-risk curve (vfs.analysis.risk) replacing the default of its "
                   "injury level; "
                   "repeat for several levels (default: nhtsa2022_all_mais3 and "
                   "nhtsa2022_all_fatal)")
    r.add_argument("--bootstrap", type=_positive_int, default=2000,
                   help="bootstrap resamples for the confidence intervals (default 2000)")
    r.add_argument("--confidence", type=float, default=0.95,
                   help="confidence level (default 0.95)")
    r.add_argument("--seed", type=int, default=0, help="seed of the bootstrap (default 0)")
    r.add_argument("--list-cases", type=int, default=5, metavar="N",
                   help="cases listed per system and kind (new crash, not avoided, avoided) "
                   "under 'Cases to look into' (default 5; 0: none)")
    r.add_argument("--case-pages", action=argparse.BooleanOptionalAction, default=True,
                   help="write a page per listed case (report/cases/<id>.html: top views, "
                   "speed and brake traces with the AEB events, impact table) by "
                   "re-simulating only those cases (default: on)")
    r.set_defaults(func=cmd_report_effectiveness)

    s = report.add_parser(
        "side-by-side", help="each system's Euro NCAP result beside its accident-based effect",
        description="For each system found in both studies: its Euro NCAP AEB Car-to-Car "
        "score (study on --db euro-ncap-c2c) beside its share of crashes avoided, net crash "
        "reduction and injury-risk reduction on an accident database (e.g. --db default); "
        "writes OUT/side_by_side.csv, .md and .html. See docs/euro-ncap.md.",
    )
    s.add_argument("--ncap", required=True, metavar="STUDY",
                   help="finished study on --db euro-ncap-c2c")
    s.add_argument("--accidents", required=True, metavar="STUDY",
                   help="finished study on an accident database")
    s.add_argument("--out", required=True, help="output folder, e.g. results/side-by-side")
    s.add_argument("--bootstrap", type=_positive_int, default=2000,
                   help="bootstrap resamples of the accident-based intervals (default 2000)")
    s.add_argument("--confidence", type=float, default=0.95,
                   help="confidence level (default 0.95)")
    s.add_argument("--seed", type=int, default=0, help="seed of the bootstrap (default 0)")
    s.set_defaults(func=cmd_report_side_by_side)


def cmd_report_side_by_side(args: argparse.Namespace) -> int:
    """``vfs report side-by-side``: Euro NCAP result and accident-based effect per system."""
    from vfs.report.euro_ncap import write_side_by_side

    started = time.perf_counter()
    path = write_side_by_side(args.ncap, args.accidents, args.out, n_boot=args.bootstrap,
                              seed=args.seed, confidence=args.confidence)
    print(path.read_text(encoding="utf-8"))
    print(f"side-by-side -> {path} ({time.perf_counter() - started:.1f} s)")
    return 0
