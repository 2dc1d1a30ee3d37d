r"""Peak memory of a study on a local dask cluster as the number of cases grows.

For each N of ``--cases`` the benchmark

1. builds a Parquet database of N cases by replicating the bundled 600-case
   database with new case ids (the physics is the same for every
   copy, which is all a memory benchmark needs);
2. runs ``run_study(db, systems, out, engine="dask", workers=W,
   dask_processes=True)`` in a fresh Python process, while a thread samples
   every 0.5 s the resident memory (``VmRSS``) of that process (the client)
   and of every process below it (the dask nanny and worker processes), and
   their high-water marks (``VmHWM`` of ``/proc/PID/status``);
3. writes one JSON line per N: client peak while the chunks run, client peak
   over the whole study (the final combination into ``runs.parquet`` and
   ``result.table`` hold the runs table, which is the study's output), peak of
   each worker process, wall time, cases per second.

Linux only (reads ``/proc``).  On a shared machine run it with ``nice``::

    nice -n 10 python benchmarks/cluster_memory.py --cases 2000,20000,100000 \
        --workers 2 --out /tmp/vfs-cluster-memory

The time steps are coarse (``--dt``; memory does not depend on them, run time
does) unless ``--dt 0.01`` is given.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

REPLICA_OFFSET = 1_000_000  # case ids of copy r: original + r * REPLICA_OFFSET


def build_database(n_cases: int, folder: Path) -> Path:
    """A Parquet database of ``n_cases`` cases: copies of the bundled one with new ids."""
    import numpy as np
    import pandas as pd

    from vfs.database import Database, open_database, save_database

    if (folder / "cases.parquet").exists():
        return folder
    base = open_database("default")
    copies = -(-n_cases // base.n_cases)
    tables = {}
    for name, df in base.tables().items():
        parts = [df.assign(case_id=df["case_id"] + r * REPLICA_OFFSET) for r in range(copies)]
        tables[name] = pd.concat(parts, ignore_index=True)
    keep = tables["cases"]["case_id"].to_numpy()[:n_cases]
    tables = {name: df[np.isin(df["case_id"].to_numpy(), keep)].reset_index(drop=True)
              for name, df in tables.items()}
    meta = {**base.meta, "name": f"default x{copies} ({n_cases} cases)"}
    save_database(Database(**tables, meta=meta), folder, validate=False)
    return folder


def _children(pid: int) -> set[int]:
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int(
                    (entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier} - found
        found |= frontier
    return found


def _status_kb(pid: int) -> dict[str, int]:
    out = {}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(value.split()[0])
    except OSError:
        pass
    return out


class Sampler(threading.Thread):
    """Samples the RSS of this process and its descendants every ``interval`` seconds."""

    def __init__(self, interval: float = 0.5) -> None:
        super().__init__(daemon=True)
        self.interval = interval
        self.stop = threading.Event()
        self.client_rss_kb = 0
        self.phase_peak_kb: dict[str, int] = {}
        self.phase = "start"
        self.workers: dict[int, dict[str, object]] = {}

    def run(self) -> None:
        """Sample until ``stop`` is set."""
        me = os.getpid()
        while not self.stop.is_set():
            rss = _status_kb(me).get("VmRSS", 0)
            self.phase_peak_kb[self.phase] = max(self.phase_peak_kb.get(self.phase, 0), rss)
            for pid in _children(me):
                status = _status_kb(pid)
                if not status:
                    continue
                rec = self.workers.setdefault(pid, {"peak_rss_kb": 0, "hwm_kb": 0})
                try:
                    cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
                    rec["cmd"] = cmd.decode(errors="replace")[:120]
                except OSError:
                    pass
                rec["peak_rss_kb"] = max(int(rec["peak_rss_kb"]), status.get("VmRSS", 0))
                rec["hwm_kb"] = max(int(rec["hwm_kb"]), status.get("VmHWM", 0))
            self.stop.wait(self.interval)


def run_one(db: Path, out: Path, workers: int, systems: list[str], dt: float,
            chunk_size: int) -> dict[str, object]:
    """One study in this process, with memory sampling (the ``--run`` mode)."""
    import resource

    from vfs.physics.precrash import PrecrashParams
    from vfs.physics.runout import RunoutParams
    from vfs.simulation import SimulationParams
    from vfs.study import run_study

    sampler = Sampler()
    sampler.start()
    params = SimulationParams(precrash=PrecrashParams(dt=dt, contact_tolerance=min(dt, 0.001)),
                              runout=RunoutParams(dt=0.025) if dt > 0.01 else RunoutParams())
    chunks_seen = [0]

    def on_chunk(chunk: int, done: int) -> None:
        sampler.phase = "chunks"
        chunks_seen[0] += 1

    started = time.perf_counter()
    result = run_study(db, systems, out, engine="dask", workers=workers, dask_processes=True,
                       chunk_size=chunk_size, params=params, overwrite=True, progress=False,
                       on_chunk=on_chunk)
    elapsed = time.perf_counter() - started
    sampler.phase = "end"
    time.sleep(1.0)
    sampler.stop.set()
    sampler.join()
    n = int(result.manifest["n_cases"])
    below = {pid: rec for pid, rec in sampler.workers.items() if int(rec["hwm_kb"]) > 0}
    return {
        "cases": n, "chunks": chunks_seen[0],
        "status": result.manifest["status"], "workers": workers, "systems": systems,
        "elapsed_s": round(elapsed, 1), "cases_per_s": round(n / elapsed, 1),
        "client_peak_while_running_mb": round(sampler.phase_peak_kb.get("chunks", 0) / 1024),
        "client_peak_total_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "processes_below_client": {str(pid): {"peak_rss_mb": round(int(r["peak_rss_kb"]) / 1024),
                                              "hwm_mb": round(int(r["hwm_kb"]) / 1024),
                                              "cmd": r.get("cmd", "")}
                                   for pid, r in sorted(below.items())},
        "runs_parquet_mb": round((out / "runs.parquet").stat().st_size / 2**20, 1)
        if (out / "runs.parquet").exists() else None,
    }


def main(argv: list[str] | None = None) -> int:
    """Build the databases, run one study per size in a child process, print JSON lines."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", default="2000,20000", help="comma-separated numbers of cases")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--systems", default="three-stage")
    p.add_argument("--chunk-size", type=int, default=200)
    p.add_argument("--dt", type=float, default=0.02, help="pre-crash time step [s]")
    p.add_argument("--out", type=Path, default=Path("/tmp/vfs-cluster-memory"))
    p.add_argument("--run", type=Path, metavar="DB", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    systems = [s for s in args.systems.split(",") if s]
    if args.run is not None:  # child: one study, result as JSON on stdout
        record = run_one(args.run, args.out, args.workers, systems, args.dt, args.chunk_size)
        print(json.dumps(record))
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    results = args.out / "results.jsonl"
    for n in [int(x) for x in args.cases.split(",") if x]:
        started = time.perf_counter()
        db = build_database(n, args.out / f"db_{n}")
        print(f"{n} cases: database in {time.perf_counter() - started:.0f} s", file=sys.stderr)
        child = subprocess.run(
            [sys.executable, __file__, "--run", str(db), "--out", str(args.out / f"study_{n}"),
             "--workers", str(args.workers), "--systems", args.systems,
             "--chunk-size", str(args.chunk_size), "--dt", str(args.dt)],
            capture_output=True, text=True, check=False)
        if child.returncode != 0:
            print(child.stderr, file=sys.stderr)
            return child.returncode
        line = child.stdout.strip().splitlines()[-1]
        with results.open("a") as fh:
            fh.write(line + "\n")
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
