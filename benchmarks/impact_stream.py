"""Peak memory and CPU time of ``vfs impact`` on large tables (issue 41: streaming).

Generates an impact table of N rows from the impacts of the bundled database's
pre-crash runs (542 configurations repeated, case ids 0..N-1), runs ``vfs impact``
on it under ``/usr/bin/time -v`` with the ``vfs`` of ``--tree`` (a checkout: the
one before streaming for the baseline) and appends a row to ``--out``: rows,
format, tree, peak RSS [MB], user + system CPU [s], wall [s].

    nice -n 10 python benchmarks/impact_stream.py --rows 1e6 --format parquet
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]


def realistic_impacts() -> pd.DataFrame:
    """The impact configurations of the bundled database's pre-crash runs [SI]."""
    from vfs.database import open_database
    from vfs.simulation import CaseBatch, simulate_cases

    db = open_database("default")
    batch = CaseBatch.from_database(db)
    res = simulate_cases(batch)
    hit = np.flatnonzero(res.precrash.collided)
    st = res.precrash.impact_state
    df = pd.DataFrame({"case_id": batch.case_id[hit]})
    for i, veh in ((1, batch.vehicle1), (2, batch.vehicle2)):
        df[f"m{i}"] = np.asarray(veh.mass)[hit]
        df[f"izz{i}"] = np.asarray(veh.yaw_inertia)[hit]
        for f in ("x", "y", "yaw", "vx", "vy", "yaw_rate"):
            df[f"{f}{i}"] = np.asarray(getattr(st, f))[hit, i - 1]
    df["poi_x"], df["poi_y"] = res.poi[hit, 0], res.poi[hit, 1]
    df["cp_angle"] = res.cp_angle[hit]
    df["restitution"], df["contact_friction"] = res.restitution[hit], res.contact_friction[hit]
    return df


def write_rows(base: pd.DataFrame, n: int, out: Path) -> None:
    """``n`` rows of ``base`` repeated, written block by block (Parquet or CSV)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    block = pd.concat([base] * (65536 // len(base) + 1), ignore_index=True).iloc[:65536]
    writer = None
    done = 0
    while done < n:
        k = min(len(block), n - done)
        part = block.iloc[:k].copy()
        part["case_id"] = np.arange(done, done + k)
        if out.suffix == ".csv":
            part.to_csv(out, index=False, header=done == 0, mode="w" if done == 0 else "a")
        else:
            table = pa.Table.from_pandas(part, preserve_index=False)
            writer = writer or pq.ParquetWriter(out, table.schema)
            writer.write_table(table)
        done += k
    if writer is not None:
        writer.close()


def measure(tree: Path, src: Path, dst: Path) -> dict[str, float]:
    """Peak RSS [MB], CPU [s] and wall [s] of ``vfs impact`` run from ``tree``."""
    proc = subprocess.run(["/usr/bin/time", "-v", sys.executable, "-m", "vfs", "impact",
                           "--input", str(src), "--output", str(dst)], cwd=tree,
                          capture_output=True, text=True, check=True)
    return parse_time(proc.stderr)


def parse_time(text: str) -> dict[str, float]:
    """The figures of ``/usr/bin/time -v`` output."""
    def num(label: str) -> float:
        return float(re.search(rf"{label}: ([\d.:]+)", text).group(1).split(":")[-1])

    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", text)
    parts = [float(p) for p in wall.group(1).split(":")] if wall else [0.0]
    seconds = sum(p * 60 ** k for k, p in enumerate(reversed(parts)))
    return {"peak_mb": num(r"Maximum resident set size \(kbytes\)") / 1024,
            "cpu_s": num(r"User time \(seconds\)") + num(r"System time \(seconds\)"),
            "wall_s": seconds}


def main() -> int:
    """Generate, measure, append the row."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=float, default=1e6)
    parser.add_argument("--format", choices=("parquet", "csv"), default="parquet")
    parser.add_argument("--tree", type=Path, default=ROOT, help="checkout whose vfs runs")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/impact_stream.md")
    args = parser.parse_args()
    n = int(args.rows)
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / f"in.{args.format}"
        write_rows(realistic_impacts(), n, src)
        got = measure(args.tree, src, Path(tmp) / f"out.{args.format}")
    row = (f"| {n:,} | {args.format} | {args.tree} | {got['peak_mb']:.0f} | "
           f"{got['cpu_s']:.1f} | {got['wall_s']:.1f} |\n")
    if not args.out.exists():
        args.out.write_text("| rows | format | tree | peak RSS MB | CPU s | wall s |\n"
                            "|---|---|---|---|---|---|\n")
    with open(args.out, "a") as fh:
        fh.write(row)
    print(row, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
