"""``vfs identify`` and ``vfs learn`` (see :mod:`vfs.diagnosis.identify`,
:mod:`vfs.diagnosis.learn`).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from vfs.cli.common import add_input_option, out_folder, out_option, say
from vfs.errors import ParameterError


def cmd_identify(args: argparse.Namespace) -> int:
    """Identify the channels per case and write identified.parquet/.csv."""
    from vfs.database import open_database, resolve_database_path
    from vfs.diagnosis.calibrate import CalibrationData
    from vfs.diagnosis.identify import identification_features, identify, write_identification

    out_folder(args, "identify", args.db)
    db = open_database(args.db)
    data = CalibrationData.from_database(db, args.outputs)
    t0 = time.perf_counter()
    table = identify(data, args.parameters, grid_points=args.grid, zoom_starts=args.zoom,
                     noise=getattr(args, "noise", "estimated"))
    seconds = time.perf_counter() - t0
    paths = write_identification(table, identification_features(data), args.out,
                                 {"database": str(resolve_database_path(args.db)),
                                  "grid_points": args.grid, "zoom_starts": args.zoom,
                                  "seconds": round(seconds, 2),
                                  "outputs": list(data.group_names)})
    for ch, g in table.groupby("channel", sort=False):
        say(f"{ch} [{g['unit'].iloc[0]}]: median {g['value'].median():.4g}, identifiable "
            f"{100 * g['identifiable'].mean():.0f} % of {len(g)} cases (flat "
            f"{100 * g['flat'].mean():.0f} %, multimodal {100 * g['multimodal'].mean():.0f} %,"
            f" at a bound {100 * g['at_bound'].mean():.0f} %; interval chi2 <= min + k^2"
            f" with k = {g['interval_factor'].iloc[0]:.2f} from the cases' consistency)")
    say(f"identified {table['channel'].nunique()} channels on {data.n} cases in "
        f"{seconds:.1f} s -> {paths['parquet']}, {paths['csv']}")
    return 0


def _read_identified(folder: str) -> object:
    import pandas as pd

    p = Path(folder)
    f = p / "identified.parquet" if p.is_dir() else p
    if not f.is_file():
        raise ParameterError(f"--identified {folder}: no identified.parquet (run vfs identify)")
    return pd.read_parquet(f) if f.suffix == ".parquet" else pd.read_csv(f)


def cmd_learn(args: argparse.Namespace) -> int:
    """Learn the laws of the identified channels; write law.json and/or a plugin."""
    from vfs.atomic import write_json, write_text
    from vfs.diagnosis.learn import LEARN_SCOPE, laws_document, learn, plugin_source, read_laws

    laws = None
    if args.identified:
        table = _read_identified(args.identified)
        channels = None if args.channels in (None, "", "all") else args.channels.split(",")
        results = learn(table, channels, folds=args.folds, seed=args.seed)
        for r in results:
            say(r.text())
        say(f"Note: {LEARN_SCOPE}.")
        doc = laws_document(results)
        if args.out:
            write_json(args.out, doc, strict=False)
            say(f"laws -> {args.out} ({len(doc['laws'])} significant)")
        laws = doc["laws"]
    elif args.law:
        laws = read_laws(args.law)
    else:
        raise ParameterError("vfs learn: give --identified DIR (learn) or --law FILE (export)")
    if args.export_plugin:
        if not laws:
            raise ParameterError("no significant law to export")
        pick = [x for x in laws if args.channel in (None, x["channel"])]
        if not pick:
            raise ParameterError(f"no law of channel {args.channel!r}")
        write_text(args.export_plugin, plugin_source(pick[0], Path(args.export_plugin).name))
        say(f"plugin -> {args.export_plugin} (effect {pick[0]['name']}; use --plugin "
            f"{args.export_plugin})")
    if laws:
        print(json.dumps([x["formula"] for x in laws if "formula" in x], indent=1))
    return 0


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``identify`` and ``learn`` to the main parser."""
    from vfs.effects.learned import CHANNELS

    p = subparsers.add_parser(
        "identify", help="per-case values of model channels that reproduce the reconstruction",
        description=(
            f"For every case and channel ({', '.join(CHANNELS)}) the value that "
            "best reproduces the reconstruction outcomes (chi^2 of the residuals standardised "
            "by the _sd scales), a chi^2 + 1 interval (noise scale estimated, --noise) and "
            "identifiability flags. Writes "
            "identified.parquet, identified.csv and units.json into --out."))
    add_input_option(p, help="database folder, or 'default'")  # reads a database
    p.add_argument("--parameters", default="all",
                   help="channels, comma separated, or 'all' (default)")
    p.add_argument("--outputs", default=None, help="compared outputs (default all available)")
    p.add_argument("--grid", type=int, default=21, help="grid values per channel (default 21)")
    p.add_argument("--zoom", type=int, default=0, metavar="N",
                   help="zoom per case into the N lowest minima of its grid profile (finer "
                        "than the grid; two more simulations per channel; default 0 = off)")
    p.add_argument("--noise", choices=("estimated", "recorded"), default="estimated",
                   help="output scales of the chi^2 and its interval: the recorded _sd scales "
                        "times each output's robust noise factor, intervals widened by the "
                        "cases' consistency (estimated, default), or the recorded ones")
    out_option(p, "output folder", "identify-<db>")
    p.set_defaults(func=cmd_identify)

    q = subparsers.add_parser(
        "learn", help="learn laws of identified channels over case features",
        description=(
            "Regress each identified channel on the case features with k-fold CV (closed "
            "forms and a smoothing spline), write the significant laws (law.json, usable "
            "with --plugin law.json) and optionally an editable Python plugin. Significant "
            "means structure in the identified values (each channel identified with the "
            "others at the model's values, so a law missing on one channel leaks into "
            "others); vfs diagnose --laws decides which laws are claimed (outcome CV, "
            "stepwise)."))
    q.add_argument("--identified", default=None, help="folder written by vfs identify")
    q.add_argument("--law", default=None, help="existing law.json (to export a plugin)")
    q.add_argument("--channels", default=None, help="channels to learn (default all)")
    q.add_argument("--folds", type=int, default=5, help="CV folds (default 5)")
    q.add_argument("--seed", type=int, default=0, help="seed of folds and bootstrap")
    q.add_argument("--out", default=None, help="law.json to write")
    q.add_argument("--export-plugin", dest="export_plugin", default=None, metavar="FILE.py",
                   help="write the law as an editable Python plugin")
    q.add_argument("--channel", default=None, help="law exported (default the first)")
    q.set_defaults(func=cmd_learn)
