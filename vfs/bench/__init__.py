"""``vfs bench``: throughput measurements (never asserted in tests).

Each benchmark is a function ``bench(quick) -> dict`` of named figures,
registered by name in :data:`BENCHMARKS` below (explicitly: importing a
library module never adds a benchmark).  The benchmark modules import what
they measure inside the functions, so listing the benchmarks stays cheap.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Callable
from typing import Any

import numpy as np

from vfs.bench import gym, kernels, study, uncertainty
from vfs.registry import Registry

Benchmark = Callable[[bool], dict[str, Any]]

#: Benchmarks by name, in the order ``vfs bench`` runs them.
BENCHMARKS: Registry[Benchmark] = Registry("benchmark")
BENCHMARKS.add("impact", kernels.bench_impact)
BENCHMARKS.add("overlap", kernels.bench_overlap)
BENCHMARKS.add("case_runs", kernels.bench_case_runs)
BENCHMARKS.add("replay", kernels.bench_replay)
BENCHMARKS.add("runout", kernels.bench_runout)
BENCHMARKS.add("generate", kernels.bench_generate)
BENCHMARKS.add("timestep_convergence", kernels.bench_timestep_convergence)
BENCHMARKS.add("uncertainty", uncertainty.bench_uncertainty)
BENCHMARKS.add("uncertainty_sampling", uncertainty.bench_uncertainty_sampling)
BENCHMARKS.add("gym_env", gym.bench_gym_env)
BENCHMARKS.add("study", study.bench_study)
BENCHMARKS.add("warmup", study.bench_warmup)
BENCHMARKS.add("diagnose", study.bench_diagnose)


def run_benchmarks(names: list[str] | None = None, quick: bool = False) -> dict[str, Any]:
    """Run the named benchmarks (all when None) and return their figures.

    Raises
    ------
    ParameterError
        For an unknown name (the message lists the known ones).
    """
    selected = list(BENCHMARKS) if not names else names
    functions = [BENCHMARKS.get(n) for n in selected]
    results: dict[str, Any] = {
        "machine": {"python": platform.python_version(), "numpy": np.__version__,
                    "cpus": os.cpu_count(), "platform": platform.platform()},
        "quick": quick,
    }
    for name, fn in zip(selected, functions, strict=True):
        results[name] = fn(quick)
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


__all__ = ["BENCHMARKS", "Benchmark", "format_results", "run_benchmarks"]
