r"""How ``vfs study`` scales with cores: wall time against workers, as users run it.

A generated ``default``-preset database of ``--cases`` cases (seed 11) is
written to a temporary folder; then ``python -m vfs study --db FOLDER
--systems S`` runs in a fresh interpreter (:func:`vfs.bench.study.run_cli`)
once with ``--engine serial`` and once per worker count W of ``--workers``
with ``--engine process --workers W``, and (with ``--dask``) with ``--engine
dask --workers W`` for the largest W. Every ``runs.parquet`` is compared
with the serial one (a case's float outputs may differ in their last bits
between batch compositions, see docs/performance.md; everything else must
be equal), so a run that scaled by losing work would show.

Writes ``core_scaling.json`` (one record per run: engine, workers, wall
seconds, speed-up and efficiency against serial, the largest float
difference) and ``core_scaling.png`` (speed-up against workers with the
ideal line) to ``--out``. Meant for a many-core machine::

    python benchmarks/core_scaling.py --cases 10000 --workers 2,4,8,16 --dask \
        --out docs/figures
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.bench.study import generated_database, run_cli


def _largest_difference(a: pd.DataFrame, b: pd.DataFrame) -> float:
    """Largest absolute difference of the float columns; raises if anything else differs."""
    a = a.sort_values(["system", "case_id"]).reset_index(drop=True)
    b = b.sort_values(["system", "case_id"]).reset_index(drop=True)
    if list(a.columns) != list(b.columns) or len(a) != len(b):
        raise RuntimeError("runs.parquet differs in columns or rows")
    worst = 0.0
    for col in a.columns:
        x, y = a[col], b[col]
        if pd.api.types.is_float_dtype(x):
            both = x.isna() & y.isna()
            if not (x.isna() == y.isna()).all():
                raise RuntimeError(f"runs.parquet: missing values of {col} differ")
            d = np.abs(x[~both].to_numpy() - y[~both].to_numpy())
            worst = max(worst, float(d.max()) if d.size else 0.0)
        elif not x.equals(y):
            raise RuntimeError(f"runs.parquet: column {col} differs")
    return worst


def plot_sets(sets: dict[str, list[dict[str, Any]]], path: Path) -> None:
    """Speed-up against workers, one line per labelled set of records (the serial run
    at 1 worker; the ideal and the 0.75-efficiency lines).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.5, 4.0))
    ax = fig.add_subplot()
    top = max(r["workers"] for rs in sets.values() for r in rs)
    ax.plot([1, top], [1, top], color="0.6", ls="--", lw=1, label="ideal")
    ax.plot([1, top], [0.75, 0.75 * top], color="0.8", ls=":", lw=1, label="0.75 efficiency")
    markers = iter("os^vD")
    for label, records in sets.items():
        for engine in ("process", "dask"):
            rs = sorted((r for r in records if r["engine"] == engine), key=lambda r: r["workers"])
            if not rs:
                continue
            xs = [1] + [r["workers"] for r in rs]
            ys = [1.0] + [r["speedup"] for r in rs]
            ax.plot(xs, ys, marker=next(markers, "o"), label=f"{label}, --engine {engine}")
    ax.set_xlabel("workers (processes)")
    ax.set_ylabel("speed-up of the wall time against --engine serial")
    first = next(iter(sets.values()))[0]
    ax.set_title(f"vfs study, {first['cases']:,} cases x {first['runs_per_case']} runs")
    ax.legend(frameon=False, fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=150)


def main() -> None:  # noqa: D103
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--systems", default="three-stage,ideal")
    parser.add_argument("--workers", default="2,4,8,16")
    parser.add_argument("--dask", action="store_true", help="also a local dask cluster")
    parser.add_argument("--serial-wall", type=float, default=None,
                        help="wall seconds of the serial run measured earlier on this machine: "
                             "the serial run is skipped (and the comparison of runs.parquet)")
    parser.add_argument("--out", default="docs/figures")
    parser.add_argument("--combine", nargs="+", metavar="LABEL=FILE",
                        help="only draw core_scaling.png from earlier core_scaling.json files")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.combine:
        sets = {label: json.loads(Path(f).read_text())
                for label, f in (item.split("=", 1) for item in args.combine)}
        plot_sets(sets, out / "core_scaling.png")
        return
    runs_per_case = 1 + len(args.systems.split(","))
    workers = [int(w) for w in args.workers.split(",")]
    plan = ([] if args.serial_wall else [("serial", 1)]) + [("process", w) for w in workers]
    if args.dask:
        plan.append(("dask", max(workers)))
    records: list[dict[str, Any]] = []
    tmp = Path(tempfile.mkdtemp(prefix="vfs-cores-"))
    try:
        t0 = time.perf_counter()
        db = generated_database(tmp / "db", args.cases)
        print(f"generated {args.cases} cases in {time.perf_counter() - t0:.1f} s", flush=True)
        serial: pd.DataFrame | None = None
        serial_wall = args.serial_wall
        for engine, w in plan:
            folder = tmp / f"study-{engine}-{w}"
            argv = ["study", "--db", str(db), "--systems", args.systems, "--engine", engine,
                    "--out", str(folder), "--overwrite"]
            if engine != "serial":
                argv += ["--workers", str(w)]
            wall, cpu = run_cli(argv)
            runs = pd.read_parquet(folder / "runs.parquet")
            if serial is None and not args.serial_wall:
                serial, serial_wall = runs, wall
            diff = None if serial is None else _largest_difference(serial, runs)
            rec = {"cases": args.cases, "systems": args.systems,
                   "runs_per_case": runs_per_case, "engine": engine, "workers": w,
                   "wall_s": wall, "children_cpu_s": cpu,
                   "case_runs_per_s_wall": args.cases * runs_per_case / wall,
                   "speedup": serial_wall / wall, "efficiency": serial_wall / wall / w,
                   "largest_float_difference": diff, "cpus": os.cpu_count()}
            print(json.dumps(rec), flush=True)
            records.append(rec)
            shutil.rmtree(folder, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    (out / "core_scaling.json").write_text(json.dumps(records, indent=1))
    plot_sets({"this run": records}, out / "core_scaling.png")


if __name__ == "__main__":
    main()
