"""Experiment (now the product path: ``VFS_THREADS``, vfs.threads): the compiled run-out
loop of the Monte-Carlo batches with numba threads (``parallel=True``, ``prange`` over
vehicles) against the one-thread kernel, on the run-out batches of `vfs bench uncertainty`
(200 cases x 1,000 samples): CPU and wall time of both and whether every output is bit-identical.
Run from the repository root: ``python benchmarks/core_37_runmc_threads.py``;
output: benchmarks/results/core_37_runmc_threads.txt.
"""
import os
import time

import numba
import numpy as np

import vfs.physics.core_runout as cr
from vfs.database import open_database
from vfs.uncertainty import CaseSet, default_config, run_uncertainty

batches = []
orig = cr.run_to_rest


def keep(par, state, consts, max_steps, per_sample, lt, record, pairs):
    """The run-out kernel's entry, keeping a copy of each batch."""
    batches.append((par.copy(), tuple(a.copy() for a in state), consts, max_steps,
                    per_sample, lt, record, pairs))
    return orig(par, state, consts, max_steps, per_sample, lt, record, pairs)


cr.run_to_rest = keep
cases = CaseSet.from_database(open_database("default")).take(slice(0, 200))
run_uncertainty(cases, default_config(), n_samples=1000, seed=1)
cr.run_to_rest = orig
serial = cr._compiled(False, False)


def run(kernel, b):
    """Run one kept batch with ``kernel``; its state and outputs."""
    par, state, consts, max_steps, per_sample, lt, record, pairs = b
    n = par.shape[0]
    st = np.zeros((n, cr._NST))
    for f, a in zip((cr._X, cr._Y, cr._YAW, cr._VX, cr._VY, cr._R), state,
                    strict=True):
        st[:, f] = a
    st[:, cr._VX_PREV:cr._R_PREV + 1] = st[:, cr._VX:cr._R + 1]
    out = (np.zeros(n, np.int64), np.zeros(n, np.bool_), np.zeros(n, np.int64),
           np.full((n, 2, 3), np.nan), np.full((n, 2), np.nan))
    kernel(par, st, np.asarray(consts, float), max_steps, per_sample, lt, *out)
    return (st,) + out


threaded = cr._compiled(False, True)
numba.set_num_threads(2)
run(threaded, batches[-1])  # compile
for name, kernel in (("one thread", serial), (f"{numba.get_num_threads()} threads", threaded)):
    c0, t0 = time.process_time(), time.perf_counter()
    outs = [run(kernel, b) for b in batches]
    print(f"{name}: CPU {time.process_time() - c0:.2f} s, wall {time.perf_counter() - t0:.2f} s")
    if name == "one thread":
        ref = outs
same = all(np.array_equal(a, b, equal_nan=True) for o, r in zip(outs, ref, strict=True)
           for a, b in zip(o, r, strict=True))
print("bit-identical to one thread:", same)
print(f"batches {len(batches)}, vehicles {sum(b[0].shape[0] for b in batches)}; "
      f"load average {os.getloadavg()[0]:.2f} on 2 cores shared with other jobs")
