"""Benchmarks of the uncertainty tools (Monte-Carlo bands and Sobol indices)."""

from __future__ import annotations

import time
from typing import Any


def bench_uncertainty(quick: bool) -> dict[str, Any]:
    """Monte-Carlo throughput (1000 samples x 200 cases of the bundled database; 100 x 50
    with ``quick``) and the time of a Sobol analysis (:mod:`vfs.uncertainty.sensitivity`).
    """
    from vfs.database import open_database
    from vfs.uncertainty import CaseSet, default_config, run_uncertainty
    from vfs.uncertainty.sensitivity import sensitivity_analysis

    db = open_database("default")
    n_cases, n_samples = (50, 100) if quick else (200, 1000)
    cases = CaseSet.from_database(db).take(slice(0, n_cases))
    config = default_config()
    t0 = time.perf_counter()
    res = run_uncertainty(cases, config, n_samples=n_samples, seed=1)
    mc = time.perf_counter() - t0
    n_base, n_sobol = (32, 10) if quick else (128, 40)
    t0 = time.perf_counter()
    sens = sensitivity_analysis(cases.take(slice(0, n_sobol)), config, n_base=n_base, seed=2,
                                n_boot=100)
    sobol = time.perf_counter() - t0
    runs = n_samples * n_cases
    return {
        "cases": n_cases, "samples_per_case": n_samples, "model_runs": runs,
        "uncertainty_seconds": mc, "runs_per_s": runs / mc,
        "sobol_cases": n_sobol, "sobol_base_samples": n_base,
        "sobol_model_runs": sens.n_runs, "sobol_seconds": sobol,
        "sobol_runs_per_s": sens.n_runs / sobol,
        "median_rel_half_width_delta_v1": float(res.summary().query(
            "outcome == 'delta_v1' and group == 'all'")["median_rel_half_width"].iloc[0]),
    }
