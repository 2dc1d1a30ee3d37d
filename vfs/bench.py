"""``vfs bench``: throughput measurements (never asserted in tests).

Each benchmark is a function registered in :data:`BENCHMARKS` that returns a
dict of named figures.  Times are the best of several repetitions of the same
batch (the usual way to suppress scheduling noise); the numpy kernels run on
one core (no threaded BLAS in these paths).
"""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np

Benchmark = Callable[[bool], dict[str, Any]]

#: Registry: benchmark name -> function(quick) -> figures.
BENCHMARKS: dict[str, Benchmark] = {}


def register_benchmark(name: str) -> Callable[[Benchmark], Benchmark]:
    """Decorator adding a benchmark to :data:`BENCHMARKS`."""

    def wrap(fn: Benchmark) -> Benchmark:
        BENCHMARKS[name] = fn
        return fn

    return wrap


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


def random_outline_pairs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """N random car-sized outline pairs in a 6 x 6 m square (about 60 % overlap)."""
    from vfs.geometry import outline_corners

    x = rng.uniform(-3, 3, (n, 2))
    y = rng.uniform(-3, 3, (n, 2))
    yaw = rng.uniform(-np.pi, np.pi, (n, 2))
    length = rng.uniform(3.5, 5.5, (n, 2))
    width = rng.uniform(1.5, 2.1, (n, 2))
    front = length * rng.uniform(0.45, 0.6, (n, 2))
    o1 = outline_corners(x[:, 0], y[:, 0], yaw[:, 0], front[:, 0], length[:, 0] - front[:, 0],
                         width[:, 0])
    o2 = outline_corners(x[:, 1], y[:, 1], yaw[:, 1], front[:, 1], length[:, 1] - front[:, 1],
                         width[:, 1])
    return o1, o2


def random_impact_configs(rng: np.random.Generator, n: int) -> Any:
    """N random but car-like impact configurations."""
    from vfs.impact import ImpactConfig

    m = rng.uniform(800, 2600, (2, n))
    return ImpactConfig.from_arrays(
        m1=m[0], izz1=m[0] * rng.uniform(1.5, 2.2, n), x1=rng.uniform(-2, 0, n),
        y1=rng.uniform(-1, 1, n), yaw1=rng.uniform(-np.pi, np.pi, n),
        vx1=rng.uniform(-30, 30, n), vy1=rng.uniform(-30, 30, n),
        yaw_rate1=rng.uniform(-0.5, 0.5, n), m2=m[1], izz2=m[1] * rng.uniform(1.5, 2.2, n),
        x2=rng.uniform(0, 2, n), y2=rng.uniform(-1, 1, n), yaw2=rng.uniform(-np.pi, np.pi, n),
        vx2=rng.uniform(-30, 30, n), vy2=rng.uniform(-30, 30, n),
        yaw_rate2=rng.uniform(-0.5, 0.5, n), poi_x=rng.uniform(-1, 1, n),
        poi_y=rng.uniform(-1, 1, n), cp_angle=rng.uniform(0, np.pi, n),
        restitution=rng.uniform(0.05, 0.3, n), contact_friction=rng.uniform(0.2, 0.8, n),
    )


@register_benchmark("impact")
def bench_impact(quick: bool) -> dict[str, Any]:
    """Impacts solved per second for one batch of N = 1e5 (2e4 with --quick)."""
    from vfs.impact import solve_impact

    n = 20_000 if quick else 100_000
    config = random_impact_configs(np.random.default_rng(0), n)
    t = best_time(lambda: solve_impact(config), 3 if quick else 7)
    return {"batch": n, "seconds": t, "impacts_per_s": n / t}


@register_benchmark("overlap")
def bench_overlap(quick: bool) -> dict[str, Any]:
    """Overlap polygon + area + centroid per second: our Sutherland-Hodgman vs shapely."""
    import shapely

    from vfs.geometry import overlap

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
    return {
        "batch": n,
        "ours_polygons_per_s": n / ours,
        "shapely_polygons_per_s": n / theirs,
        "speedup_vs_shapely": theirs / ours,
        "max_area_difference_m2": area_error,
    }


