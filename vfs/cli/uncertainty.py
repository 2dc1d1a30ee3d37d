"""``vfs uncertainty``, ``vfs sensitivity`` and ``vfs reconstruct`` (command group of
:mod:`vfs.cli`, registered as ``_optional("vfs.cli.uncertainty")``).

Methods and outputs: docs/uncertainty.md.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from vfs.cli.common import add_figure_options, add_input_option, out_folder, out_option
from vfs.errors import ParameterError
from vfs.units import KMH_PER_MS


def parse_case_list(text: str | None) -> list[str] | None:
    """``"3,17,42"`` -> ``["3", "17", "42"]`` (None: every case)."""
    if text is None:
        return None
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise ParameterError(f"--cases {text!r}: give case ids separated by commas")
    return items


def parse_range(text: str, flag: str) -> tuple[float, float]:
    """``"LO,HI"`` -> (lo, hi) with lo < hi (ParameterError naming the flag)."""
    parts = [p.strip() for p in text.split(",")]
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise ParameterError(f"{flag} {text!r}: expected two numbers LO,HI") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise ParameterError(f"{flag} {text!r}: need 0 <= LO < HI")
    return lo, hi


def _positive(value: Any, flag: str, integer: bool = False, minimum: float = 0.0) -> Any:
    if value is None:
        return None
    v = int(value) if integer else float(value)
    if not (math.isfinite(v) and v > minimum):
        raise ParameterError(f"{flag} {value}: must be > {minimum:g}")
    return v


def _load_cases(args: argparse.Namespace) -> Any:
    """The CaseSet of ``--db`` / ``--where`` / ``--cases`` / ``--max-cases``."""
    return _load_db_and_cases(args)[1]


def _load_db_and_cases(args: argparse.Namespace) -> tuple[Any, Any]:
    """The database of ``--db`` / ``--where`` and :func:`_load_cases`'s CaseSet."""
    from vfs.cli.common import open_db
    from vfs.uncertainty import CaseSet

    db = open_db(args)
    cases = CaseSet.from_database(db, parse_case_list(getattr(args, "cases", None)))
    limit = getattr(args, "max_cases", None)
    if limit is not None:
        limit = _positive(limit, "--max-cases", integer=True)
        cases = cases.take(slice(0, limit))
    return db, cases


def _config(args: argparse.Namespace) -> Any:
    from vfs.uncertainty import load_config

    return load_config(args.config)


def _common(p: argparse.ArgumentParser, max_cases_default: int | None = None) -> None:
    add_input_option(p, help="database folder (Parquet, CSV or PCM) or 'default' for the "
                     "bundled one")  # reads a database
    p.add_argument("--cases", metavar="IDS", help="case ids, comma separated (default: every "
                   "case with a reconstruction)")
    p.add_argument("--where", metavar="SQL", help="SQL predicate on the cases table, e.g. "
                   "\"accident_type IN (241, 242)\"")
    p.add_argument("--max-cases", dest="max_cases", type=int, default=max_cases_default,
                   metavar="N", help="only the first N selected cases"
                   + (f" (default {max_cases_default})" if max_cases_default else ""))
    p.add_argument("--config", metavar="TOML", help="input distributions (TOML, on top of "
                   "vfs/data/uncertainty_default.toml; see docs/uncertainty.md)")
    p.add_argument("--seed", type=int, default=0, help="seed of all random numbers (default 0)")
    out_option(p, "output folder", f"{p.prog.split()[-1]}-<db>")
    p.add_argument("--no-plots", dest="no_plots", action="store_true", help="skip figures")


