"""Steps per vehicle in the Monte-Carlo run-outs of `vfs bench uncertainty` (200 cases x
1,000 samples), the distinct rows of the run-out batches and the CPU time per vehicle-step of
the compiled run-out; output: benchmarks/results/core_37_runmc_steps.txt.
Run from the repository root: ``python benchmarks/core_37_runmc_steps.py``.
"""
import time

import numpy as np

import vfs.physics.core_runout as cr
import vfs.physics.runout as ro
from vfs.database import open_database
from vfs.uncertainty import CaseSet, default_config, run_uncertainty

rec = []
orig = cr.run_to_rest


def wrapped(par, state, consts, max_steps, per_sample, lt, record, pairs):
    """The run-out kernel's entry, recording each batch's steps and CPU time."""
    c0 = time.process_time()
    t0 = time.perf_counter()
    out = orig(par, state, consts, max_steps, per_sample, lt, record, pairs)
    rec.append((par.shape[0], out.steps.copy(), out.moving.copy(), consts[0], max_steps,
                time.process_time() - c0, time.perf_counter() - t0, lt, par[:, cr._STEER].copy()))
    return out


cr.run_to_rest = wrapped
nd = []
orig_d = ro.distinct_rows


def dwrap(t):
    """distinct_rows, recording rows and distinct rows of each batch."""
    f, inv = orig_d(t)
    nd.append((t.shape[0], f.size))
    return f, inv


ro.distinct_rows = dwrap
db = open_database("default")
cases = CaseSet.from_database(db).take(slice(0, 200))
cfg = default_config()
run_uncertainty(cases.take(slice(0, 2)), cfg, n_samples=4, seed=1)
rec.clear()
nd.clear()
c0 = time.process_time()
run_uncertainty(cases, cfg, n_samples=1000, seed=1)
print("total cpu", time.process_time() - c0)
steps = np.concatenate([r[1] for r in rec])
mov = np.concatenate([r[2] for r in rec])
print("calls", len(rec), "vehicles", steps.size, "dt", rec[0][3], "max_steps", rec[0][4],
      "load_transfer", rec[0][7])
print("distinct rows (rows, distinct):", nd)
print("steps: sum", steps.sum(), "mean", steps.mean(), "pcts 0/10/50/90/99/100",
      np.percentile(steps, [0, 10, 50, 90, 99, 100]))
print("zero-step vehicles", (steps == 0).sum(), "at time limit", mov.sum())
cpu = sum(r[5] for r in rec)
wall = sum(r[6] for r in rec)
print("run_to_rest cpu", cpu, "wall", wall, "ns/vehicle-step", 1e9 * cpu / steps.sum())
st = np.concatenate([r[8] for r in rec])
print("steered vehicles", (st != 0).sum())
print("hist", np.histogram(steps, bins=[0,1,10,50,100,150,200,300,500,1000,1501])[0])
