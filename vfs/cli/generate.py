"""``vfs generate``: write a synthetic accident database (see :mod:`vfs.scenarios.generator`)."""

from __future__ import annotations

import argparse
import time

from vfs.errors import ParameterError


def _noise(text: str) -> float:
    if text.strip().lower() in ("none", "off", "0"):
        return 0.0
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--noise {text!r}: give a scale factor >= 0 or 'none'") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"--noise {text!r}: must be >= 0")
    return value


def cmd_generate(args: argparse.Namespace) -> int:
    """Generate, write and summarise a synthetic database."""
    from dataclasses import replace

    from vfs.effects import registered_effects
    from vfs.scenarios.generator import generate_database, get_preset, write_generated

    if args.list_effects:
        for name, cls in sorted(registered_effects().items()):
            params = ", ".join(f"{p.name}={p.default:g} {p.unit} [{p.lo:g}, {p.hi:g}]"
                               for p in cls.parameters)
            print(f"{name}: {cls.summary} ({params})")
        return 0
    if args.out is None:
        raise ParameterError("--out DIR is required")
    preset = get_preset(args.preset)
    noise = None if args.noise is None else replace(preset.noise, scale=args.noise)
    hidden = None if args.hidden is None else [h for h in args.hidden if h.lower() != "none"]
    t0 = time.perf_counter()
    db, truth = generate_database(preset, n_cases=args.cases, seed=args.seed, hidden=hidden,
                                  noise=noise, sample_interval=args.sample_interval)
    folder = write_generated(db, truth, args.out, fmt=args.format, truth_path=args.truth)
    elapsed = time.perf_counter() - t0
    types = db.cases["accident_type"].value_counts().sort_index()
    near = int((~db.cases["collision"].astype(bool)).sum())
    rec = db.reconstruction
    print(f"wrote {folder}: {db.n_cases} cases ({near} near misses), "
          f"{len(db.trajectories)} trajectory samples, {len(rec)} reconstructions "
          f"in {elapsed:.1f} s")
    print("accident types: " + ", ".join(f"{k}: {v}" for k, v in types.items()))
    if len(rec):
        kinds = rec["impact_type"].value_counts()
        print("impact types: " + ", ".join(f"{k}: {v}" for k, v in kinds.items()))
    print("hidden effects and noise: written to the ground-truth file (not shown; "
          "analysis commands never read it)")
    return 0


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs generate`` to the main parser."""
    p = subparsers.add_parser(
        "generate", help="generate a synthetic accident database with hidden effects",
        description=(
            "Generate a CEDATU-like synthetic database: scenes of the accident-type "
            "catalogue, a car fleet, pre-crash trajectories, and reconstructions from the "
            "model plus hidden effects plus measurement noise. The ground truth goes to "
            "ground_truth.json in the output folder."),
    )
    p.add_argument("--preset", default="default",
                   help="recipe: a name (./scenarios/presets/NAME.toml first, then the built-in "
                   "default, study36, clean) or a preset file (scenarios/README.md)")
    p.add_argument("--cases", type=int, default=None, help="number of cases (preset default)")
    p.add_argument("--seed", type=int, default=0, help="seed of all randomness (default 0)")
    p.add_argument("--out", default=None, help="output database folder")
    p.add_argument("--hidden", action="append", default=None, metavar="EFFECT[=VALUE]",
                   help=("hidden effect, repeatable: NAME, NAME=VALUE (primary parameter) or "
                         "NAME:PARAM=VALUE,...; 'none' for no effect; default: the preset's"))
    p.add_argument("--noise", type=_noise, default=None, metavar="SCALE",
                   help="factor on the preset's measurement noise, or 'none'")
    p.add_argument("--sample-interval", type=float, default=None, metavar="SECONDS",
                   help="trajectory sampling [s] (default: the preset's, 0.01)")
    p.add_argument("--format", choices=("parquet", "csv"), default="parquet",
                   help="file format of the database (default parquet)")
    p.add_argument("--truth", default=None, metavar="FILE",
                   help="ground-truth JSON file (default OUT/ground_truth.json)")
    p.add_argument("--list-effects", action="store_true",
                   help="list the effects that can be hidden and exit")
    p.set_defaults(func=cmd_generate)