def cmd_uncertainty(args: argparse.Namespace) -> int:
    """Run ``vfs uncertainty``."""
    from vfs.report.uncertainty import write_uncertainty_report
    from vfs.uncertainty import OUTCOMES_BY_NAME, run_uncertainty

    samples = _positive(args.samples, "--samples", integer=True)
    out_folder(args, "uncertainty", args.db)
    db, cases = _load_db_and_cases(args)
    db = db.subset(cases.case_id)  # the provenance names the cases the bands are of
    result = run_uncertainty(cases, _config(args), n_samples=samples, seed=args.seed,
                             keep_samples=args.save_samples, sampling=args.sampling)
    files = write_uncertainty_report(result, args.out, plots=not args.no_plots, database=db,
                                     database_reference=str(args.db))
    summary = result.summary()
    print(f"{cases.size} cases x {samples} samples ({args.sampling}) = "
          f"{cases.size * samples} model runs in "
          f"{result.seconds:.1f} s")
    print("median relative half-width (p95 - p5) / (2 median) over the cases "
          "[all / nominal full / nominal sliding]:")
    for name in ("delta_v1", "delta_v2", "ees1", "ees2", "velocity_angle_change1",
                 "post_speed1", "runout_distance1", "runout_distance2", "energy_loss"):
        parts = []
        for group in ("all", "full", "sliding"):
            row = summary[(summary["outcome"] == name) & (summary["group"] == group)]
            v = float(row["median_rel_half_width"].iloc[0]) if len(row) else math.nan
            parts.append("-" if math.isnan(v) else f"+-{100 * v:.0f} %")
        print(f"  {OUTCOMES_BY_NAME[name].label:28s} " + " / ".join(parts))
    print(f"mean probability of a sliding impact: {result.cases['p_sliding'].mean():.2f}")
    print(f"report -> {files['report_md']} and {files['report_html']}; bands -> "
          f"{files['bands_parquet']}")
    return 0


def cmd_sensitivity(args: argparse.Namespace) -> int:
    """Run ``vfs sensitivity``."""
    from vfs.report.uncertainty import write_sensitivity_report
    from vfs.uncertainty import OUTCOMES_BY_NAME
    from vfs.uncertainty.sensitivity import sensitivity_analysis

    outcomes = None
    if args.outcomes:
        outcomes = [o.strip() for o in args.outcomes.split(",") if o.strip()]
    n_base = _positive(args.base_samples, "--base-samples", integer=True)
    n_boot = int(args.bootstrap)
    if n_boot < 0:
        raise ParameterError(f"--bootstrap {n_boot}: must be >= 0")
    out_folder(args, "sensitivity", args.db)
    cases = _load_cases(args)
    result = sensitivity_analysis(cases, _config(args), n_base=n_base, seed=args.seed,
                                  outcomes=outcomes, n_boot=n_boot)
    files = write_sensitivity_report(result, args.out, plots=not args.no_plots)
    print(f"{cases.size} cases, {result.n_runs} model runs in {result.seconds:.1f} s")
    shown = [o for o in ("delta_v1", "ees1", "velocity_angle_change1", "runout_distance1",
                         "sliding") if o in set(result.groups["outcome"])]
    for outcome in shown:
        for group in ("full", "sliding"):
            t = result.ranking(outcome, group).head(4)
            if t.empty or not t["n_cases"].max():
                continue
            text = ", ".join(f"{r.input} {r.st:.2f}" for r in t.itertuples())
            print(f"  {OUTCOMES_BY_NAME[outcome].label:26s} {group:8s} ST: {text}")
    print(f"report -> {files['report_md']} and {files['report_html']}; indices -> "
          f"{files['groups_parquet']}")
    return 0


