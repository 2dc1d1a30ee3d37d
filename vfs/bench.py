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
    """Best wall time [s] of ``repeats`` calls (after one warm-up call)."""
    fn()
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
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


def run_benchmarks(names: list[str] | None = None, quick: bool = False) -> dict[str, Any]:
    """Run the named benchmarks (all when None) and return their figures."""
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
