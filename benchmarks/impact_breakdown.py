"""Where the time of ``vfs bench impact`` goes: the compiled impact kernel's parts.

Times (best wall time of 15 calls, one process, one batch of 100,000 random impacts as in
``vfs bench impact``) of :func:`vfs.physics.impact.solve_impact` and of its three parts:
the per-impact kernel (``_solve_all`` of :mod:`vfs.physics.core_impact`), numpy's
``arctan2`` of the four angles per impact, and the finishing kernel (``_finish``: PDOF
wrap and clock); and what writing the result's arrays costs when they are fresh (as
every call allocates them) against arrays written before (the first write to fresh
memory page-faults).  Prints JSON; the record is benchmarks/results/core_37_impact_breakdown.json.

Usage: python benchmarks/impact_breakdown.py > benchmarks/results/core_37_impact_breakdown.json
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable

import numpy as np

from vfs.bench.kernels import random_impact_configs
from vfs.physics import core_impact
from vfs.physics.impact import solve_impact


def best(f: Callable[[], object], repeats: int = 15) -> float:
    """Best wall time [s] of ``repeats`` calls of ``f``."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        out.append(time.perf_counter() - t0)
    return min(out)


def main() -> None:
    """Time the parts and print them as JSON (seconds per batch)."""
    n = 100_000
    c = random_impact_configs(np.random.default_rng(0), n)
    solve_impact(c)  # compiled or loaded from the cache
    # the kernels themselves (a measuring script may reach into the module)
    solve, finish = core_impact._compiled()
    two, one = (n, 2), (n,)
    col = core_impact._column
    args = (col(c.m, n, two), col(c.izz, n, two), col(c.x, n, two), col(c.y, n, two),
            col(c.yaw, n, two), col(c.vx, n, two), col(c.vy, n, two),
            col(c.yaw_rate, n, two), col(c.poi_x, n, one), col(c.poi_y, n, one),
            col(c.cp_angle, n, one), col(c.restitution, n, one),
            col(c.contact_friction, n, one), np.full(n, np.nan), False)
    real, pair = np.empty((9, n)), np.empty((9, n, 2))
    itype, clocks = np.empty(n, dtype=np.int64), np.empty((n, 2), dtype=np.int64)
    ay, ax = np.empty((n, 4)), np.empty((n, 4))
    total = best(lambda: solve_impact(c))
    kernel = best(lambda: solve(*args, real, pair, itype, ay, ax))
    angles = np.arctan2(ay, ax)
    atan = best(lambda: np.arctan2(ay, ax))
    fin = best(lambda: finish(angles, args[4], itype, pair, clocks))

    def fresh() -> None:
        # the result's arrays as solve_compiled allocates them, written once (the
        # operating system maps and zero-fills fresh pages at the first write)
        for a in (np.empty((9, n)), np.empty((9, n, 2)), np.empty(n, dtype=np.int64),
                  np.empty((n, 2), dtype=np.int64), np.empty((n, 4)), np.empty((n, 4))):
            a.fill(0)

    def reused() -> None:
        for a in (real, pair, itype, clocks, ay, ax):
            a.fill(0)

    fresh_s, reused_s = best(fresh), best(reused)
    print(json.dumps({
        "batch": n, "total_s": total, "impacts_per_s": n / total,
        "kernel_s": kernel, "kernel_ns_per_impact": 1e9 * kernel / n,
        "arctan2_s": atan, "finish_s": fin,
        "rest_s": total - kernel - atan - fin,
        "fresh_result_arrays_s": fresh_s, "reused_arrays_write_s": reused_s,
        "first_touch_s": fresh_s - reused_s,
        "load_average_1min": os.getloadavg()[0],
    }, indent=1))


if __name__ == "__main__":
    main()
