"""``vfs diagnose``, ``vfs calibrate`` and ``vfs ledger`` (see :mod:`vfs.diagnosis.diagnose`,
:mod:`vfs.report.diagnose`).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vfs.cli.common import (
    add_figure_options,
    add_input_option,
    load_plugins,
    out_folder,
    out_option,
)
from vfs.errors import ParameterError
from vfs.settings import cli_kwargs, declared

if TYPE_CHECKING:  # pragma: no cover
    from vfs.database import Database
    from vfs.diagnosis.diagnose import Diagnosis
    from vfs.diagnosis.diagnose_spec import DiagnoseSpec

#: Settings of ``--quick`` (small grids, 3 folds, fewer bootstrap samples).
QUICK = {"folds": 3, "grid": 5, "zoom": 2, "n_boot": 500}
#: Flag -> the :class:`DiagnoseSpec` setting it sets (where the names differ).
FLAGS = {"grid": "grid_points", "zoom": "zoom_rounds"}


def _option(name: str, **kwargs: Any) -> dict[str, Any]:
    """Argparse keywords of the declared setting ``name`` of :class:`DiagnoseSpec`."""
    from vfs.diagnosis.diagnose_spec import DiagnoseSpec  # not imported by other commands

    return cli_kwargs(declared(DiagnoseSpec)[FLAGS.get(name, name)]) | kwargs


def _later(name: str, **kwargs: Any) -> dict[str, Any]:
    """:func:`_option` with default None: the flag's default is set later (``--quick``)."""
    return _option(name, default=None, **kwargs)


def _load_db(text: str) -> tuple[Database, str]:
    from vfs.database import open_database, resolve_database_path

    return open_database(text), str(resolve_database_path(text))


def _settings(args: argparse.Namespace) -> dict[str, int]:
    s = {"folds": args.folds, "grid": args.grid, "zoom": args.zoom, "n_boot": args.n_boot}
    if args.quick:
        for k, v in QUICK.items():
            if getattr(args, k) is None:
                s[k] = v
    from vfs.diagnosis.diagnose_spec import DiagnoseSpec

    specs = declared(DiagnoseSpec)
    return {k: (specs[FLAGS.get(k, k)].default if v is None else int(v)) for k, v in s.items()}


def diagnose_spec(args: argparse.Namespace, database: str = "") -> DiagnoseSpec:
    """The :class:`vfs.diagnosis.diagnose_spec.DiagnoseSpec` of the flags of ``vfs diagnose``."""
    from vfs.diagnosis.diagnose_spec import MAX_STEPS, DiagnoseSpec

    s = _settings(args)
    steps = args.max_steps if args.max_steps is not None else (
        args.law_rounds + 1 if args.law_rounds is not None else MAX_STEPS)
    return DiagnoseSpec(outputs=args.outputs, effects=args.effects, laws=args.laws,
                        folds=s["folds"], seed=args.seed, parameters=args.parameters,
                        grid_points=s["grid"], zoom_rounds=s["zoom"], n_boot=s["n_boot"],
                        correction=args.correction, alpha=args.alpha,
                        min_reduction=args.min_reduction, worst=args.worst, max_steps=steps,
                        database=database)


def _progress() -> Callable[[str], None]:
    """Progress lines with the elapsed time, through the ``vfs`` logger (stderr; ``-q``
    silences them, ``vfs.progress``), on a terminal and when piped alike.
    """
    import time

    from vfs.progress import note

    t0 = time.perf_counter()

    def tell(msg: str) -> None:
        note("[%6.1f s] %s", time.perf_counter() - t0, msg)

    return tell


def format_selection(diag: Diagnosis) -> str:
    """The console's table of the selection (:meth:`Diagnosis.selection_table`, the table
    of the report).
    """
    t = diag.selection_table()
    if not len(t):
        return "(no candidate)"

    def ci(v: float, lo: float, hi: float) -> str:
        return "" if v != v else f"{100 * v:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"

    import pandas as pd

    show = pd.DataFrame({
        "candidate": t["candidate"], "kind": t["kind"], "status": t["status"],
        "alone %": [ci(*r) for r in zip(t["alone"], t["alone_low"], t["alone_high"],
                                         strict=True)],
        "on top %": [ci(*r) for r in zip(t["on_top"], t["on_top_low"], t["on_top_high"],
                                          strict=True)],
        "on top of": t["on_top_of"],
        "share %": [ci(*r) for r in zip(t["share"], t["share_low"], t["share_high"],
                                         strict=True)],
    })
    return show.to_string(index=False)


