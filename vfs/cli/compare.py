"""``vfs compare``: baseline VFS against the reconstructions (command group of :mod:`vfs.cli`)."""

from __future__ import annotations

import argparse

from vfs.cli.common import (
    add_figure_options,
    add_impact_parameters_option,
    add_input_option,
    out_option,
)


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Register ``vfs compare``."""
    from vfs.analysis.compare import OUTCOMES
    from vfs.simulation import ImpactParameterSource

    names = ", ".join(f"{o.name} [{o.display_unit}]" for o in OUTCOMES)
    p = subparsers.add_parser(
        "compare", help="compare the baseline VFS of every reconstructed case with its "
        "reconstruction (impact types, POI, Table 1 of the Momentum Based Impact Model paper, "
        "agreement statistics)",
        description="Compare the baseline virtual forward simulation (no ADAS) of every "
        "reconstructed case with its reconstruction: impact-type contingency (chi-squared as in "
        "the Momentum Based Impact Model paper, McNemar, Bowker, kappa), POI distances in vehicle "
        "coordinates, paired tests "
        "of delta-v, EES, change of velocity angle, post-impact speed, rest positions and more "
        "(t-test, Wilcoxon, Bland-Altman, TOST, Holm), errors per case. Writes comparison.json, "
        "CSV/Parquet tables, report.md, report.html and figures. Details: docs/compare.md.",
    )
    add_figure_options(p)  # draws figures
    add_input_option(p, help="database folder (Parquet, CSV or PCM) or 'default' for the "
                     "bundled one")  # reads a database
    p.add_argument("--run", metavar="DIR",
                   help="results folder of 'vfs study' (its runs.parquet, rows with system == "
                   "'baseline') or a run table file; default: simulate the cases now")
    p.add_argument("--plugin", action="append", default=None, metavar="MODULE",
                   help="import a module, .py file or law.json of vfs learn that registers "
                   "effects used by --model (repeatable)")
    p.add_argument("--model", metavar="CONFIG",
                   help="model configuration (JSON: {\"effects\": [{\"name\": ..., "
                   "\"parameters\": {...}}]}); default: the default model")
    p.add_argument("--where", metavar="SQL", help="SQL predicate on the cases table, e.g. "
                   "\"accident_type IN (241, 242)\"")
    p.add_argument("--margins", metavar="LIST", default="",
                   help="equivalence margins OUTCOME=VALUE[UNIT],... (bare numbers in the "
                   f"report unit): {names}; defaults in docs/compare.md")
    p.add_argument("--alpha", type=float, default=0.05,
                   help="significance level of the equivalence tests (default 0.05)")
    p.add_argument("--top", type=int, default=10, help="worst cases listed (default 10)")
    p.add_argument("--sketches", type=int, default=4,
                   help="worst cases re-simulated and drawn as top views (default 4)")
    add_impact_parameters_option(
        p, ImpactParameterSource.DEFAULT, "compare's default is the model's generic values "
        "for every case (the prospective protocol of the frontal-collision paper); not used "
        "with --run ('defaults' of earlier versions is accepted with a warning)")
    p.add_argument("--case-pages", action=argparse.BooleanOptionalAction, default=True,
                   help="write a page per case in the report's tables (OUT/cases/<id>.html: "
                   "the simulation beside the reconstruction, top views, impact table, speed "
                   "over time) by re-simulating only those cases (default: on)")
    out_option(p, "output folder", "compare-<db>")
    p.set_defaults(func=run_compare)


def run_compare(args: argparse.Namespace) -> int:
    """Run ``vfs compare`` (exit code 0)."""
    from vfs.analysis.compare import compare_database, parse_margins
    from vfs.analysis.model_config import load_model_config
    from vfs.cli.common import load_plugins, open_db, out_folder
    from vfs.report.compare import write_comparison_report

    load_plugins(args.plugin)
    out_folder(args, "compare", args.db)
    db = open_db(args)
    params = load_model_config(args.model) if args.model else None
    comparison = compare_database(db, run=args.run, params=params,
                                  margins=parse_margins(args.margins), alpha=args.alpha,
                                  impact_parameters=args.impact_parameters)
    from vfs.progress import note

    note("writing the report, its figures and case pages")
    files = write_comparison_report(comparison, args.out, database=db, top=args.top,
                                    database_reference=str(args.db),
                                    sketches=args.sketches, case_pages=args.case_pages)
    print(comparison.summary())
    print(f"report -> {files['report_md']} and {files['report_html']} ({len(files)} files)")
    return 0
