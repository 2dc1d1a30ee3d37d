"""Paired differences between two AEB systems of one study, with intervals.

Two systems of a study ran on the same cases, so the question "how much more does B avoid than
A?" is answered case by case: on the cases that crash in the baseline, the per-case difference
B - A of an outcome (avoided: 0/1; impact speed and delta-v with the system, 0 where avoided),
weighted by the cases' frequency weights, with a BCa bootstrap interval over the cases
resampled jointly (the pairing kept; :func:`vfs.analysis.stats.bootstrap_ci`).  Comparing the
two systems' intervals against the baseline instead would ignore that they share their cases
and give intervals that are too wide.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations

import numpy as np
import pandas as pd

from vfs.analysis.effectiveness import Effectiveness, PairedRuns
from vfs.analysis.stats import bootstrap_ci
from vfs.units import KMH_PER_MS

#: Compared outcome -> (label, unit shown, per-case value of a paired run).
OUTCOMES: dict[str, tuple[str, str]] = {
    "avoided_share": ("avoided share of the baseline crashes", "%"),
    "impact_speed": ("mean impact speed per baseline crash", "km/h"),
    "delta_v": ("mean delta-v per baseline crash (larger of the two vehicles)", "km/h"),
}


def _per_case(pair: PairedRuns, outcome: str) -> np.ndarray:
    """The per-case value of ``outcome`` with the system (display units: % or km/h)."""
    if outcome == "avoided_share":
        return 100.0 * (~pair.crash_treat.astype(bool)).astype(float)
    if outcome == "impact_speed":
        return pair.speed_treat * KMH_PER_MS
    return np.max(pair.delta_v_treat, axis=1) * KMH_PER_MS


def _aligned(a: PairedRuns, b: PairedRuns) -> tuple[np.ndarray, np.ndarray]:
    """Positions in ``a`` and ``b`` of their common cases (by case id)."""
    common, ia, ib = np.intersect1d(a.case_id, b.case_id, return_indices=True)
    return ia, ib


def system_differences(eff: Effectiveness, *, pairs: Sequence[tuple[str, str]] | None = None,
                       n_boot: int | None = None, confidence: float | None = None,
                       seed: int | None = None) -> pd.DataFrame:
    """Paired differences B - A between the systems of a study.

    Parameters
    ----------
    eff : Effectiveness
        The study's effectiveness (:func:`vfs.analysis.effectiveness.effectiveness`).
    pairs : sequence of (str, str), optional
        (A, B) system pairs; default every pair in the study's order.
    n_boot, confidence, seed : optional
        Bootstrap settings; default those of ``eff``.

    Returns
    -------
    DataFrame
        One row per pair and outcome: ``system_a``, ``system_b``, ``outcome``, ``label``,
        ``unit`` (% or km/h), ``value_a``, ``value_b``, ``difference`` (B - A), ``low``,
        ``high`` (BCa bootstrap over the baseline crashes), ``n_cases`` (baseline crashes
        both systems ran).
    """
    by_name = {p.system: p for p in eff.pairs}
    if pairs is None:
        pairs = list(combinations([p.system for p in eff.pairs], 2))
    n_boot = eff.n_boot if n_boot is None else n_boot
    confidence = eff.confidence if confidence is None else confidence
    rng = np.random.default_rng(eff.seed if seed is None else seed)
    rows = []
    for name_a, name_b in pairs:
        a, b = by_name[name_a], by_name[name_b]
        ia, ib = _aligned(a, b)
        crash = a.crash_base[ia].astype(bool) & b.crash_base[ib].astype(bool)
        ia, ib = ia[crash], ib[crash]
        w = a.weight[ia].astype(float)
        for outcome, (label, unit) in OUTCOMES.items():
            va, vb = _per_case(a, outcome)[ia], _per_case(b, outcome)[ib]
            row = {"system_a": name_a, "system_b": name_b, "outcome": outcome, "label": label,
                   "unit": unit, "n_cases": int(len(ia))}
            if len(ia) < 2 or w.sum() <= 0:
                rows.append({**row, "value_a": np.nan, "value_b": np.nan,
                             "difference": np.nan, "low": np.nan, "high": np.nan})
                continue
            d = vb - va
            if np.ptp(d) == 0.0:  # no case differs: the interval is the point
                est = low = high = float(d[0])
            else:
                est, low, high = bootstrap_ci(np.average, d, n_boot=n_boot,
                                              confidence=confidence, rng=rng, weights=w,
                                              method="bca")
            rows.append({**row, "value_a": float(np.average(va, weights=w)),
                         "value_b": float(np.average(vb, weights=w)),
                         "difference": float(est), "low": float(low), "high": float(high)})
    return pd.DataFrame(rows, columns=["system_a", "system_b", "outcome", "label", "unit",
                                       "value_a", "value_b", "difference", "low", "high",
                                       "n_cases"])


__all__ = ["OUTCOMES", "system_differences"]
