"""The run-out's share of the full diagnosis (`vfs bench diagnose`: 600 generated cases, laws,
stepwise): vehicles, vehicle-steps and CPU time of every compiled run-out batch, with one
BLAS thread as the command line has.  Output: benchmarks/results/core_37_diagnose_steps.txt.
Run from the repository root: ``VFS_THREADS=1 python benchmarks/core_37_diagnose_steps.py``.
"""
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import vfs.physics.core_runout as core_runout
from vfs.bench.study import generated_database, run_diagnose
from vfs.blas import single_threaded_blas
from vfs.database import open_database

batches = []
original = core_runout.run_to_rest


def timed(par, state, consts, max_steps, per_sample, lt, record, pairs):
    """The run-out kernel's entry, recording each batch's steps and CPU time."""
    c0 = time.process_time()
    out = original(par, state, consts, max_steps, per_sample, lt, record, pairs)
    batches.append((out.steps.copy(), out.moving.copy(), time.process_time() - c0, max_steps))
    return out


core_runout.run_to_rest = timed


def main() -> None:
    """Run the full diagnosis once and write the run-out's figures."""
    with tempfile.TemporaryDirectory() as tmp, single_threaded_blas():
        db = open_database(str(generated_database(Path(tmp) / "db", 600)))
        c0 = time.process_time()
        run_diagnose(db, False)
        total = time.process_time() - c0
    steps = np.concatenate([b[0] for b in batches])
    moving = np.concatenate([b[1] for b in batches])
    runout = sum(b[2] for b in batches)
    p10, p50, p90, p99 = np.percentile(steps, [10, 50, 90, 99])
    lines = [
        f"# benchmarks/core_37_diagnose_steps.py: full diagnosis of 600 generated cases, CPU "
        f"time, VFS_THREADS={os.environ.get('VFS_THREADS', '(unset)')}, load average "
        f"{os.getloadavg()[0]:.2f}",
        f"diagnosis: {total:.1f} s CPU; compiled run-out: {runout:.1f} s in {len(batches)} "
        f"batches",
        f"vehicles run out: {steps.size:,}; vehicle-steps: {int(steps.sum()):,} "
        f"({1e9 * runout / steps.sum():.0f} ns each)",
        f"steps per vehicle (5 ms each): 10 % {p10:.0f}, median {p50:.0f}, 90 % {p90:.0f}, "
        f"99 % {p99:.0f}; at the time limit: {int(moving.sum()):,} vehicles",
    ]
    out = Path(__file__).resolve().parent / "results" / "core_37_diagnose_steps.txt"
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
