r"""How the CPU time of ``vfs study`` grows with the number of cases and of systems.

For each N of ``--cases`` a generated ``default``-preset database of N cases
(seed 11) is written to a temporary folder, and ``python -m vfs study --db
FOLDER --systems S --engine serial`` is run in a fresh interpreter for each
system list S of ``--systems`` (``;``-separated), exactly as a user runs it
(:func:`vfs.bench.study.run_cli`): imports, parser, chunk files and
``runs.parquet`` included.  The CPU time of the child process is recorded
(on a shared machine it is the fairer figure; wall time is also written).

Writes ``scaling.json`` (one record per run) and ``study_scaling.png`` (CPU
seconds against cases, one line per system list; the figure of
docs/performance.md) to ``--out``::

    nice -n 10 python benchmarks/study_scaling.py --cases 200,500,1000,2000 \
        --systems "ideal;three-stage,ideal" --out docs/figures
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

from vfs.bench.study import generated_database, run_cli


def main() -> None:  # noqa: D103
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default="200,500,1000,2000")
    parser.add_argument("--systems", default="ideal;three-stage,ideal")
    parser.add_argument("--task-cases", type=int, default=None,
                        help="--task-cases of vfs study (default: its default)")
    parser.add_argument("--out", default="docs/figures")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    records = []
    tmp = Path(tempfile.mkdtemp(prefix="vfs-scaling-"))
    try:
        for n in (int(c) for c in args.cases.split(",")):
            db = generated_database(tmp / f"db{n}", n)
            for systems in args.systems.split(";"):
                argv = ["study", "--db", str(db), "--systems", systems, "--engine", "serial",
                        "--out", str(tmp / "study"), "--overwrite"]
                if args.task_cases:
                    argv += ["--task-cases", str(args.task_cases)]
                wall, cpu = run_cli(argv)
                runs = n * (1 + len(systems.split(",")))
                rec = {"cases": n, "systems": systems, "case_runs": runs, "cpu_s": cpu,
                       "wall_s": wall, "case_runs_per_s_cpu": runs / cpu,
                       "load_average_1min": os.getloadavg()[0]}
                print(json.dumps(rec), flush=True)
                records.append(rec)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    (out / "scaling.json").write_text(json.dumps(records, indent=1))
    _plot(records, out / "study_scaling.png")


def _plot(records: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 3.8))
    for systems in dict.fromkeys(r["systems"] for r in records):
        rs = [r for r in records if r["systems"] == systems]
        ax.plot([r["cases"] for r in rs], [r["cpu_s"] for r in rs], "o-",
                label=f"baseline + {systems} ({1 + len(systems.split(','))} runs per case)")
    ax.set_xlabel("cases")
    ax.set_ylabel("CPU time of vfs study [s]")
    ax.set_title("vfs study --engine serial, one core")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
