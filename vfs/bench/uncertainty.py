"""Benchmarks of the uncertainty tools (Monte-Carlo bands and Sobol indices)."""

from __future__ import annotations

import os
import time
from typing import Any


def bench_uncertainty(quick: bool) -> dict[str, Any]:
    """Monte-Carlo throughput (1000 samples x 200 cases of the bundled database; 100 x 50
    with ``quick``) and the time of a Sobol analysis (:mod:`vfs.uncertainty.sensitivity`).
    ``uncertainty_cpu_seconds``: CPU time of the process, all threads.
    ``compute_threads``: the run-out's threads (:func:`vfs.threads.compute_threads`,
    ``VFS_THREADS``); ``load_average_1min`` at the end (the machine's other work).
    ``runout_kernel``: "compiled" where :func:`vfs.physics.numba_support.enabled` (the
    default; ``VFS_COMPILED=0``: "numpy"); a small run before the timing compiles the
    kernel (or loads numba's cache).
    """
    from vfs.database import open_database
    from vfs.uncertainty import CaseSet, default_config, run_uncertainty
    from vfs.uncertainty.sensitivity import sensitivity_analysis

    db = open_database("default")
    n_cases, n_samples = (50, 100) if quick else (200, 1000)
    cases = CaseSet.from_database(db).take(slice(0, n_cases))
    config = default_config()
    # compile the run-out kernel (or load numba's cache) outside the timing
    run_uncertainty(cases.take(slice(0, 2)), config, n_samples=4, seed=1)
    t0, c0 = time.perf_counter(), time.process_time()
    res = run_uncertainty(cases, config, n_samples=n_samples, seed=1)
    mc, mc_cpu = time.perf_counter() - t0, time.process_time() - c0
    n_base, n_sobol = (32, 10) if quick else (128, 40)
    t0 = time.perf_counter()
    sens = sensitivity_analysis(cases.take(slice(0, n_sobol)), config, n_base=n_base, seed=2,
                                n_boot=100)
    sobol = time.perf_counter() - t0
    runs = n_samples * n_cases
    from vfs.physics.numba_support import enabled
    from vfs.threads import compute_threads

    return {
        "runout_kernel": "compiled" if enabled() else "numpy",
        "compute_threads": compute_threads(),
        "load_average_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "cases": n_cases, "samples_per_case": n_samples, "model_runs": runs,
        "uncertainty_seconds": mc, "uncertainty_cpu_seconds": mc_cpu, "runs_per_s": runs / mc,
        "sobol_cases": n_sobol, "sobol_base_samples": n_base,
        "sobol_model_runs": sens.n_runs, "sobol_seconds": sobol,
        "sobol_runs_per_s": sens.n_runs / sobol,
        "median_rel_half_width_delta_v1": float(res.summary().query(
            "outcome == 'delta_v1' and group == 'all'")["median_rel_half_width"].iloc[0]),
    }


#: Ratio outcomes whose 5-95 % bands the sampling benchmark checks.
SAMPLING_OUTCOMES = ("delta_v1", "delta_v2", "ees1", "ees2", "runout_distance1")


def band_error(bands: Any, reference: Any, outcomes: tuple[str, ...] = SAMPLING_OUTCOMES
               ) -> float:
    """Mean error of the band ends relative to the reference band width [-].

    Mean over cases and outcomes of ``(|p5 - p5_ref| + |p95 - p95_ref|) / (2 (p95_ref -
    p5_ref))`` (cases with a zero-width reference band are skipped).
    """
    import numpy as np

    key = ["case_id", "outcome"]
    a = bands[bands["outcome"].isin(outcomes)].set_index(key)
    r = reference[reference["outcome"].isin(outcomes)].set_index(key).reindex(a.index)
    width = (r["p95"] - r["p5"]).to_numpy(float)
    err = (np.abs(a["p5"] - r["p5"]) + np.abs(a["p95"] - r["p95"])).to_numpy(float)
    ok = np.isfinite(err) & (width > 0)
    return float(np.mean(err[ok] / (2 * width[ok])))


def samples_needed(sizes: Any, errors: Any, target: float) -> float:
    """Samples for a mean band error ``target``: log-log interpolation of the error curve
    (NaN if the curve never reaches it; extrapolated with the last slope below the range).
    """
    import numpy as np

    s = np.log(np.asarray(sizes, float))
    e = np.log(np.asarray(errors, float))
    below = np.flatnonzero(e <= np.log(target))
    if below.size == 0:
        return float("nan")
    k = int(below[0])
    if k == 0:
        return float(np.exp(s[0]))
    slope = (e[k] - e[k - 1]) / (s[k] - s[k - 1])
    return float(np.exp(s[k - 1] + (np.log(target) - e[k - 1]) / slope))


def bench_uncertainty_sampling(quick: bool) -> dict[str, Any]:
    """Samples per case needed for a given accuracy of the 5-95 % bands: random vs QMC.

    Reference bands: plain Monte Carlo with 2^14 samples per case (2^12 with ``quick``) on the
    first 10 cases of the bundled database (5 with ``quick``).  For each sampling method and
    S = 2^5 ... 2^10 (2^8 with ``quick``) samples, ``reps`` independent seeds; the error is
    :func:`band_error` (band ends vs the reference, in units of the band width), averaged
    over the seeds.  ``samples_for_5pct`` / ``samples_for_3pct``: S at which the mean error
    falls to 5 % / 3 % of the band width (:func:`samples_needed`).
    """
    import numpy as np

    from vfs.database import open_database
    from vfs.uncertainty import CaseSet, default_config, run_uncertainty
    from vfs.uncertainty.sampling import SAMPLING_METHODS

    n_cases, ref_pow, top_pow, reps = (5, 12, 8, 3) if quick else (10, 14, 10, 6)
    cases = CaseSet.from_database(open_database("default")).take(slice(0, n_cases))
    config = default_config()
    t0 = time.perf_counter()
    ref = run_uncertainty(cases, config, n_samples=2 ** ref_pow, seed=12345,
                          sampling="random").bands
    sizes = [2 ** k for k in range(5, top_pow + 1)]
    out: dict[str, Any] = {"cases": n_cases, "reference_samples": 2 ** ref_pow,
                           "repetitions": reps, "sizes": sizes}
    for method in SAMPLING_METHODS:
        errors = []
        for s in sizes:
            e = [band_error(run_uncertainty(cases, config, n_samples=s, seed=1000 + r,
                                            sampling=method).bands, ref) for r in range(reps)]
            errors.append(float(np.mean(e)))
        out[f"{method}_band_error"] = errors
        out[f"{method}_samples_for_5pct"] = samples_needed(sizes, errors, 0.05)
        out[f"{method}_samples_for_3pct"] = samples_needed(sizes, errors, 0.03)
    out["seconds"] = time.perf_counter() - t0
    return out