def cmd_reconstruct(args: argparse.Namespace) -> int:
    """Run ``vfs reconstruct`` for each ``--case``."""
    from pathlib import Path

    from vfs.report.uncertainty import write_reconstruct_report
    from vfs.uncertainty import Distribution
    from vfs.uncertainty.reconstruct import (
        ObservationSettings,
        ReconstructSettings,
        format_reconstruction,
        reconstruct,
    )

    if args.speed_range_kmh and args.speed_factor_range:
        raise ParameterError("give either --speed-range-kmh or --speed-factor-range")

    def prior(flag_kmh: str | None, flag_name: str) -> Distribution:
        if flag_kmh:
            lo, hi = parse_range(flag_kmh, flag_name)
            return Distribution("uniform", "absolute", low=lo / KMH_PER_MS,
                                high=hi / KMH_PER_MS, unit="km/h")
        if args.speed_range_kmh:
            lo, hi = parse_range(args.speed_range_kmh, "--speed-range-kmh")
            return Distribution("uniform", "absolute", low=lo / KMH_PER_MS,
                                high=hi / KMH_PER_MS, unit="km/h")
        lo, hi = parse_range(args.speed_factor_range or "0.5,1.5", "--speed-factor-range")
        return Distribution("uniform", "factor", low=lo, high=hi)

    observe = tuple(o.strip() for o in args.observe.split(",") if o.strip())

    def rad(v: float | None, flag: str) -> float | None:
        v = _positive(v, flag)
        return None if v is None else math.radians(v)

    obs = ObservationSettings(
        observe=observe,
        rest_position_sd=_positive(args.rest_position_sd_m, "--rest-position-sd-m"),
        rest_yaw_sd=rad(args.rest_yaw_sd_deg, "--rest-yaw-sd-deg"),
        ees_sd=None if args.ees_sd_kmh is None else _positive(args.ees_sd_kmh,
                                                                "--ees-sd-kmh") / KMH_PER_MS,
        direction_sd=rad(args.direction_sd_deg, "--direction-sd-deg"))
    settings = ReconstructSettings(
        speed1=prior(args.speed1_range_kmh, "--speed1-range-kmh"),
        speed2=prior(args.speed2_range_kmh, "--speed2-range-kmh"),
        k_sigma=_positive(args.k_sigma, "--k-sigma"), criterion=args.criterion,
        n_prior=_positive(args.samples, "--samples", integer=True),
        n_starts=_positive(args.starts, "--starts", integer=True),
        n_chains=int(args.chains), n_steps=int(args.steps), burn_in=int(args.steps) // 2,
        thin=max(1, int(args.steps) // 20))
    args.max_cases = None
    args.where = None
    args.cases = ",".join(args.case)
    out_folder(args, "reconstruct", args.db, *args.case[:1])
    cases = _load_cases(args)
    config = _config(args)
    out = Path(args.out)
    for k, case_id in enumerate(cases.case_id):
        rec = reconstruct(cases, case_id, config, obs, settings, seed=args.seed + k)
        folder = out if len(cases.case_id) == 1 else out / f"case_{case_id}"
        files = write_reconstruct_report(rec, folder, plots=not args.no_plots)
        print(format_reconstruction(rec))
        print(f"  report -> {files['report_md']}; feasible set -> {files['feasible']}")
    return 0


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``uncertainty``, ``sensitivity`` and ``reconstruct`` to the main parser."""
    from vfs.uncertainty import OUTCOME_NAMES
    from vfs.uncertainty.reconstruct import OBSERVABLES
    from vfs.uncertainty.sampling import DEFAULT_SAMPLING, SAMPLING_METHODS

    p = subparsers.add_parser(
        "uncertainty", help="Monte-Carlo bands of every outcome (the Collision Calculation "
        "Uncertainty paper's +- percent)",
        description="Sample the uncertain inputs (road friction, restitution, contact friction, "
        "POI shift, contact-plane angle, penetration time, speeds at impact, masses, post-crash "
        "wheel brakes) from the distributions of the configuration, solve impact and run-out "
        "for every sample of every case from the reconstruction's impact configuration, and "
        "report per case and outcome the median, the 5-95 % band, the relative half-width "
        "(p95 - p5) / (2 median) and the probability of a sliding impact. Writes bands.parquet, "
        "cases.parquet, summary.csv, uncertainty.json, report.md/html and figures. Details: "
        "docs/uncertainty.md.")
    add_figure_options(p)  # draws figures
    _common(p)
    p.add_argument("--samples", type=int, default=1024,
                   help="samples per case (default 1024; a power of two keeps Sobol' balanced)")
    p.add_argument("--sampling", choices=SAMPLING_METHODS, default=DEFAULT_SAMPLING,
                   help="random: plain Monte Carlo; sobol: scrambled Sobol' per case; lhs: "
                   f"Latin hypercube per case (default {DEFAULT_SAMPLING}: fewest samples for "
                   "a given band accuracy, docs/uncertainty.md)")
    p.add_argument("--save-samples", dest="save_samples", action="store_true",
                   help="also write every model run to samples.parquet")
    p.set_defaults(func=cmd_uncertainty)

    s = subparsers.add_parser(
        "sensitivity", help="Sobol indices of the outcomes on the uncertain inputs, full vs "
        "sliding impacts (the variance-based analysis the Momentum Based Impact Model paper's "
        "outlook proposes as an ANOVA; the paper itself ran none)",
        description="Saltelli sampling and the Saltelli (2010) / Jansen (1999) estimators of "
        "first-order and total Sobol indices per case, averaged over the cases whose nominal "
        "impact is full and those whose nominal impact is sliding, with bootstrap intervals, "
        "ranked bar figures and a dummy input as a check. Outcomes: "
        + ", ".join(OUTCOME_NAMES) + ". Details: docs/uncertainty.md.")
    add_figure_options(s)  # draws figures
    _common(s, max_cases_default=60)
    s.add_argument("--base-samples", dest="base_samples", type=int, default=256,
                   help="base samples n per case, a power of two; n (d + 2) runs per case "
                   "(default 256)")
    s.add_argument("--outcomes", metavar="LIST", default=None,
                   help="outcomes, comma separated (default: delta-v, EES, change of velocity "
                   "angle, post-impact speed, rest distance of both vehicles, sliding)")
    s.add_argument("--bootstrap", type=int, default=200,
                   help="bootstrap resamples for the intervals (default 200; 0: none)")
    s.set_defaults(func=cmd_sensitivity)

    r = subparsers.add_parser(
        "reconstruct", help="impact speeds consistent with the rest positions: the feasible "
        "set and its spread",
        description="Inverse mode: find the impact speeds and uncertain parameters consistent "
        "with the observed rest positions and headings (optionally EES and post-impact "
        "directions) within their tolerances. Every observation enters as a residual scaled "
        "by its standard deviation (database _sd columns, the flags below, or documented "
        "defaults). Monte-Carlo acceptance (the Collision Calculation Uncertainty paper), a local "
        "optimiser "
        "(scipy least_squares) and chains exploring the feasible set; reports the feasible "
        "set, its 5-95 % spread and the optimum with its scaled residuals. Details: "
        "docs/uncertainty.md.")
    add_figure_options(r)  # draws figures
    add_input_option(r, help="database folder (Parquet, CSV or PCM) or 'default' for the "
                     "bundled one")  # reads a database
    r.add_argument("--case", action="append", required=True, metavar="ID",
                   help="case to reconstruct (repeatable)")
    r.add_argument("--observe", default="rest_position,rest_yaw",
                   help="observations, comma separated: " + ", ".join(OBSERVABLES)
                   + " (default rest_position,rest_yaw)")
    r.add_argument("--rest-position-sd-m", dest="rest_position_sd_m", type=float,
                   help="sd of each rest coordinate [m] (default: database, else 0.3)")
    r.add_argument("--rest-yaw-sd-deg", dest="rest_yaw_sd_deg", type=float,
                   help="sd of the rest heading [deg] (default: database, else 5)")
    r.add_argument("--ees-sd-kmh", dest="ees_sd_kmh", type=float,
                   help="sd of the EES [km/h] (default: database, else 10 %% of the EES)")
    r.add_argument("--direction-sd-deg", dest="direction_sd_deg", type=float,
                   help="sd of the post-impact direction of motion [deg] (default: database, "
                   "else 5)")
    r.add_argument("--speed-factor-range", dest="speed_factor_range", default=None,
                   help="uniform prior of both impact speeds as factors of the database's "
                   "speeds (default 0.5,1.5)")
    r.add_argument("--speed-range-kmh", dest="speed_range_kmh",
                   help="uniform prior of both impact speeds LO,HI [km/h] instead")
    r.add_argument("--speed1-range-kmh", dest="speed1_range_kmh",
                   help="prior of vehicle 1's impact speed LO,HI [km/h]")
    r.add_argument("--speed2-range-kmh", dest="speed2_range_kmh",
                   help="prior of vehicle 2's impact speed LO,HI [km/h]")
    r.add_argument("--k-sigma", dest="k_sigma", type=float, default=2.0,
                   help="accept when every |scaled residual| <= K (default 2; --criterion box)")
    r.add_argument("--criterion", choices=("box", "chi2"), default="box",
                   help="box (default): every |r| <= K; chi2: sum r^2 <= chi2 quantile 0.95")
    r.add_argument("--samples", type=int, default=20_000,
                   help="Monte-Carlo samples of the acceptance stage (default 20000)")
    r.add_argument("--starts", type=int, default=6,
                   help="local optimisations from the best samples spread over the speed "
                   "prior (default 6; more find more basins of the feasible set)")
    r.add_argument("--chains", type=int, default=400,
                   help="chains exploring the feasible set (default 400; 0: none)")
    r.add_argument("--steps", type=int, default=80,
                   help="steps per chain, the first half burn-in (default 80)")
    r.add_argument("--config", metavar="TOML", help="distributions of the uncertain "
                   "parameters (see docs/uncertainty.md)")
    r.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    out_option(r, "output folder (one sub-folder per case when several are given)",
               "reconstruct-<db>")
    r.add_argument("--no-plots", dest="no_plots", action="store_true", help="skip figures")
    r.set_defaults(func=cmd_reconstruct)
