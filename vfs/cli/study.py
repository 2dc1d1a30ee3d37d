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

from vfs.cli.common import DB_HELP, WHERE_HELP
from vfs.errors import ParameterError


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 1")
    return value


def cmd_study(args: argparse.Namespace) -> int:
    """``vfs study``: run or resume a study and print its summary."""
    from vfs.study import StudySpec, run_study

    systems = [s.strip() for s in args.systems.split(",") if s.strip()]
    if not systems:
        raise ParameterError("--systems: name at least one system, e.g. three-stage,ideal")
    spec = StudySpec(
        args.db, tuple(systems), args.out, engine=args.engine, workers=args.workers,
        scheduler=args.scheduler, chunk_size=args.chunk_size, task_cases=args.task_cases,
        seed=args.seed, where=args.where, equip=args.equip, resume=args.resume,
        overwrite=args.overwrite, impact_parameters=args.impact_parameters,
        dashboard=args.dashboard)
    try:
        result = run_study(spec)
    except KeyboardInterrupt:
        print(f"interrupted; finished chunks are kept in {args.out}; continue with the same "
              "command and --resume", file=sys.stderr)
        return 130
    print(result.summary())
    if result.complete:
        print(f"runs -> {result.path / 'runs.parquet'}")
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
    from vfs.study.layout import DEFAULT_CHUNK_SIZE
    from vfs.study.spec import DEFAULT_TASK_CASES, Equip, ImpactParameterSource

    p.add_argument("--db", required=True, help=DB_HELP)
    p.add_argument("--systems", required=True, metavar="NAMES",
                   help="comma-separated AEB systems, e.g. three-stage,ideal; known: "
                   f"{', '.join(SYSTEMS)} (docs/aeb.md)")
    p.add_argument("--out", required=True, help="study folder, e.g. results/NAME")
    p.add_argument("--where", metavar="SQL", help=WHERE_HELP)
    p.add_argument("--equip", choices=[m.value for m in Equip], default=Equip.BOTH.value,
                   help="vehicles carrying the system in the treatment runs (default both)")
    p.add_argument("--engine", choices=EXECUTORS.names(), default="process",
                   help="executor: serial, local processes (default), dask, or one registered "
                   "with vfs.study.register_executor or by an installed package (entry-point "
                   "group vfs.executors)")
    p.add_argument("--workers", type=_positive_int,
                   help="parallel workers (default: min(CPUs, chunks))")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="dask scheduler address, e.g. tcp://host:8786 (with --engine dask; "
                   "default a local cluster); its workers need the same vfs and numpy")
    p.add_argument("--dashboard", metavar="ADDRESS",
                   help="serve the dashboard of the local dask cluster at ADDRESS, e.g. :8787, "
                   "and print its link (needs bokeh; default off)")
    p.add_argument("--chunk-size", type=_positive_int, default=DEFAULT_CHUNK_SIZE,
                   help=f"cases per chunk file, the unit of resume and of the random streams "
                   f"(default {DEFAULT_CHUNK_SIZE})")
    p.add_argument("--task-cases", type=_positive_int, default=DEFAULT_TASK_CASES,
                   metavar="N",
                   help="cases one task simulates as one batch: whole chunks, each with its "
                   "own random stream, so results do not depend on it; larger batches share "
                   f"the per-step cost (default {DEFAULT_TASK_CASES}; fewer when workers "
                   "would idle)")
    p.add_argument("--seed", type=int, default=0, help="seed of all random draws (default 0)")
    p.add_argument("--impact-parameters", choices=[m.value for m in ImpactParameterSource],
                   default=ImpactParameterSource.RECONSTRUCTION.value,
                   help="restitution and contact friction: the reconstruction's where present "
                   "(default) or the model defaults")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--resume", action="store_true",
                       help="continue an interrupted study in --out (same inputs)")
    group.add_argument("--overwrite", action="store_true",
                       help="replace an existing study in --out")
    p.set_defaults(func=cmd_study)

    report = report_subparsers(subparsers)
    r = report.add_parser(
        "effectiveness", help="effectiveness of the systems of a study versus the baseline",
        description="Crashes avoided, impact-speed and delta-v reduction, impact types and "
        "injury risk per system and accident type, with confidence intervals (Wilson for "
        "shares, BCa bootstrap for ratios); "
        "writes STUDY/report/report.md, report.html and PNG figures.",
    )
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
