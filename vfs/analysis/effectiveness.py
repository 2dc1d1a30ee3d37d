"""Effectiveness of AEB systems from a study's runs: crashes avoided, speeds, injury risk.

Input: the runs table of a study (:mod:`vfs.study.layout`, ``runs.parquet``), one row
per (case, system) with ``system = "baseline"`` for the runs without a
system.  Every system is compared with the baseline *case by case* (paired),
overall and per accident type, with the cases weighted by their ``weight``
(frequency weights: a case of weight 2 counts like two identical cases).

Definitions (``docs/study.md`` has them with formulas).  For case i with
weight w_i, baseline crash indicator b_i and treatment crash indicator c_i:

* avoided share ``A = sum w b (1 - c) / sum w b`` (baseline crashes the
  system avoids); new crashes ``sum w (1 - b) c``; net crash reduction
  ``sum w (b - c) / sum w b``;
* case impact speed ``v`` = the larger impact speed of the two vehicles
  [m/s]; case delta-v ``dv`` = the larger delta-v of the two vehicles.
  Two averages: *per baseline crash* (a case without a crash counts 0 km/h,
  so avoided crashes count as 0 and new crashes are included):
  ``sum w (v_b b - v_t c) / sum w b``; and *crashes not avoided* (cases
  that crash in both runs): ``sum w b c (v_b - v_t) / sum w b c``;
* injury risk: every vehicle holds one occupant (the driver) whose risk is
  ``P(delta-v)`` of the curve (0 without a crash); a case's expected
  number of injured drivers is the *sum* over its two vehicles; expected
  injured drivers avoided = ``sum w (R_b - R_t)``.

Confidence intervals (docs/statistics.md, "Intervals at the edges"): shares of the
baseline crashes (avoided share, the impact-speed distribution) get the Wilson score
interval with Kish's effective number of cases; ratios of sums (mean speeds, relative
reductions) the BCa bootstrap; totals the percentile bootstrap.  The bootstrap resamples
cases with replacement within the group, each keeping its weight (all figures of a
(system, group) from the same resamples), drawn from
``numpy.random.default_rng([seed, system index, group index])``.  Cases with
an error in any run of the study are excluded from every comparison and
counted in the report.

:func:`effectiveness` computes everything;
:func:`vfs.report.effectiveness.write_effectiveness_report` writes
``report.md``, ``report.html``, ``metrics.csv`` and PNG figures into
``STUDY/report/``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from vfs.analysis.risk import RiskCurve, default_risk_curve, get_risk_curve
from vfs.analysis.stats import bca_interval, wilson_interval
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.units import KMH_PER_MS

BASELINE = "baseline"  # same as vfs.study.layout.BASELINE (not imported: keep this module light)

#: Injury levels of the report and their curves unless replaced
#: (:data:`vfs.analysis.risk.DEFAULT_CURVES`).
DEFAULT_RISK_LEVELS: tuple[str, ...] = ("MAIS3+", "fatal")

#: Label of the group of all cases.
ALL = "all"

#: Metrics that are shares (proportions of the baseline crashes): Wilson intervals.
SHARE_METRICS: frozenset[str] = frozenset({"avoided_share"})

#: Impact-type categories of the crosstab: no crash, the two impact types, and a
#: contact whose impulse was zero (the vehicles were already separating).
TYPE_ORDER: tuple[str, ...] = ("none", "full", "sliding", "separating")

#: Columns the runs table must have.
REQUIRED_COLUMNS: tuple[str, ...] = ("case_id", "system", "collided", "impact_type",
                                     "impact_speed1", "impact_speed2", "delta_v1", "delta_v2")

#: Upper bound of resampled elements (replicates x cases) held at once.
_MAX_RESAMPLED = 1 << 22


# ----------------------------------------------------------------------------
# Inputs
# ----------------------------------------------------------------------------


def risk_curves_for(names: Iterable[str] | None = None) -> dict[str, RiskCurve]:
    """Risk curves by injury level: the defaults of :data:`DEFAULT_RISK_LEVELS`,
    each replaced by a named curve of the same level (other levels are added).

    Raises
    ------
    ParameterError
        Unknown curve, or two curves given for one injury level.
    """
    curves = {level: default_risk_curve(level) for level in DEFAULT_RISK_LEVELS}
    given: dict[str, str] = {}
    for name in names or ():
        curve = get_risk_curve(name)
        if curve.injury_level in given:
            raise ParameterError(f"two risk curves for {curve.injury_level}: "
                                 f"{given[curve.injury_level]} and {name}")
        given[curve.injury_level] = name
        curves[curve.injury_level] = curve
    return curves


def _check_runs(runs: pd.DataFrame) -> pd.DataFrame:
    missing = [c for c in REQUIRED_COLUMNS if c not in runs.columns]
    if missing:
        raise DataError(DataProblem("runs", ", ".join(missing), None, None,
                                    "column(s) missing in the runs table"))
    out = runs.copy()
    if "error" not in out.columns:
        out["error"] = ""
    out["error"] = out["error"].fillna("").astype(str)
    if "weight" not in out.columns:
        out["weight"] = 1.0
    w = pd.to_numeric(out["weight"], errors="coerce").to_numpy(float)
    w = np.where(np.isnan(w), 1.0, w)
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise DataError(DataProblem("runs", "weight", None, None,
                                    "weights must be finite and >= 0"))
    out["weight"] = w
    if "accident_type" not in out.columns:
        out["accident_type"] = "unknown"
    out["accident_type"] = out["accident_type"].astype(object).where(
        out["accident_type"].notna(), "unknown")
    if not (out["system"] == BASELINE).any():
        raise DataError(DataProblem("runs", "system", None, None,
                                    f"no {BASELINE!r} rows: nothing to compare with"))
    dup = out.duplicated(["case_id", "system"])
    if dup.any():
        row = int(np.flatnonzero(dup.to_numpy())[0])
        raise DataError(DataProblem("runs", "system", row, out["case_id"].iloc[row],
                                    "(case, system) appears twice"))
    return out


@dataclass(frozen=True)
class PairedRuns:
    """Baseline and treatment outcomes of one system, aligned by case.

    Attributes
    ----------
    system : str
    case_id, accident_type, weight : ndarray (n,)
    crash_base, crash_treat : ndarray of bool (n,)
        Collision in the baseline / treatment run.
    speed_base, speed_treat : ndarray (n,)
        Case impact speed: the larger of the two vehicles' [m/s]; 0 without a crash.
    delta_v_base, delta_v_treat : ndarray (n, 2)
        Delta-v of vehicles 1 and 2 [m/s]; 0 without a crash.
    type_base, type_treat : ndarray of str (n,)
        Impact type (:data:`TYPE_ORDER`).
    """

    system: str
    case_id: np.ndarray
    accident_type: np.ndarray
    weight: np.ndarray
    crash_base: np.ndarray
    crash_treat: np.ndarray
    speed_base: np.ndarray
    speed_treat: np.ndarray
    delta_v_base: np.ndarray
    delta_v_treat: np.ndarray
    type_base: np.ndarray
    type_treat: np.ndarray

    def take(self, mask: np.ndarray) -> PairedRuns:
        """Subset of the cases."""
        return PairedRuns(self.system, *(getattr(self, f)[mask]
                                         for f in self.__dataclass_fields__ if f != "system"))

    @property
    def size(self) -> int:
        """Number of cases."""
        return int(self.case_id.shape[0])


def _outcomes(rows: pd.DataFrame) -> dict[str, np.ndarray]:
    crash = rows["collided"].astype("boolean").fillna(False).to_numpy(bool)
    speed = np.fmax(rows["impact_speed1"].to_numpy(float), rows["impact_speed2"].to_numpy(float))
    dv = np.stack([rows["delta_v1"].to_numpy(float), rows["delta_v2"].to_numpy(float)], axis=1)
    kind = rows["impact_type"].astype(object).where(rows["impact_type"].notna(), "none")
    kind = np.where(kind.to_numpy() == "none", "separating", kind.to_numpy()).astype(object)
    return {
        "crash": crash,
        "speed": np.where(crash, np.nan_to_num(speed), 0.0),
        "dv": np.where(crash[:, None], np.nan_to_num(dv), 0.0),
        "type": np.where(crash, kind, "none"),
    }


def paired_runs(runs: pd.DataFrame) -> tuple[list[PairedRuns], pd.DataFrame]:
    """Pair every system's runs with the baseline.

    Cases with an error in any of their runs are dropped from all systems
    (so every system is compared on the same cases).

    Returns
    -------
    pairs : list of PairedRuns
        One per system, in the order of first appearance in ``runs``.
    excluded : pandas.DataFrame
        The failed runs: case_id, system, error.
    """
    runs = _check_runs(runs)
    failed = runs["error"] != ""
    bad_cases = set(runs.loc[failed, "case_id"].tolist())
    excluded = runs.loc[failed, ["case_id", "system", "error"]].reset_index(drop=True)
    ok = runs[~runs["case_id"].isin(bad_cases)]
    base = ok[ok["system"] == BASELINE].set_index("case_id")
    b = _outcomes(base)
    systems = [s for s in pd.unique(runs["system"]) if s != BASELINE]
    pairs = []
    for name in systems:
        t = ok[ok["system"] == name].set_index("case_id").reindex(base.index)
        if t["system"].isna().any():
            missing = base.index[t["system"].isna().to_numpy()][0]
            raise DataError(DataProblem("runs", "system", None, missing,
                                        f"no run of system {name!r} for this case"))
        o = _outcomes(t)
        pairs.append(PairedRuns(
            system=str(name), case_id=base.index.to_numpy(),
            accident_type=base["accident_type"].to_numpy(object),
            weight=base["weight"].to_numpy(float), crash_base=b["crash"], crash_treat=o["crash"],
            speed_base=b["speed"], speed_treat=o["speed"], delta_v_base=b["dv"],
            delta_v_treat=o["dv"], type_base=b["type"], type_treat=o["type"]))
    return pairs, excluded


# ----------------------------------------------------------------------------
# Bootstrap of ratios of weighted sums
# ----------------------------------------------------------------------------


def bootstrap_sums(values: np.ndarray, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """Column sums of ``values`` (n, K) over ``n_boot`` resamples of the rows.

    Each resample draws n row indices uniformly with replacement; its sums
    are ``counts @ values`` with the (resample x row) count matrix, built in
    blocks of at most 2^22 elements.

    Returns
    -------
    ndarray (n_boot, K)
    """
    n, k = values.shape
    out = np.empty((n_boot, k))
    block = max(1, _MAX_RESAMPLED // max(n, 1))
    for start in range(0, n_boot, block):
        size = min(block, n_boot - start)
        idx = rng.integers(0, n, size=(size, n))
        flat = (np.arange(size)[:, None] * n + idx).ravel()
        counts = np.bincount(flat, minlength=size * n).reshape(size, n)
        out[start:start + size] = counts @ values
    return out


class _Sums:
    """Weighted sums of named columns and their bootstrap replicates."""

    def __init__(self, weight: np.ndarray) -> None:
        self.weight = weight
        self.names: list[str] = []
        self.columns: list[np.ndarray] = []

    def add(self, name: str, values: np.ndarray) -> None:
        self.names.append(name)
        self.columns.append(self.weight * np.asarray(values, float))

    def run(self, n_boot: int, rng: np.random.Generator) -> None:
        matrix = np.stack(self.columns, axis=1)
        self.estimate = dict(zip(self.names, matrix.sum(axis=0), strict=True))
        boot = bootstrap_sums(matrix, n_boot, rng)
        self.boot = {name: boot[:, i] for i, name in enumerate(self.names)}
        self.column = dict(zip(self.names, self.columns, strict=True))

    def jackknife(self, num: str, den: str) -> np.ndarray:
        """Leave-one-case-out values of the ratio num / den (one per case)."""
        return np.asarray(_ratio(self.estimate[num] - self.column[num],
                                 self.estimate[den] - self.column[den]))

    def share_interval(self, num: str, den: str, confidence: float) -> tuple[float, float]:
        """Wilson interval of the share num / den, n = Kish's effective number of the
        denominator's cases, (sum w)^2 / sum w^2 (= the count for unit weights).
        """
        total = float(self.estimate[den])
        sq = float(np.sum(self.column[den] ** 2))
        if total <= 0.0 or sq <= 0.0:
            return math.nan, math.nan
        n_eff = total * total / sq
        lo, hi = wilson_interval(float(self.estimate[num]) / total * n_eff, n_eff, confidence)
        return float(lo), float(hi)


def _ratio(num: float | np.ndarray, den: float | np.ndarray) -> Any:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.divide(num, den)


def _interval(boot: np.ndarray, confidence: float) -> tuple[float, float]:
    finite = boot[np.isfinite(boot)]
    if finite.size == 0:
        return math.nan, math.nan
    # empirical quantiles (no interpolation): interval ends are resampled values
    lo, hi = np.quantile(finite, [0.5 * (1 - confidence), 0.5 * (1 + confidence)],
                         method="inverted_cdf")
    return float(lo), float(hi)


#: (metric, unit, numerator, denominator or None for a total, description)
def _metric_specs(levels: Sequence[str]) -> list[tuple[str, str, str, str | None, str]]:
    specs: list[tuple[str, str, str, str | None, str]] = [
        ("crashes_baseline", "cases", "b", None, "baseline crashes (weighted)"),
        ("crashes_treatment", "cases", "c", None, "treatment crashes (weighted)"),
        ("crashes_avoided", "cases", "b_not_c", None, "baseline crashes avoided"),
        ("crashes_new", "cases", "c_not_b", None, "crashes only with the system"),
        ("avoided_share", "-", "b_not_c", "b", "share of baseline crashes avoided"),
        ("crash_reduction", "-", "b_minus_c", "b", "net crash reduction (avoided - new)"),
    ]
    for q, label in (("speed", "impact speed"), ("dv", "delta-v")):
        specs += [
            (f"{q}_baseline", "m/s", f"{q}_b", "b", f"mean {label} of baseline crashes"),
            (f"{q}_treatment_all", "m/s", f"{q}_t", "b",
             f"mean treatment {label} per baseline crash (no crash = 0)"),
            (f"{q}_reduction_all", "m/s", f"{q}_diff", "b",
             f"mean {label} reduction per baseline crash (no crash = 0)"),
            (f"{q}_reduction_all_rel", "-", f"{q}_diff", f"{q}_b",
             f"relative {label} reduction (no crash = 0)"),
            (f"{q}_baseline_nav", "m/s", f"{q}_b_nav", "nav",
             f"mean baseline {label} of crashes not avoided"),
            (f"{q}_treatment_nav", "m/s", f"{q}_t_nav", "nav",
             f"mean treatment {label} of crashes not avoided"),
            (f"{q}_reduction_nav", "m/s", f"{q}_diff_nav", "nav",
             f"mean {label} reduction of crashes not avoided"),
            (f"{q}_reduction_nav_rel", "-", f"{q}_diff_nav", f"{q}_b_nav",
             f"relative {label} reduction of crashes not avoided"),
        ]
    for level in levels:
        specs += [
            (f"risk_{level}_baseline", "drivers", f"r_{level}_b", None,
             f"expected {level} injured drivers, baseline"),
            (f"risk_{level}_treatment", "drivers", f"r_{level}_t", None,
             f"expected {level} injured drivers with the system"),
            (f"risk_{level}_avoided", "drivers", f"r_{level}_diff", None,
             f"expected {level} injured drivers avoided"),
            (f"risk_{level}_reduction", "-", f"r_{level}_diff", f"r_{level}_b",
             f"relative reduction of expected {level} injured drivers"),
        ]
    return specs


def _risk(curve: RiskCurve, delta_v: np.ndarray, crash: np.ndarray) -> np.ndarray:
    """Expected injured drivers per case: sum over the two vehicles of P(delta-v), 0 without
    a crash (the curves give a small risk even at delta-v 0).
    """
    p = np.nan_to_num(curve.probability(np.abs(delta_v)), nan=0.0)
    return np.where(crash, p.sum(axis=1), 0.0)


def _group_sums(pair: PairedRuns, curves: dict[str, RiskCurve]) -> _Sums:
    b = pair.crash_base.astype(float)
    c = pair.crash_treat.astype(float)
    nav = b * c
    sums = _Sums(pair.weight)
    for name, values in (("b", b), ("c", c), ("b_not_c", b * (1 - c)),
                         ("c_not_b", (1 - b) * c), ("b_minus_c", b - c), ("nav", nav)):
        sums.add(name, values)
    quantities = {"speed": (pair.speed_base, pair.speed_treat),
                  "dv": (pair.delta_v_base.max(axis=1), pair.delta_v_treat.max(axis=1))}
    for q, (vb, vt) in quantities.items():
        sums.add(f"{q}_b", vb)
        sums.add(f"{q}_t", vt)
        sums.add(f"{q}_diff", vb - vt)
        sums.add(f"{q}_b_nav", nav * vb)
        sums.add(f"{q}_t_nav", nav * vt)
        sums.add(f"{q}_diff_nav", nav * (vb - vt))
    for level, curve in curves.items():
        rb = _risk(curve, pair.delta_v_base, pair.crash_base)
        rt = _risk(curve, pair.delta_v_treat, pair.crash_treat)
        sums.add(f"r_{level}_b", rb)
        sums.add(f"r_{level}_t", rt)
        sums.add(f"r_{level}_diff", rb - rt)
    return sums


def _cdf_columns(sums: _Sums, pair: PairedRuns, grid: np.ndarray) -> None:
    """Cumulative share of baseline crashes with impact speed <= grid [m/s] (no crash = 0)."""
    b = pair.crash_base.astype(float)
    for g, x in enumerate(grid):
        sums.add(f"cdf_b_{g}", b * (pair.speed_base <= x))
        sums.add(f"cdf_t_{g}", b * (pair.speed_treat <= x))


# ----------------------------------------------------------------------------
# The analysis
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Effectiveness:
    """All figures of an effectiveness analysis.

    Attributes
    ----------
    metrics : pandas.DataFrame
        Long table: system, group (``"all"`` or an accident type), metric,
        unit (SI: m/s, or ``-`` for fractions, ``cases``, ``drivers``),
        description, estimate, low, high, n_cases (cases in the group),
        weight (their total weight).
    crosstabs : dict of str to pandas.DataFrame
        Per system, weighted counts of baseline impact type (rows) x
        treatment impact type (columns), :data:`TYPE_ORDER`, all cases.
    cdf : pandas.DataFrame
        Impact-speed distributions over the baseline crashes (no crash =
        0 m/s): columns system (baseline first), speed [m/s], share, low, high.
    pairs : list of PairedRuns
        The paired outcomes (valid cases).
    excluded : pandas.DataFrame
        Failed runs (case_id, system, error); their cases are excluded.
    curves : dict of str to RiskCurve
        Risk curve per injury level.
    n_boot, confidence, seed
        Bootstrap settings.
    """

    metrics: pd.DataFrame
    crosstabs: dict[str, pd.DataFrame]
    cdf: pd.DataFrame
    pairs: list[PairedRuns]
    excluded: pd.DataFrame
    curves: dict[str, RiskCurve]
    n_boot: int
    confidence: float
    seed: int

    def value(self, system: str, metric: str, group: object = ALL) -> float:
        """Point estimate of one metric."""
        m = self.metrics
        row = m[(m["system"] == system) & (m["metric"] == metric) & (m["group"] == group)]
        if row.empty:
            raise ParameterError(f"no metric {metric!r} for system {system!r}, group {group!r}")
        return float(row["estimate"].iloc[0])


def effectiveness(runs: pd.DataFrame, *, risk_curves: Iterable[str] | None = None,
                  n_boot: int = 2000, confidence: float = 0.95, seed: int = 0) -> Effectiveness:
    """Compare every system of a runs table with the baseline.

    Parameters
    ----------
    runs : pandas.DataFrame
        Runs table (:mod:`vfs.study.layout`); needs :data:`REQUIRED_COLUMNS`, and
        uses ``weight`` (default 1), ``accident_type`` and ``error`` if present.
    risk_curves : iterable of str, optional
        Curve names replacing the default curve of their injury level
        (:func:`risk_curves_for`).
    n_boot : int
        Bootstrap resamples (default 2000).
    confidence : float
        Level of the intervals (default 0.95).
    seed : int
        Seed of the bootstrap.

    Returns
    -------
    Effectiveness

    Raises
    ------
    DataError
        Missing columns, no baseline, duplicate rows, no valid case.
    ParameterError
        Bad n_boot, confidence or curve names.
    """
    if isinstance(n_boot, bool) or int(n_boot) != n_boot or n_boot < 1:
        raise ParameterError(f"n_boot={n_boot!r} must be a positive integer")
    if not 0.0 < confidence < 1.0:
        raise ParameterError(f"confidence={confidence!r} must be in (0, 1)")
    curves = risk_curves_for(risk_curves)
    pairs, excluded = paired_runs(runs)
    if not pairs or pairs[0].size == 0:
        raise DataError(DataProblem("runs", "", None, None,
                                    "no case with successful baseline and system runs"))
    specs = _metric_specs(list(curves))
    types = sorted(set(pairs[0].accident_type.tolist()), key=str)
    groups: list[object] = [ALL, *types]
    top = max(float(p.speed_base.max()) for p in pairs)
    grid = np.arange(0.0, math.ceil(top * KMH_PER_MS / 5.0) * 5.0 + 1.0, 1.0) / KMH_PER_MS
    rows = []
    cdf_rows = []
    for si, pair in enumerate(pairs, start=1):
        for gi, group in enumerate(groups):
            part = pair if group == ALL else pair.take(pair.accident_type == group)
            if part.size == 0:
                continue
            sums = _group_sums(part, curves)
            if group == ALL:
                _cdf_columns(sums, part, grid)
            sums.run(int(n_boot), np.random.default_rng([int(seed), si, gi]))
            for metric, unit, num, den, text in specs:
                est = sums.estimate[num] if den is None else _ratio(sums.estimate[num],
                                                                    sums.estimate[den])
                if metric in SHARE_METRICS:
                    lo, hi = sums.share_interval(num, str(den), confidence)
                elif den is None:
                    lo, hi = _interval(sums.boot[num], confidence)
                else:
                    lo, hi = bca_interval(_ratio(sums.boot[num], sums.boot[den]), float(est),
                                          sums.jackknife(num, den), confidence)
                rows.append((pair.system, group, metric, unit, text, float(est), lo, hi,
                             part.size, float(part.weight.sum())))
            if group == ALL:
                for which, label in (("b", BASELINE), ("t", pair.system)):
                    if which == "b" and si > 1:
                        continue
                    for g, x in enumerate(grid):
                        lo, hi = sums.share_interval(f"cdf_{which}_{g}", "b", confidence)
                        cdf_rows.append((label, x, float(_ratio(
                            sums.estimate[f"cdf_{which}_{g}"], sums.estimate["b"])), lo, hi))
    metrics = pd.DataFrame(rows, columns=["system", "group", "metric", "unit", "description",
                                          "estimate", "low", "high", "n_cases", "weight"])
    cdf = pd.DataFrame(cdf_rows, columns=["system", "speed", "share", "low", "high"])
    crosstabs = {p.system: impact_type_crosstab(p) for p in pairs}
    return Effectiveness(metrics, crosstabs, cdf, pairs, excluded, curves, int(n_boot),
                         float(confidence), int(seed))


def impact_type_crosstab(pair: PairedRuns) -> pd.DataFrame:
    """Weighted counts: baseline impact type (rows) x treatment impact type (columns)."""
    present = set(pair.type_base.tolist()) | set(pair.type_treat.tolist())
    order = [t for t in TYPE_ORDER if t in present or t != "separating"]
    table = pd.crosstab(pd.Categorical(pair.type_base, categories=order),
                        pd.Categorical(pair.type_treat, categories=order),
                        values=pair.weight, aggfunc="sum", dropna=False).fillna(0.0)
    table.index.name = "baseline"
    table.columns.name = pair.system
    return table.reindex(index=order, columns=order, fill_value=0.0)


__all__ = [
    "ALL",
    "DEFAULT_RISK_LEVELS",
    "REQUIRED_COLUMNS",
    "TYPE_ORDER",
    "Effectiveness",
    "PairedRuns",
    "bootstrap_sums",
    "effectiveness",
    "impact_type_crosstab",
    "paired_runs",
    "risk_curves_for",
]