def cmd_diagnose(args: argparse.Namespace) -> int:
    """Run the diagnosis, write the reports and append the ledger."""
    from vfs.diagnosis.diagnose import diagnose
    from vfs.diagnosis.ledger import append_records, make_record
    from vfs.report.diagnose import write_diagnosis_report

    load_plugins(args.plugin)
    out_folder(args, "diagnose", args.db)
    db, path = _load_db(args.db)
    spec = diagnose_spec(args, str(path))
    diag = diagnose(db, spec, progress=_progress())
    paths = write_diagnosis_report(diag, args.out, json_path=args.json, plots=not args.no_plots,
                                   database=db, database_reference=str(args.db))
    print()
    print(format_selection(diag))
    print()
    for line in diag.verdict:
        print(f"- {line}")
    st = diag.stats
    print(f"\n{st['variants']} model variants simulated ({st['case_runs']} case runs, "
          f"{st['seconds']:.1f} s); total {st['total_seconds']:.1f} s")
    ledger_dir = Path(args.ledger) if args.ledger else Path(args.out).resolve().parent
    records = [make_record(diag.default, diag.data, "default", "diagnose", spec.folds,
                           args.seed, str(path))]
    records += [make_record(c.cv, diag.data, "candidate", "diagnose", spec.folds, args.seed,
                            str(path), note=f"rank {c.rank}; {c.status or 'not significant'}")
                for c in diag.candidates]
    lp = append_records(ledger_dir, records)
    print(f"report -> {paths['html']} and {paths['markdown']}; ranking -> {paths['ranking']}; "
          f"ledger -> {lp}")
    if args.json:
        print(f"summary -> {paths['json']}")
    return 0


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Fit the chosen effects jointly, write the model configuration, append the ledger."""
    from vfs.diagnosis.calibrate import CalibrationData, calibrate, write_model_config
    from vfs.diagnosis.diagnose import resolve_candidates
    from vfs.diagnosis.ledger import append_records, make_record
    from vfs.effects import parse_effect

    load_plugins(args.plugin)
    if not args.effects or args.effects.strip() == "all":
        raise ParameterError("--effects A,B names the effects to calibrate")
    specs = [x.strip() for x in args.effects.split(",") if x.strip()]
    effects = [parse_effect(x) for x in specs]
    resolve_candidates([e.name for e in effects])
    db, path = _load_db(args.db)
    s = _settings(args)
    data = CalibrationData.from_database(db, args.outputs)
    cal = calibrate(data, effects, parameters=args.parameters,
                    folds=0 if args.no_cv else s["folds"], seed=args.seed,
                    grid_points=s["grid"], zoom_rounds=s["zoom"])
    names = "+".join(e.name for e in cal.effects)
    print(f"calibrated {names} on {data.n} cases:")
    for e in cal.effects:
        print(f"  {e.name}: " + ", ".join(f"{k} = {v:.4g}" for k, v in e.values.items()))
    fit: dict[str, object] = {
        "database": str(path), "n_cases": data.n, "outputs": list(data.group_names),
        "parameters": args.parameters, "rmse_in_sample": cal.rmse,
        "objective": cal.train_mse, "stats": cal.stats,
    }
    if cal.steps:
        print(f"\ncross-validated ({s['folds']} folds, seed {args.seed}), standardised RMSE:")
        first = cal.steps[0].overall_rmse()
        for st in cal.steps:
            v = st.overall_rmse()
            print(f"  {st.label:40s} {v:8.4f}  ({100 * (v / first - 1):+.1f} % vs default)")
        fit["cv"] = [{"model": st.label, "cv_rmse_overall": st.overall_rmse(),
                      "cv_rmse": dict(zip(data.group_names, st.rmse().tolist(), strict=True))}
                     for st in cal.steps]
        ledger_dir = Path(args.ledger) if args.ledger else (
            Path(args.out).resolve().parent if args.out else Path("results"))
        recs = [make_record(st, data, "default" if k == 0 else "calibrated", "calibrate",
                            s["folds"], args.seed, str(path))
                for k, st in enumerate(cal.steps)]
        lp = append_records(ledger_dir, recs)
        print(f"ledger -> {lp}")
    if args.out:
        out = write_model_config(args.out, cal.effects,
                                 created_by=f"vfs calibrate --effects {args.effects}", fit=fit)
        print(f"model configuration -> {out}")
    print(f"{cal.stats['variants']} model variants simulated in {cal.stats['seconds']:.1f} s "
          f"(total {cal.stats['total_seconds']:.1f} s)")
    return 0


def cmd_ledger(args: argparse.Namespace) -> int:
    """Show the ledger table, the error chain and write the waterfall figure."""
    from vfs.diagnosis.ledger import (
        chain_table,
        format_chain,
        ledger_chain,
        ledger_path,
        ledger_table,
        read_ledger,
    )
    from vfs.report.ledger import plot_waterfall

    records = read_ledger(args.folder)
    table = ledger_table(records)
    if args.all:
        print(table.drop(columns=["fingerprint"]).to_string(
            index=False, float_format=lambda v: f"{v:.4f}"))
        print()
    fps = table["fingerprint"].unique()
    if len(fps) > 1:
        print(f"note: {len(fps)} different databases/output sets in the ledger; the chain uses "
              "the records comparable with the newest one")
    chain = ledger_chain(records)
    print(format_chain(chain))
    folder = ledger_path(args.folder).parent
    if chain:
        chain_table(chain).to_csv(folder / "ledger_chain.csv", index=False)
        if not args.no_plots:
            fig = plot_waterfall(chain, args.plot or folder / "ledger_waterfall.png")
            print(f"waterfall -> {fig}")
    return 0


def _common(p: argparse.ArgumentParser) -> None:
    add_input_option(p, help="database folder (Parquet or CSV), or 'default' for the bundled "
                     "one")  # reads a database
    p.add_argument("--outputs", default=None,
                   help="compared outputs, comma separated (default: all available): "
                   "delta_v, ees, energy_loss, post_speed, velocity_angle_change, pdof, "
                   "rest_position, rest_yaw, runout_distance, impact_type")
    p.add_argument("--parameters", **_option("parameters"))
    p.add_argument("--folds", type=int, **_later("folds"))
    p.add_argument("--seed", type=int, **_option("seed"))
    p.add_argument("--grid", type=int, **_later("grid"))
    p.add_argument("--zoom", type=int, **_later("zoom"))
    p.add_argument("--quick", action="store_true",
                   help="3 folds, grid 5, 2 zoom rounds, 500 bootstrap samples")
    p.add_argument("--plugin", action="append", default=None, metavar="MODULE",
                   help="import a module, .py file or law.json (vfs learn) that registers "
                   "effects (repeatable)")
    p.add_argument("--ledger", default=None, metavar="DIR",
                   help="folder of ledger.jsonl (default: the parent of --out)")


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``diagnose``, ``calibrate`` and ``ledger`` to the main parser."""
    p = subparsers.add_parser(
        "diagnose", help="where the model fails and which effect is missing",
        description=(
            "Compare the default model with the reconstructions (residuals by stratum, "
            "residual-feature associations, worst cases), cross-validate every candidate "
            "effect (fitted on training folds, scored on held-out folds) and rank them by "
            "the reduction of the CV RMSE with bootstrap CIs. Never reads ground-truth "
            "files. Writes ranking.csv, summary.json, report.md/html with figures into "
            "--out and appends the models to the ledger."),
    )
    add_figure_options(p)  # draws figures
    _common(p)
    p.add_argument("--effects", default="all",
                   help="candidate effects, comma separated, or 'all' (default)")
    p.add_argument("--json", default=None, metavar="FILE", help="also write the summary here")
    out_option(p, "report folder", "diagnose-<db>")
    p.add_argument("--n-boot", dest="n_boot", type=int,
                   **_later("n_boot"))
    p.add_argument("--correction", **_option("correction"))
    p.add_argument("--alpha", type=float, **_option("alpha"))
    p.add_argument("--min-reduction", dest="min_reduction", type=float,
                   **_option("min_reduction"))
    p.add_argument("--worst", type=int, **_option("worst"))
    p.add_argument("--laws", default="all",
                   help="channels identified per case and learned (vfs identify / learn): "
                   "'all' (default), a list, or 'none'; their laws are candidates of the "
                   "one selection with the library effects")
    p.add_argument("--max-steps", dest="max_steps", type=int,
                   **_later("max_steps"))
    p.add_argument("--law-rounds", dest="law_rounds", type=int, default=None,
                   help=argparse.SUPPRESS)
    p.add_argument("--no-plots", dest="no_plots", action="store_true", help="skip figures")
    p.set_defaults(func=cmd_diagnose)

    c = subparsers.add_parser(
        "calibrate", help="fit effect parameters jointly and write a model configuration",
        description=(
            "Fit the parameters of the chosen effects jointly on all cases (bounded "
            "coordinate search), cross-validate the default model and each added effect, "
            "append them to the ledger and write the model configuration for "
            "vfs compare --model."),
    )
    add_figure_options(c)  # draws figures
    _common(c)
    c.add_argument("--effects", required=True,
                   help="effects in the order they are added: NAME or NAME:PARAM=VALUE "
                   "(start values), comma separated")
    c.add_argument("--out", default=None, metavar="CONFIG.json",
                   help="model configuration file to write")
    c.add_argument("--no-cv", dest="no_cv", action="store_true",
                   help="skip the cross-validation (and the ledger)")
    c.set_defaults(func=cmd_calibrate, n_boot=None)

    g = subparsers.add_parser(
        "ledger", help="the model error falling with each added effect",
        description=("Show the error ledger of a results folder: every evaluated model and "
                     "the chain from the default model through each added effect "
                     "(cross-validated RMSE), with a waterfall figure."),
    )
    add_figure_options(g)  # draws figures
    g.add_argument("folder", help="results folder holding ledger.jsonl")
    g.add_argument("--all", action="store_true", help="also list every record")
    g.add_argument("--plot", default=None, metavar="FILE",
                   help="waterfall figure (default FOLDER/ledger_waterfall.png)")
    g.add_argument("--no-plots", dest="no_plots", action="store_true", help="skip the figure")
    g.set_defaults(func=cmd_ledger)
