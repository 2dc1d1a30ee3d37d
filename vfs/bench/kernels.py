"""Benchmarks of the physics kernels, the case chain and the generator.

Times are the best of several repetitions of the same batch (the usual way
to suppress scheduling noise); the numpy kernels run on one core (no
threaded BLAS in these paths).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from vfs.physics.numba_support import ENV_SWITCH
from vfs.scenarios.random import random_impact_configs, random_outline_pairs, synthetic_case_batch


def best_time(fn: Callable[[], object], repeats: int) -> float:
    """Best wall time [s] of ``repeats`` calls (after one warm-up call).

    The previous result is kept alive while the next call runs, as in real
    use where results are consumed; glibc's allocator adapts its mmap
    threshold to that pattern, and the figures then no longer depend on the
    allocation history of the process (which can otherwise halve them).
    """
    result = fn()
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    del result
    return float(best)


def bench_impact(quick: bool) -> dict[str, Any]:
    """Impacts solved per second for one batch of N = 1e5 (2e4 with --quick): the product
    path (the compiled kernel of :mod:`vfs.physics.core_impact`) and its numpy reference
    (``VFS_COMPILED=0``), best wall time of several calls in this one process.
    """
    from vfs.physics.impact import solve_impact

    n = 20_000 if quick else 100_000
    repeats = 3 if quick else 7
    config = random_impact_configs(np.random.default_rng(0), n)
    t = best_time(lambda: solve_impact(config), repeats)
    with compiled_switch("0"):
        t_ref = best_time(lambda: solve_impact(config), repeats)
    return {"batch": n, "seconds": t, "impacts_per_s": n / t,
            "numpy_reference_seconds": t_ref, "numpy_reference_impacts_per_s": n / t_ref,
            "load_average": os.getloadavg()[0]}


def bench_overlap(quick: bool) -> dict[str, Any]:
    """Overlap polygon + area + centroid per second: our Sutherland-Hodgman vs shapely."""
    import shapely

    from vfs.physics.geometry import overlap

    n = 20_000 if quick else 100_000
    o1, o2 = random_outline_pairs(np.random.default_rng(1), n)
    ours = best_time(lambda: overlap(o1, o2), 3 if quick else 7)
    p1, p2 = shapely.polygons(o1), shapely.polygons(o2)

    def with_shapely() -> None:
        inter = shapely.intersection(p1, p2)
        shapely.area(inter)
        shapely.centroid(inter)

    theirs = best_time(with_shapely, 2 if quick else 5)
    check = overlap(o1, o2)
    inter = shapely.intersection(p1, p2)
    area_error = float(np.max(np.abs(check.area - shapely.area(inter))))
    compiled: dict[str, Any] = {}
    from vfs.physics import compiled as ck

    if ck.AVAILABLE:
        ck.overlap_compiled(o1[:8], o2[:8])  # compile (or load the cache) outside the timing
        fast = best_time(lambda: ck.overlap_compiled(o1, o2), 3 if quick else 7)
        compiled = {"compiled_polygons_per_s": n / fast,
                    "compiled_speedup_vs_shapely": theirs / fast,
                    "compiled_max_area_difference_m2": float(np.max(np.abs(
                        ck.overlap_compiled(o1, o2).area - check.area)))}
    else:
        compiled = {"compiled_polygons_per_s": "numba not installed (pip install numba)"}
    return {
        "batch": n,
        "ours_polygons_per_s": n / ours,
        "shapely_polygons_per_s": n / theirs,
        "speedup_vs_shapely": theirs / ours,
        "max_area_difference_m2": area_error,
        **compiled,
    }


def bench_case_runs(quick: bool) -> dict[str, Any]:
    """Full case-runs per second: 5 s pre-crash (half the cases braking) + impact + run-out."""
    from vfs.physics.precrash import ScheduledBraking
    from vfs.simulation import SimulationParams, simulate_cases

    n = 1_000 if quick else 10_000
    rng = np.random.default_rng(2)
    batch = synthetic_case_batch(n, rng)
    start = np.where(rng.random(n) < 0.5, rng.uniform(3.5, 4.8, n), np.nan)
    controller = ScheduledBraking(np.c_[start, np.full(n, np.nan)],
                                  np.c_[np.full(n, 9.0), np.zeros(n)])
    params = SimulationParams()
    t0 = time.perf_counter()
    res = simulate_cases(batch, controller=controller, params=params)
    seconds = time.perf_counter() - t0
    return {
        "cases": n, "seconds": seconds, "case_runs_per_s": n / seconds,
        "collided_share": float(res.precrash.collided.mean()),
        "precrash_dt_s": params.precrash.dt, "runout_dt_s": params.runout.dt,
    }


@contextlib.contextmanager
def compiled_switch(flag: str) -> Iterator[None]:
    """``VFS_COMPILED`` set to ``flag`` ("0": the numpy references) inside the block."""
    saved = os.environ.get(ENV_SWITCH)
    os.environ[ENV_SWITCH] = flag
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop(ENV_SWITCH, None)
        else:
            os.environ[ENV_SWITCH] = saved


def _both_paths(run: Callable[[], Any], out: dict[str, Any], n: int,
                unit: str) -> dict[str, Any]:
    """CPU time of ``run`` on the numpy reference and on the compiled path (after one
    untimed call each: numba compiles or loads its cache); returns both results by path.
    """
    results = {}
    for flag, name in (("0", "numpy"), ("1", "compiled")):
        with compiled_switch(flag):
            run()
            c0 = time.process_time()
            results[name] = run()
            cpu = time.process_time() - c0
        out[f"{name}_cpu_s"] = cpu
        out[f"{name}_{unit}_per_cpu_s"] = n / cpu
    out["speed_up"] = out["numpy_cpu_s"] / out["compiled_cpu_s"]
    return results


def bench_replay(quick: bool) -> dict[str, Any]:
    """Pre-crash replays (no controller) per CPU second: the compiled per-case loop of
    :mod:`vfs.physics.core` against the numpy reference (``VFS_COMPILED=0``), on the same
    synthetic cases (2,000; 500 with --quick); ``identical``: every output equal.
    """
    from vfs.physics.precrash import simulate_precrash

    n = 500 if quick else 2_000
    batch = synthetic_case_batch(n, np.random.default_rng(5))
    out: dict[str, Any] = {"cases": n}
    results = _both_paths(lambda: simulate_precrash(batch.vehicle1, batch.vehicle2,
                                                    batch.paths, batch.road_friction),
                          out, n, "replays")
    a, b = results["numpy"], results["compiled"]
    out["identical"] = all(
        np.array_equal(np.asarray(x), np.asarray(y), equal_nan=np.asarray(x).dtype.kind == "f")
        for fa, fb in zip(a, b, strict=True)
        for x, y in (zip(fa, fb, strict=True) if isinstance(fa, tuple) else [(fa, fb)]))
    return out


def bench_runout(quick: bool) -> dict[str, Any]:
    """Run-outs to rest per CPU second, the compiled kernel (:mod:`vfs.physics.core_runout`)
    against the numpy reference (``VFS_COMPILED=0``).

    ``pairs``: the study's run-out (:func:`vfs.physics.runout.run_out_pair`, default
    parameters, secondary collisions checked, path samples kept) of the post-impact states of
    the collisions among 4,000 synthetic cases (1,000 with --quick), in batches of
    ``pair_batch``.  ``mc``: the Monte-Carlo model's run-out (:func:`~vfs.physics.runout.run_out`,
    dt 20 ms, rest poses only) of 40,000 vehicles (10,000), those states jittered.
    ``max_difference_m``: the largest difference of a rest position, ``bit_identical``: the
    share of bit-identical rest positions and headings.
    """
    from vfs.physics.runout import RunoutParams, RunoutState, run_out, run_out_pair
    from vfs.simulation import simulate_cases

    n = 1_000 if quick else 4_000
    batch = synthetic_case_batch(n, np.random.default_rng(6))
    res = simulate_cases(batch)
    hit = np.flatnonzero(res.precrash.collided)
    st, imp = res.precrash.impact_state, res.impact
    states = [RunoutState(st.x[hit, j], st.y[hit, j], st.yaw[hit, j], imp.vx_post[hit, j],
                          imp.vy_post[hit, j], imp.yaw_rate_post[hit, j]) for j in (0, 1)]
    v1, v2 = batch.vehicle1.take(hit), batch.vehicle2.take(hit)
    mu, brake = batch.road_friction[hit], res.wheel_brake[hit]
    size = 256

    def pairs() -> list[Any]:
        out = []
        for lo in range(0, hit.size, size):
            rows = np.arange(lo, min(lo + size, hit.size))
            s1, s2 = (RunoutState(*(a[rows] for a in s)) for s in states)
            out.append(run_out_pair(v1.take(rows), v2.take(rows), s1, s2, mu[rows], None,
                                    brake[rows, 0], brake[rows, 1]))
        return out

    out: dict[str, Any] = {"pairs": int(hit.size), "pair_batch": size}
    by_path = _both_paths(pairs, out, int(hit.size), "pairs")
    ref = [np.concatenate([getattr(r, f).ravel() for r in by_path["numpy"]])
           for f in ("rest_x", "rest_y", "rest_yaw")]
    got = [np.concatenate([getattr(r, f).ravel() for r in by_path["compiled"]])
           for f in ("rest_x", "rest_y", "rest_yaw")]
    steps = sum(float(np.nansum(r.time_to_rest)) for r in by_path["numpy"]) / 0.005
    for name in ("numpy", "compiled"):  # time steps of the vehicles to rest (default dt)
        out[f"{name}_ns_per_vehicle_step"] = 1e9 * out[f"{name}_cpu_s"] / steps
    out["max_difference_m"] = float(max(np.max(np.abs(a - b)) for a, b in zip(ref[:2], got[:2],
                                                                              strict=True)))
    out["bit_identical"] = float(np.mean(np.concatenate([a == b for a, b in zip(ref, got,
                                                                                strict=True)])))
    m = 10_000 if quick else 40_000
    rng = np.random.default_rng(7)
    pick = rng.integers(0, 2 * hit.size, m)
    both = [np.concatenate([a, b]) for a, b in zip(*states, strict=True)]
    jitter = [a[pick] * rng.uniform(0.9, 1.1, m) for a in both]
    cars = type(v1)(*(np.concatenate([a, b])[pick] for a, b in zip(v1, v2, strict=True)))
    params = RunoutParams(dt=0.02, path_interval=30.0)
    mc: dict[str, Any] = {"vehicles": m}
    rest = _both_paths(lambda: run_out(cars, RunoutState(*jitter), np.concatenate([mu, mu])[pick],
                                       params, np.concatenate([brake[:, 0], brake[:, 1]])[pick],
                                       paths=False), mc, m, "vehicles")["numpy"]
    steps = float(np.nansum(rest.time_to_rest)) / params.dt
    for name in ("numpy", "compiled"):
        mc[f"{name}_ns_per_vehicle_step"] = 1e9 * mc[f"{name}_cpu_s"] / steps
    out.update({f"mc_{k}": v for k, v in mc.items()})
    return out


def bench_generate(quick: bool) -> dict[str, Any]:
    """Synthetic database generation (scenes + truth simulation + noise), cases per second."""
    from vfs.scenarios.generator import generate_database

    n = 1_000 if quick else 10_000
    t0 = time.perf_counter()
    db, truth = generate_database("default", n_cases=n, seed=1)
    seconds = time.perf_counter() - t0
    return {
        "cases": n, "seconds": seconds, "cases_per_s": n / seconds,
        "trajectory_samples": len(db.trajectories),
        "reconstructions": len(db.reconstruction),
        "hidden_effects": len(truth.effects),
    }


def bench_timestep_convergence(quick: bool) -> dict[str, Any]:
    """Change of rest positions when both time steps (pre-crash, run-out) are halved."""
    from dataclasses import replace

    from vfs.physics.precrash import ScheduledBraking
    from vfs.simulation import SimulationParams, simulate_cases

    n = 300 if quick else 2_000
    rng = np.random.default_rng(7)
    batch = synthetic_case_batch(n, rng)
    # brake starts on the 10 ms grid, so both step sizes sample them alike and
    # the comparison measures the integration, not the controller's cycle
    start = np.where(rng.random(n) < 0.5, np.round(rng.uniform(3.5, 4.8, n), 2), np.nan)
    controller = ScheduledBraking(np.c_[start, np.full(n, np.nan)],
                                  np.c_[np.full(n, 9.0), np.zeros(n)])
    base = SimulationParams()
    fine = SimulationParams(
        precrash=replace(base.precrash, dt=base.precrash.dt / 2),
        runout=replace(base.runout, dt=base.runout.dt / 2,
                       path_interval=base.runout.path_interval),
    )
    a = simulate_cases(batch, controller=controller, params=base)
    b = simulate_cases(batch, controller=controller, params=fine)
    both = a.precrash.collided & b.precrash.collided
    change = np.concatenate([
        np.hypot(a.runout.rest_x[:, 0] - b.runout.rest_x[:, 0],
                 a.runout.rest_y[:, 0] - b.runout.rest_y[:, 0])[both],
        np.hypot(a.runout.rest_x[:, 1] - b.runout.rest_x[:, 1],
                 a.runout.rest_y[:, 1] - b.runout.rest_y[:, 1])[both],
    ])
    dv = np.abs(a.impact.delta_v[:, 0] - b.impact.delta_v[:, 0])[both]
    return {
        "cases": n, "collided_in_both": int(both.sum()),
        "collision_outcome_changed": int((a.precrash.collided != b.precrash.collided).sum()),
        "dt_s": f"{base.precrash.dt}/{base.runout.dt} -> {fine.precrash.dt}/{fine.runout.dt}",
        "rest_position_change_max_m": float(change.max()) if change.size else 0.0,
        "rest_position_change_p99_m": float(np.percentile(change, 99)) if change.size else 0.0,
        "delta_v1_change_max_m_s": float(dv.max()) if dv.size else 0.0,
    }