def synthetic_case_batch(n: int, rng: np.random.Generator, duration: float = 5.0,
                         dt: float = 0.01) -> Any:
    """N varied frontal/oblique cases with 10 ms records of ``duration`` s before contact.

    Vehicle 1 drives along a gentle arc or a straight line, vehicle 2 comes
    from the front at an angle of up to 30 deg with a lateral offset, so the
    batch mixes full and sliding impacts.  Built with array operations (no
    per-case loop); for benchmarks and tests.
    """
    from vfs.paths import concat_paths, pack_paths
    from vfs.simulation import CaseBatch
    from vfs.vehicle import vehicle_arrays

    t = np.arange(0.0, duration + 0.5 + 1e-9, dt)
    m = t.size

    def fleet() -> Any:
        mass = rng.uniform(900, 2300, n)
        length = 3.6 + (mass - 900) / 1400 * 1.4
        wheelbase = 0.6 * length
        return vehicle_arrays(mass=mass, length=length, width=1.65 + 0.15 * (mass - 900) / 1400,
                              wheelbase=wheelbase, cg_to_front_axle=0.45 * wheelbase,
                              front_overhang=0.2 * length, track_width=1.5,
                              cg_height=0.55)

    v1, v2 = fleet(), fleet()
    speed1 = rng.uniform(8, 28, n)
    speed2 = rng.uniform(8, 28, n)
    curvature = rng.choice([0.0, 1.0], n) * rng.uniform(-1 / 300, 1 / 300, n)
    angle = np.radians(rng.uniform(-30, 30, n))
    offset = rng.uniform(-1.2, 1.2, n)
    tau = t[None, :] - duration  # 0 at the planned contact
    s1 = speed1[:, None] * tau
    arc = curvature[:, None] * s1
    safe = np.where(np.abs(curvature) < 1e-9, 1.0, curvature)[:, None]
    straight = (np.abs(curvature) < 1e-9)[:, None]
    x1 = np.where(straight, s1, np.sin(arc) / safe)
    y1 = np.where(straight, 0.0, (1 - np.cos(arc)) / safe)
    yaw2 = np.pi + angle
    reach = v1.cg_to_front + v2.cg_to_front
    x2c = reach * np.cos(angle) * 0.5 + 0.5 * reach
    x2 = x2c[:, None] + speed2[:, None] * np.cos(yaw2)[:, None] * tau
    y2 = offset[:, None] + speed2[:, None] * np.sin(yaw2)[:, None] * tau
    group = np.repeat(np.arange(n), m)

    def pack(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, speed: np.ndarray) -> Any:
        return pack_paths(np.tile(t, n), x.ravel(), y.ravel(), yaw.ravel(),
                          np.repeat(speed, m), group)

    p1 = pack(x1, y1, np.broadcast_to(arc, (n, m)), speed1)
    p2 = pack(x2, y2, np.broadcast_to(yaw2[:, None], (n, m)), speed2)
    nan = np.full(n, np.nan)
    return CaseBatch(np.arange(n), v1, v2, concat_paths(p1, p2),
                     rng.uniform(0.5, 0.95, n), nan, nan.copy())


@register_benchmark("case_runs")
def bench_case_runs(quick: bool) -> dict[str, Any]:
    """Full case-runs per second: 5 s pre-crash (half the cases braking) + impact + run-out."""
    from vfs.precrash import ScheduledBraking
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


@register_benchmark("generate")
def bench_generate(quick: bool) -> dict[str, Any]:
    """Synthetic database generation (scenes + truth simulation + noise), cases per second."""
    from scenarios.generator import generate_database

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


@register_benchmark("timestep_convergence")
def bench_timestep_convergence(quick: bool) -> dict[str, Any]:
    """Change of rest positions when both time steps (pre-crash, run-out) are halved."""
    from dataclasses import replace

    from vfs.precrash import ScheduledBraking
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
        np.hypot(a.runout.result1.rest_x - b.runout.result1.rest_x,
                 a.runout.result1.rest_y - b.runout.result1.rest_y)[both],
        np.hypot(a.runout.result2.rest_x - b.runout.result2.rest_x,
                 a.runout.result2.rest_y - b.runout.result2.rest_y)[both],
    ])
    dv = np.abs(a.impact.delta_v1 - b.impact.delta_v1)[both]
    return {
        "cases": n, "collided_in_both": int(both.sum()),
        "collision_outcome_changed": int((a.precrash.collided != b.precrash.collided).sum()),
        "dt_s": f"{base.precrash.dt}/{base.runout.dt} -> {fine.precrash.dt}/{fine.runout.dt}",
        "rest_position_change_max_m": float(change.max()) if change.size else 0.0,
        "rest_position_change_p99_m": float(np.percentile(change, 99)) if change.size else 0.0,
        "delta_v1_change_max_m_s": float(dv.max()) if dv.size else 0.0,
    }


#: Modules that register further benchmarks when imported (skipped when absent).
BENCHMARK_MODULES: tuple[str, ...] = ("vfs.uncertainty", "adas.gym_env")


def _load_benchmark_modules() -> None:
    import importlib

    for module in BENCHMARK_MODULES:
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise


def run_benchmarks(names: list[str] | None = None, quick: bool = False) -> dict[str, Any]:
    """Run the named benchmarks (all when None) and return their figures."""
    _load_benchmark_modules()
    selected = list(BENCHMARKS) if not names else names
    unknown = [n for n in selected if n not in BENCHMARKS]
    if unknown:
        from vfs.errors import ParameterError

        raise ParameterError(f"unknown benchmark(s) {unknown}; known: {sorted(BENCHMARKS)}")
    results: dict[str, Any] = {
        "machine": {"python": platform.python_version(), "numpy": np.__version__,
                    "cpus": os.cpu_count(), "platform": platform.platform()},
        "quick": quick,
    }
    for name in selected:
        results[name] = BENCHMARKS[name](quick)
    return results


def format_results(results: dict[str, Any]) -> str:
    """Human-readable table of benchmark figures."""
    lines = []
    for name, figures in results.items():
        if name in ("machine", "quick"):
            continue
        lines.append(f"{name}:")
        for key, value in figures.items():
            if isinstance(value, float):
                text = f"{value:,.3g}" if abs(value) < 1e3 else f"{value:,.0f}"
            else:
                text = str(value)
            lines.append(f"  {key:<34} {text}")
    return "\n".join(lines)


def write_json(results: dict[str, Any], path: str) -> None:
    """Write the figures as JSON."""
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(results, fh, indent=2, default=float)
