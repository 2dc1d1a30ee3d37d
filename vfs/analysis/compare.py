"""Baseline virtual forward simulation (VFS) against the reconstructions (``vfs compare``).

Reproduces the analysis of the Momentum Based Impact Model paper (VFS with the geometric
POI / contact-plane rule against the reconstructions of 36 head-on accidents)
and adds the statistics reviewers expect for paired data:

* impact-type contingency reconstruction x VFS (Figure 4) with the paper's
  chi-squared test, McNemar / Stuart-Maxwell / Bowker and Cohen's kappa;
* the distance between the POIs in vehicle coordinates (Figure 5), grouped as
  in the paper: all, both full, both sliding, type changed;
* paired comparisons of delta-v, EES, change of velocity angle, post-impact
  speed, rest positions and further outcomes per vehicle (n = 2 x cases),
  overall and split by "same impact type in both" (Table 1, Figure 6), with
  t-test, Wilcoxon, Bland-Altman, TOST equivalence and Holm adjustment;
* errors per case ranked worst first.

Everything is computed in SI units (m/s, rad, m, J); km/h and degrees appear
only in the report (:mod:`vfs.report.compare`).  Formulas and conventions:
``docs/compare.md``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from vfs.analysis.model_config import load_model_config
from vfs.analysis.staged_tests import staged_summary, staged_test_errors
from vfs.analysis.stats import (
    MIN_PAIRS_FOR_TESTS,
    ContingencyComparison,
    PairedComparison,
    bootstrap_ci,
    contingency_comparison,
    holm_bonferroni,
    paired_comparison,
)
from vfs.database.schema import OUTCOME_MEASUREMENT, RECONSTRUCTION
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.outcomes import Outcome, from_reconstruction, from_results, get_outcome, unit_factors
from vfs.physics.geometry import to_vehicle_frame
from vfs.progress import note
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases
from vfs.units import KMH_PER_MS, wrap_angle

# ----------------------------------------------------------------------------
# Groups, statuses, outcomes
# ----------------------------------------------------------------------------

#: Group of all compared cases.
GROUP_ALL = "all"
#: Full impact in the reconstruction and in the VFS.
GROUP_FULL = "both full"
#: Sliding impact in the reconstruction and in the VFS.
GROUP_SLIDING = "both sliding"
#: Impact type differs between reconstruction and VFS (either direction).
GROUP_CHANGED = "type changed"
#: The reconstruction gives no impact type (an instrumented test that does not measure one,
#: ``impact_type = ''``): neither agreement nor a change.  Listed only when present.
GROUP_UNKNOWN = "type unknown"
#: The groups of every grouped table, in table order (the Momentum Based Impact Model paper,
# section 6); :data:`GROUP_UNKNOWN` follows when a case has it.
GROUPS: tuple[str, ...] = (GROUP_ALL, GROUP_FULL, GROUP_SLIDING, GROUP_CHANGED)

#: Case compared (the VFS found an impact).
STATUS_OK = "ok"
#: The VFS found no contact (the case was avoided).
STATUS_AVOIDED = "avoided"
#: The outlines touched but the bodies were separating: no impulse.
STATUS_NO_IMPACT = "no impact"
#: The run table records an error for the case.
STATUS_ERROR = "error"
#: The run table has no baseline row for the case.
STATUS_MISSING = "missing"

#: Impact-type categories of the contingency; "none" = no impact in the VFS.
IMPACT_CATEGORIES: tuple[str, ...] = ("full", "sliding")
NO_IMPACT_CATEGORY = "none"

#: Columns a run table (``runs.parquet`` of ``vfs study``) must have.
RUN_REQUIRED_COLUMNS: tuple[str, ...] = (
    "case_id", "impact_type", "x1", "y1", "yaw1", "x2", "y2", "yaw2", "poi_x", "poi_y",
)

@dataclass(frozen=True)
class ComparedOutcome:
    """An outcome of :mod:`vfs.outcomes` as ``vfs compare`` compares it.

    Attributes
    ----------
    outcome : vfs.outcomes.Outcome
        Quantity, units and derivation.
    name : str
        Key in the comparison's tables and margins: the outcome's name, except
        ``runout_displacement`` for :data:`runout_distance
        <vfs.outcomes.OUTCOMES_BY_NAME>` (the name of the output files).
    label : str
        Name in reports.
    default_margin : float
        Default TOST equivalence margin [SI unit of the quantity].
    """

    outcome: Outcome
    name: str
    label: str
    default_margin: float

    @property
    def quantity(self) -> str:
        """Quantity kind (key of :data:`vfs.outcomes.QUANTITIES`)."""
        return self.outcome.quantity

    @property
    def level(self) -> str:
        """``"vehicle"`` (stacked: n = 2 x cases) or ``"case"``."""
        return self.outcome.level

    @property
    def angular(self) -> bool:
        """Differences are wrapped to (-pi, pi] (directions, not magnitudes)."""
        return self.outcome.wrap

    @property
    def unit(self) -> str:
        """SI unit."""
        return self.outcome.unit

    @property
    def display_unit(self) -> str:
        """Unit in reports."""
        return self.outcome.display_unit

    @property
    def display_factor(self) -> float:
        """Factor from the SI unit to :attr:`display_unit`."""
        return self.outcome.display_factor


_KMH = 1.0 / KMH_PER_MS  # 1 km/h in m/s


def _c(name: str, margin: float, key: str | None = None, label: str | None = None
       ) -> ComparedOutcome:
    o = get_outcome(name)
    return ComparedOutcome(o, key or name, label or o.label, margin)


#: Every outcome vfs compare knows, in report order.  An outcome is compared
#: when its columns are present in both the reconstruction and the VFS table.
#: Default margins (SI) are justified in docs/compare.md.
OUTCOMES: tuple[ComparedOutcome, ...] = (
    _c("delta_v", 5.0 * _KMH),
    _c("ees", 5.0 * _KMH),
    _c("velocity_angle_change", math.radians(5.0)),
    _c("post_speed", 5.0 * _KMH),
    # the output files keep their name and label (one release)
    _c("runout_distance", 1.0, "runout_displacement", "Run-out displacement (impact to rest)"),
    _c("rest_x", 1.0),
    _c("rest_y", 1.0),
    _c("pdof", math.radians(10.0)),
    _c("rest_yaw", math.radians(10.0)),
    _c("yaw_rate_post", math.radians(10.0)),
    _c("energy_loss", 25e3),
)

#: Outcomes by name (the keys of the comparison's tables).
OUTCOMES_BY_NAME: Mapping[str, ComparedOutcome] = MappingProxyType({o.name: o for o in OUTCOMES})
#: Other accepted names of outcomes in margins: the vocabulary's name -> key.
_ALIASES: Mapping[str, str] = MappingProxyType(
    {o.outcome.name: o.name for o in OUTCOMES if o.outcome.name != o.name})

#: The three parameters of the Momentum Based Impact Model paper's Table 1 and Figure 6.
TABLE1_OUTCOMES: tuple[str, ...] = ("delta_v", "ees", "velocity_angle_change")

#: Outcomes whose margin-scaled error ranks the cases (worst first).
RANKING_OUTCOMES: tuple[str, ...] = (
    "delta_v", "ees", "velocity_angle_change", "post_speed", "rest_x", "rest_y",
)

#: Default margins by outcome name [SI].
DEFAULT_MARGINS: Mapping[str, float] = MappingProxyType(
    {o.name: o.default_margin for o in OUTCOMES})

#: Seed of the case bootstrap of the mean POI / rest distances (reproducible reports).
BOOTSTRAP_SEED = 20180001
#: Number of bootstrap samples.
BOOTSTRAP_SAMPLES = 2000


# ----------------------------------------------------------------------------
# Inputs: model configuration, run tables, margins
# ----------------------------------------------------------------------------

def read_run_table(run: str | os.PathLike[str] | pd.DataFrame) -> pd.DataFrame:
    """The baseline rows of a run table written by ``vfs study``.

    Parameters
    ----------
    run : path or DataFrame
        A results folder holding ``runs.parquet``, a ``.parquet`` / ``.csv``
        file, or the table itself (columns of
        :func:`vfs.simulation.results_table` plus ``case_id``, ``system``,
        ``error``).

    Returns
    -------
    pandas.DataFrame
        Rows with ``system == "baseline"`` (all rows if there is no ``system``
        column), one per case.

    Raises
    ------
    DataError
        If the file is missing, a required column (:data:`RUN_REQUIRED_COLUMNS`)
        is missing, there is no baseline row or a case appears twice.
    """
    name = "run table"
    if isinstance(run, pd.DataFrame):
        df = run.copy()
    else:
        path = Path(run)
        if path.is_dir():
            path = path / "runs.parquet"
        name = str(path)
        if not path.is_file():
            raise DataError(DataProblem(name, "", None, None, "run table not found"))
        if path.suffix.lower() == ".csv":
            df = pd.read_csv(path)
        else:
            df = pd.read_parquet(path)
    missing = [c for c in RUN_REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise DataError([DataProblem(name, c, None, None, "column is missing") for c in missing])
    if "system" in df.columns:
        df = df[df["system"].astype(str) == "baseline"]
        if df.empty:
            raise DataError(DataProblem(name, "system", None, None,
                                        "no row with system == 'baseline'"))
    dup = df["case_id"].duplicated(keep=False).to_numpy()
    if dup.any():
        raise DataError([DataProblem(name, "case_id", int(i), df["case_id"].iloc[i],
                                     "case appears more than once among the baseline rows")
                         for i in np.flatnonzero(dup)[:20]])
    return df.reset_index(drop=True)


def resolve_margins(margins: Mapping[str, float | None] | None) -> dict[str, float | None]:
    """The default margins updated by ``margins`` (SI units; None = no TOST).

    Keys are names of :data:`OUTCOMES` (``runout_distance`` is accepted for
    ``runout_displacement``).

    Raises
    ------
    ParameterError
        For an unknown outcome or a margin that is not a positive finite number.
    """
    out: dict[str, float | None] = dict(DEFAULT_MARGINS)
    for name, value in (margins or {}).items():
        key = _ALIASES.get(name, name)
        if key not in OUTCOMES_BY_NAME:
            raise ParameterError(f"margin for unknown outcome {key!r}; known: {list(out)}")
        if value is None:
            out[key] = None
            continue
        try:
            v = float(value)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"margin {key}={value!r} is not a number") from exc
        if not (math.isfinite(v) and v > 0.0):
            raise ParameterError(f"margin {key}={value!r} must be a positive finite number")
        out[key] = v
    return out


# ----------------------------------------------------------------------------
# The result record
# ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Comparison:
    """Result of :func:`compare_database` (treat the DataFrames as read-only).

    All values in SI units (m/s, rad, m, J) unless a column says otherwise.

    Attributes
    ----------
    source : str
        Where the VFS came from: ``"simulation"`` or ``"run <path>"``.
    alpha : float
        Significance level of the equivalence decisions [-].
    confidence : float
        Level of the confidence intervals [-].
    margins : Mapping[str, float or None]
        TOST margin per outcome [SI]; None = no equivalence test.
    outcomes : tuple of str
        Outcomes compared (present in both tables).
    cases : pandas.DataFrame
        One row per case with a reconstruction: ``case_id``, ``status``
        (ok / avoided / no impact / error / missing), ``reference_type``,
        ``vfs_type`` (full / sliding / none; missing for error and missing),
        ``group`` (both full / both sliding / type changed; missing unless ok),
        ``error`` (message from the run table).
    pairs : pandas.DataFrame
        Compared cases stacked per vehicle (2 rows per case: ``case_id``,
        ``vehicle``, ``group``, types, ``reference_<o>``, ``vfs_<o>``,
        ``difference_<o>`` for every vehicle-level outcome, the POI in the
        vehicle frame ``reference_poi_x/y``, ``vfs_poi_x/y`` [m, x forward,
        y left, origin CG], ``poi_distance`` [m], ``rest_distance`` [m] and the
        vehicle's ``length``, ``width``, ``cg_to_front`` [m] when known).
    contingency : ContingencyComparison
        Reconstruction x VFS impact type over the cases with status ok,
        avoided or no impact (categories full, sliding and, if it occurs, none).
    contingency_impacts : ContingencyComparison
        The same over the cases with an impact in the VFS (2 x 2: McNemar
        is always defined).
    poi_distances : pandas.DataFrame
        Per group of :data:`GROUPS`: ``n`` (vehicles), ``n_cases``, ``mean``,
        ``median``, ``sd``, ``max``, ``mean_ci_low``, ``mean_ci_high`` (case
        bootstrap) of the POI distance [m].
    rest_distances : pandas.DataFrame
        The same for the distance between the rest positions [m].
    paired : pandas.DataFrame
        One row per (outcome, group): ``outcome``, ``label``, ``level``,
        ``unit``, ``display_unit``, ``display_factor``, ``group``, the fields of
        :class:`vfs.analysis.stats.PairedComparison`, ``n_cases``, the case-level test
        (``case_t_pvalue``, ``case_ci_low``, ``case_ci_high``: per-case mean
        of the two vehicles) and Holm-adjusted p-values ``t_pvalue_holm``,
        ``wilcoxon_pvalue_holm``, ``tost_pvalue_holm`` (family: all rows).
    table1 : pandas.DataFrame
        The Momentum Based Impact Model paper's Table 1 in report units (km/h, deg):
        ``parameter``, ``n``,
        ``mean_reconstruction``, ``mean_vfs``, ``p_value`` and extra columns.
    case_errors : pandas.DataFrame
        Errors per compared case ranked worst first (``score``: largest
        ``|difference| / margin`` over :data:`RANKING_OUTCOMES` and both
        vehicles).
    params : SimulationParams or None
        Model parameters of the simulation (None: default model).
    measured : pandas.DataFrame
        Crash tests (reconstruction rows with ``outcome_source = measurement``): one row
        per measured outcome value, ``case_id``, ``outcome`` (column), ``measured``, ``sd``
        (NaN: not stated), ``model``, ``difference`` (model - measured) and ``z``
        (difference / sd) [SI units]; empty when there are no measurement rows.
    staged : pandas.DataFrame or None
        Staged tests (measurement rows): one row per test and vehicle with the errors of
        :func:`staged_test_errors` (delta-v, heading change, range error) and the published
        errors of other codes where the database gives them; empty without measurement
        rows.
    impact_parameters : str
        Restitution and contact friction of the simulation: ``"default"`` (the model's
        generic defaults for every case, the prospective protocol of the frontal-collision
        paper), ``"reconstruction"`` (each case's reconstructed values) or ``""`` (a run
        table: its study's setting).
    """

    source: str
    alpha: float
    confidence: float
    margins: Mapping[str, float | None]
    outcomes: tuple[str, ...]
    cases: pd.DataFrame
    pairs: pd.DataFrame
    contingency: ContingencyComparison
    contingency_impacts: ContingencyComparison
    poi_distances: pd.DataFrame
    rest_distances: pd.DataFrame
    paired: pd.DataFrame
    table1: pd.DataFrame
    case_errors: pd.DataFrame
    params: SimulationParams | None = None
    measured: pd.DataFrame | None = None
    impact_parameters: str = ""
    staged: pd.DataFrame | None = None

    @property
    def status_counts(self) -> dict[str, int]:
        """Number of cases per status."""
        counts = self.cases["status"].value_counts()
        order = (STATUS_OK, STATUS_AVOIDED, STATUS_NO_IMPACT, STATUS_ERROR, STATUS_MISSING)
        return {s: int(counts.get(s, 0)) for s in order}

    @property
    def excluded(self) -> pd.DataFrame:
        """Cases left out of the paired analyses (status not ok) with the reason."""
        return self.cases[self.cases["status"] != STATUS_OK].reset_index(drop=True)

    def summary(self) -> str:
        """A few lines for the terminal (km/h, degrees)."""
        c = self.contingency
        counts = self.status_counts
        lines = [
            f"{len(self.cases)} reconstructed cases from {self.source}: "
            + ", ".join(f"{k} {v}" for k, v in counts.items() if v),
            "impact type reconstruction x VFS: "
            + ", ".join(f"{r}->{m} {int(c.table.loc[r, m])}" for r in c.categories
                        for m in c.categories if r in IMPACT_CATEGORIES and c.table.loc[r, m]),
            f"chi-squared (paper, independent samples) {_fmt_p(c.chi2_pvalue)}; "
            f"McNemar {_fmt_p(self.contingency_impacts.mcnemar_pvalue)}; "
            f"Bowker {_fmt_p(c.bowker_pvalue)}; kappa = {_fmt(c.kappa)}",
        ]
        poi = self.poi_distances.set_index("group")
        if int(poi.loc[GROUP_ALL, "n"]) == 0:
            lines.append("POI distance: none (no reconstructed POI; a crash test's POI is "
                         "the assumed set-up)")
        else:
            lines.append("POI distance [m] mean (n): " + ", ".join(
                f"{g} {_fmt(poi.loc[g, 'mean'])} ({int(poi.loc[g, 'n'])})" for g in GROUPS))
        for _, row in self.table1.iterrows():
            lines.append(f"{row['parameter']}: n = {row['n']}, reconstruction "
                         f"{_fmt(row['mean_reconstruction'], 2)}, VFS {_fmt(row['mean_vfs'], 2)},"
                         f" {_fmt_p(row['p_value'])}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Every number as a JSON-ready dict (SI units; NaN/inf become None)."""
        return _json_ready({
            "source": self.source,
            "alpha": self.alpha,
            "confidence": self.confidence,
            "units": "SI (m/s, rad, m, rad/s, J); table1 in km/h and deg",
            "margins": dict(self.margins),
            "outcomes": list(self.outcomes),
            "model_effects": ([e.to_dict() for e in self.params.effects]
                              if self.params is not None else []),
            "status_counts": self.status_counts,
            "cases": self.cases.to_dict(orient="records"),
            "contingency": contingency_to_dict(self.contingency),
            "contingency_impacts": contingency_to_dict(self.contingency_impacts),
            "poi_distances": self.poi_distances.to_dict(orient="records"),
            "rest_distances": self.rest_distances.to_dict(orient="records"),
            "paired": self.paired.to_dict(orient="records"),
            "table1": self.table1.to_dict(orient="records"),
            "case_errors": self.case_errors.to_dict(orient="records"),
            **({"staged_tests": self.staged.to_dict(orient="records"),
                "staged_summary": staged_summary(self.staged).to_dict(orient="records")}
               if self.staged is not None and len(self.staged) else {}),
        })


def _fmt(value: float, digits: int = 3) -> str:
    """Number for text output; 'n/a' for NaN."""
    v = float(value)
    return "n/a" if math.isnan(v) else f"{v:.{digits}f}"


def _fmt_p(value: float) -> str:
    """'p = 0.123', 'p < 0.001' or 'p = n/a'."""
    v = float(value)
    return "p < 0.001" if v < 0.001 else f"p = {_fmt(v)}"


def _json_ready(obj: Any) -> Any:
    """Nested structure with numpy scalars as Python numbers and NaN/inf as None."""
    if isinstance(obj, Mapping):
        return {str(k): _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_ready(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_json_ready(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if obj is pd.NA or obj is pd.NaT:
        return None
    return obj


def contingency_to_dict(c: ContingencyComparison) -> dict[str, Any]:
    """A :class:`ContingencyComparison` as a JSON-ready dict (table as nested lists)."""
    out = {f.name: getattr(c, f.name) for f in fields(c) if f.name != "table"}
    out["categories"] = list(c.categories)
    out["table"] = c.table.to_numpy().tolist()
    out["table_rows"] = "reference (reconstruction)"
    out["table_columns"] = "model (VFS)"
    return _json_ready(out)


# ----------------------------------------------------------------------------
# Computation
# ----------------------------------------------------------------------------


def _reconstruction(db: Any) -> pd.DataFrame:
    """The reconstruction rows in the order of the cases table."""
    rec = getattr(db, "reconstruction", None)
    if rec is None or not getattr(db, "has_reconstruction", True) or rec.empty:
        raise DataError(DataProblem("reconstruction", "", None, None,
                                    "the database has no reconstruction to compare with"))
    order = pd.Index(db.case_ids)
    rec = rec.drop_duplicates("case_id")
    pos = order.get_indexer(rec["case_id"])
    return rec.iloc[np.argsort(pos, kind="stable")].reset_index(drop=True)


def compare_database(
    db: Any,
    *,
    run: str | os.PathLike[str] | pd.DataFrame | None = None,
    params: SimulationParams | None = None,
    margins: Mapping[str, float | None] | None = None,
    alpha: float = 0.05,
    confidence: float = 0.95,
    impact_parameters: str = "default",
) -> Comparison:
    """Compare the baseline VFS of every reconstructed case with its reconstruction.

    Parameters
    ----------
    db : vfs.database.Database
        Cases with reconstructions (cases without a reconstruction row, e.g.
        near misses, are not compared).
    run : path or DataFrame, optional
        Baseline rows of a ``vfs study`` run (:func:`read_run_table`).  Without
        it, the cases are simulated with :func:`vfs.simulation.simulate_cases`
        (no controller) with the impact parameters ``impact_parameters``.
    params : SimulationParams, optional
        Model of the simulation (default: the default model); with ``run`` only
        used to re-simulate the worst cases for the report.
    margins : mapping, optional
        TOST margins per outcome name [SI: m/s, rad, m, rad/s, J], updating
        :data:`DEFAULT_MARGINS`; None for an outcome switches its TOST off.
    alpha, confidence : float
        Significance level of the equivalence decision, level of the
        confidence intervals.
    impact_parameters : {"default", "reconstruction"}
        Restitution and contact friction of the simulation: the model's generic
        defaults for every case (default: a prospective assessment has no expert
        values, the protocol of "Evaluation of a momentum based impact model in frontal
        car collisions for the prospective assessment of ADAS"), or each case's
        reconstructed values (NaN: the default).  Nothing else changes.  Not used
        with ``run`` (the run's study chose).

    Returns
    -------
    Comparison

    Raises
    ------
    DataError
        If the database has no reconstruction or the run table is invalid.
    ParameterError
        For invalid margins, alpha or confidence.
    """
    rec = _reconstruction(db)
    ids = rec["case_id"].to_numpy()
    if run is None:
        note("simulating %d reconstructed case(s), from pre-crash to rest", len(ids))
        batch = CaseBatch.from_database(db, ids, impact_parameters=impact_parameters)
        res = simulate_cases(batch, params=params or SimulationParams())
        vfs = results_table(batch, res)
        source = "simulation"
        setting = impact_parameters
    else:
        vfs = read_run_table(run)
        source = "run table" if isinstance(run, pd.DataFrame) else f"run {run}"
        setting = ""
    note("comparing the simulation with the reconstructions (tests and intervals)")
    comparison = compare_tables(rec, vfs, participants=getattr(db, "participants", None),
                                margins=margins, alpha=alpha, confidence=confidence,
                                source=source, params=params)
    return dataclasses.replace(comparison, impact_parameters=setting,
                               measured=measured_outcomes(rec, vfs),
                               staged=staged_test_errors(rec, vfs))


#: Reconstruction columns a crash test can measure and the simulation's results table has.
MEASURABLE: tuple[str, ...] = tuple(
    f"{q}{i}" for q in ("delta_v", "ees", "pdof", "velocity_angle_change")
    for i in (1, 2)) + (
    "vx1_post", "vy1_post", "yaw_rate1_post", "vx2_post", "vy2_post", "yaw_rate2_post",
    "rest_x1", "rest_y1", "rest_yaw1", "rest_x2", "rest_y2", "rest_yaw2", "energy_loss")


def measured_outcomes(reconstruction: pd.DataFrame, vfs: pd.DataFrame) -> pd.DataFrame:
    """Model against measurement for every measured value of the crash-test rows (SI).

    Only rows with ``outcome_source == "measurement"`` and only their finite values
    (NaN = not measured) enter; see :attr:`Comparison.measured`.
    """
    cols = ["case_id", "outcome", "measured", "sd", "model", "difference", "z"]
    if "outcome_source" not in reconstruction.columns:
        return pd.DataFrame(columns=cols)
    rec = reconstruction[reconstruction["outcome_source"] == "measurement"]
    if rec.empty:
        return pd.DataFrame(columns=cols)
    model = vfs.drop_duplicates("case_id").set_index("case_id")
    out = []
    for col in MEASURABLE:
        if col not in rec.columns or col not in model.columns:
            continue
        meas = pd.to_numeric(rec[col], errors="coerce").to_numpy(float)
        ok = np.isfinite(meas)
        if not ok.any():
            continue
        ids = rec["case_id"].to_numpy()[ok]
        sd = (pd.to_numeric(rec[f"{col}_sd"], errors="coerce").to_numpy(float)[ok]
              if f"{col}_sd" in rec.columns else np.full(ok.sum(), np.nan))
        mod = pd.to_numeric(model[col].reindex(ids), errors="coerce").to_numpy(float)
        diff = mod - meas[ok]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(sd > 0, diff / sd, np.nan)
        out.append(pd.DataFrame({"case_id": ids, "outcome": col, "measured": meas[ok],
                                 "sd": sd, "model": mod, "difference": diff, "z": z}))
    if not out:
        return pd.DataFrame(columns=cols)
    return pd.concat(out, ignore_index=True).sort_values(["case_id", "outcome"],
                                                         ignore_index=True)


def _poi_local(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """POI of each case in the frames of vehicles 1 and 2, arrays (n, 2) [m]."""
    def col(name: str) -> np.ndarray:
        return pd.to_numeric(table[name], errors="coerce").to_numpy(float)

    poi = np.stack([col("poi_x"), col("poi_y")], axis=1)
    local = [to_vehicle_frame(poi, col(f"x{i}"), col(f"y{i}"), col(f"yaw{i}")) for i in (1, 2)]
    return (np.stack([p[:, 0] for p in local], axis=1),
            np.stack([p[:, 1] for p in local], axis=1))


def _as_labels(values: pd.Series) -> np.ndarray:
    """String labels with missing values (and '' = not measured) as None."""
    arr = values.astype(object).to_numpy()
    return np.asarray(np.where(pd.isna(arr) | (arr == ""), None, arr), dtype=object)


def _case_status(rec: pd.DataFrame, vfs: pd.DataFrame) -> pd.DataFrame:
    """Status, impact types and group of every reconstructed case.

    ``vfs`` is aligned with ``rec`` (same case order; all-NaN rows where the
    VFS table has no row) and has a boolean column ``_present``.
    """
    ids = rec["case_id"].to_numpy()
    present = vfs["_present"].to_numpy(bool)
    error = np.zeros(ids.shape[0], dtype=bool)
    message = np.full(ids.shape[0], None, dtype=object)
    if "error" in vfs.columns:
        text = np.array([("" if pd.isna(v) else str(v)) for v in vfs["error"].astype(object)],
                        dtype=object)
        error = np.array([bool(t.strip()) for t in text], dtype=bool) & present
        message = np.where(error, text, None)
    vfs_type = _as_labels(vfs["impact_type"])
    if "collided" in vfs.columns:
        collided = vfs["collided"].astype(object).fillna(False).to_numpy(bool)
    else:
        collided = vfs_type != NO_IMPACT_CATEGORY
    known = {*IMPACT_CATEGORIES, NO_IMPACT_CATEGORY}
    bad = np.flatnonzero(~error & present & ~np.isin(vfs_type, list(known)))
    if bad.size:
        raise DataError([DataProblem("run table", "impact_type", int(i), ids[i],
                                     f"impact type {vfs_type[i]!r} is not one of "
                                     f"{sorted(known)} (rows with an error need an error text)")
                         for i in bad[:20]])
    status = np.select(
        [~present, error, ~collided, vfs_type == NO_IMPACT_CATEGORY],
        [STATUS_MISSING, STATUS_ERROR, STATUS_AVOIDED, STATUS_NO_IMPACT], STATUS_OK,
    ).astype(object)
    ref_type = _as_labels(rec["impact_type"])
    labelled = np.isin(status, [STATUS_OK, STATUS_AVOIDED, STATUS_NO_IMPACT])
    vfs_label = np.where(status == STATUS_OK, vfs_type,
                         np.where(labelled, NO_IMPACT_CATEGORY, None)).astype(object)
    ok = status == STATUS_OK
    group = np.select(
        [~ok, ~np.isin(ref_type, list(IMPACT_CATEGORIES)),
         (ref_type == "full") & (vfs_label == "full"),
         (ref_type == "sliding") & (vfs_label == "sliding")],
        [np.full(len(ok), None), GROUP_UNKNOWN, GROUP_FULL, GROUP_SLIDING], GROUP_CHANGED,
    ).astype(object)
    group = np.where(ok, group, None)
    return pd.DataFrame({
        "case_id": ids, "status": status, "reference_type": ref_type,
        "vfs_type": vfs_label, "group": group, "error": message,
    })


def _normalise_vfs(vfs: pd.DataFrame, ok: np.ndarray) -> pd.DataFrame:
    """VFS table aligned with the cases, numbers of cases not compared set to NaN.

    The columns the reconstruction files store in another unit (angles in
    degrees) are rounded as the files round them
    (:meth:`vfs.database.schema.ColumnSpec.as_stored`): identical values then
    compare exactly equal.
    """
    out = vfs.copy()
    for c in out.columns:
        if c == "case_id" or not pd.api.types.is_numeric_dtype(out[c]):
            continue
        if pd.api.types.is_bool_dtype(out[c]):
            continue
        values = out[c].to_numpy(float, na_value=np.nan)
        if c in RECONSTRUCTION.column_names:
            values = RECONSTRUCTION.column(c).as_stored(values)
        out[c] = np.where(ok, values, np.nan)
    return out


def _distance_stats(distance: np.ndarray, group_case: np.ndarray,
                    confidence: float) -> pd.DataFrame:
    """n, n_cases, mean, median, sd, max and a case-bootstrap CI of the mean per group.

    ``distance`` (n_cases, 2) [m] per case and vehicle; ``group_case`` the
    group label of every case (None = not compared).
    """
    rows = []
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    for g, mask in _group_masks(group_case).items():
        per_case = distance[mask]
        per_case = per_case[np.isfinite(per_case).any(axis=1)]
        d = per_case[np.isfinite(per_case)]
        n = int(d.size)
        low = high = math.nan
        if per_case.shape[0] >= MIN_PAIRS_FOR_TESTS:
            # resample cases with both their vehicles: the two vehicles of a
            # case are not independent
            def case_mean(values: np.ndarray, axis: int = 0) -> np.ndarray:
                return np.nanmean(values.reshape(values.shape[:axis] + (-1,)), axis=axis)

            # distances are positive and right-skewed: BCa (docs/statistics.md)
            _, low, high = bootstrap_ci(case_mean, per_case, n_boot=BOOTSTRAP_SAMPLES,
                                        confidence=confidence, rng=rng, method="bca")
        rows.append({
            "group": g, "n": n, "n_cases": int(per_case.shape[0]),
            "mean": float(np.mean(d)) if n else math.nan,
            "median": float(np.median(d)) if n else math.nan,
            "sd": float(np.std(d, ddof=1)) if n >= 2 else math.nan,
            "max": float(np.max(d)) if n else math.nan,
            "mean_ci_low": float(low), "mean_ci_high": float(high),
        })
    return pd.DataFrame(rows)


def _group_masks(groups: np.ndarray) -> dict[str, np.ndarray]:
    """Boolean masks of :data:`GROUPS` (and :data:`GROUP_UNKNOWN` where a case has it) over
    an array of group labels (None = not compared).
    """
    compared = np.array([g is not None for g in groups], dtype=bool)
    names = (*GROUPS, GROUP_UNKNOWN) if np.any(groups == GROUP_UNKNOWN) else GROUPS
    return {g: compared if g == GROUP_ALL else (groups == g) for g in names}


def compare_tables(
    reconstruction: pd.DataFrame,
    vfs: pd.DataFrame,
    *,
    participants: pd.DataFrame | None = None,
    margins: Mapping[str, float | None] | None = None,
    alpha: float = 0.05,
    confidence: float = 0.95,
    source: str = "",
    params: SimulationParams | None = None,
) -> Comparison:
    """Compare a VFS results table with a reconstruction table (the work of
    :func:`compare_database`).

    Parameters
    ----------
    reconstruction : pandas.DataFrame
        Reconstruction table (schema of ``docs/data-format.md``, SI units as
        :attr:`vfs.database.Database.reconstruction` holds it: angles in rad),
        one row per case.
    vfs : pandas.DataFrame
        Results table of the VFS (columns of
        :func:`vfs.simulation.results_table`, angles in rad), optionally with
        ``error``; one row per case, matched by ``case_id``.
    participants : pandas.DataFrame, optional
        Participants table (vehicle length, width, CG to front) for the POI
        figure.
    margins, alpha, confidence
        See :func:`compare_database`.
    source : str
        Description of the VFS source.
    params : SimulationParams, optional
        Model parameters (recorded; the report re-simulates cases with them).

    Returns
    -------
    Comparison
    """
    if not 0.0 < float(alpha) < 1.0 or not 0.0 < float(confidence) < 1.0:
        raise ParameterError(f"alpha={alpha!r} and confidence={confidence!r} must lie in (0, 1)")
    resolved = resolve_margins(margins)
    missing = [c for c in RUN_REQUIRED_COLUMNS if c not in vfs.columns]
    if missing:
        raise DataError([DataProblem("VFS table", c, None, None, "column is missing")
                         for c in missing])
    rec = reconstruction.reset_index(drop=True)
    ids = rec["case_id"].to_numpy()
    n_cases = ids.shape[0]
    aligned = vfs.assign(_present=True).set_index("case_id").reindex(ids).reset_index()
    aligned["_present"] = aligned["_present"].astype(object).fillna(False).astype(bool)
    cases = _case_status(rec, aligned)
    ok = (cases["status"] == STATUS_OK).to_numpy()
    vfs_n = _normalise_vfs(aligned, ok)
    rec_n = rec

    # ---- stacked per vehicle (case-major: case 1 vehicle 1, case 1 vehicle 2, ...)
    case_index = np.repeat(np.arange(n_cases), 2)
    group_case = cases["group"].to_numpy(object)
    group_veh = group_case[case_index]
    pairs: dict[str, Any] = {
        "case_id": ids[case_index],
        "vehicle": np.tile([1, 2], n_cases),
        "group": group_veh,
        "reference_type": cases["reference_type"].to_numpy(object)[case_index],
        "vfs_type": cases["vfs_type"].to_numpy(object)[case_index],
    }
    values: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    recorded = from_reconstruction(rec_n, [o.outcome for o in OUTCOMES])
    modelled = from_results(vfs_n, [o.outcome for o in OUTCOMES])
    for o in OUTCOMES:
        ref = recorded.get(o.outcome.name)
        mod = modelled.get(o.outcome.name)
        if ref is None or mod is None:
            continue
        if o.angular:
            mod = ref + wrap_angle(mod - ref)  # smallest signed difference
        values[o.name] = (ref, mod)
        if o.level == "vehicle":
            pairs[f"reference_{o.name}"] = ref.ravel()
            pairs[f"vfs_{o.name}"] = mod.ravel()
            pairs[f"difference_{o.name}"] = (mod - ref).ravel()
    rx, ry = _poi_local(rec_n)
    vx, vy = _poi_local(vfs_n)
    pairs["reference_poi_x"], pairs["reference_poi_y"] = rx.ravel(), ry.ravel()
    pairs["vfs_poi_x"], pairs["vfs_poi_y"] = vx.ravel(), vy.ravel()
    poi_distance = np.hypot(vx - rx, vy - ry)
    # An instrumented test's POI is the assumed set-up (scenarios/databases/crash-tests/README.md,
    # "Assumptions"), not an observation: no distance to report.
    poi_distance[_assumed_poi(rec_n)] = np.nan
    poi_distance = poi_distance.ravel()
    pairs["poi_distance"] = poi_distance
    rest_distance = np.full(2 * n_cases, np.nan)
    if "rest_x" in values and "rest_y" in values:
        rest_distance = np.hypot(values["rest_x"][1] - values["rest_x"][0],
                                 values["rest_y"][1] - values["rest_y"][0]).ravel()
    pairs["rest_distance"] = rest_distance
    pairs.update(_vehicle_dimensions(participants, ids))
    pairs_df = pd.DataFrame(pairs)
    pairs_df = pairs_df[np.isin(cases["status"].to_numpy(object)[case_index], [STATUS_OK])]
    pairs_df = pairs_df.reset_index(drop=True)

    # ---- impact types
    labelled = cases["vfs_type"].notna().to_numpy()
    cats = list(IMPACT_CATEGORIES)
    if (cases["vfs_type"] == NO_IMPACT_CATEGORY).any():
        cats.append(NO_IMPACT_CATEGORY)
    ref_type = cases["reference_type"].to_numpy(object)
    vfs_type = cases["vfs_type"].to_numpy(object)
    contingency = contingency_comparison(ref_type[labelled], vfs_type[labelled],
                                         categories=cats, confidence=confidence)
    contingency_impacts = contingency_comparison(
        ref_type[ok], vfs_type[ok], categories=list(IMPACT_CATEGORIES), confidence=confidence)

    # ---- distances
    poi_stats = _distance_stats(poi_distance.reshape(-1, 2), group_case, confidence)
    rest_stats = _distance_stats(rest_distance.reshape(-1, 2), group_case, confidence)

    # ---- paired outcomes
    paired = _paired_table(values, group_case, resolved, alpha, confidence)
    table1 = _table1(paired)
    errors = _case_errors(cases, values, resolved, poi_distance, rest_distance)

    return Comparison(
        source=source, alpha=float(alpha), confidence=float(confidence),
        margins=MappingProxyType(resolved), outcomes=tuple(values),
        cases=cases, pairs=pairs_df, contingency=contingency,
        contingency_impacts=contingency_impacts, poi_distances=poi_stats,
        rest_distances=rest_stats, paired=paired, table1=table1, case_errors=errors,
        params=params,
    )


def _assumed_poi(rec: pd.DataFrame) -> np.ndarray:
    """Cases whose POI is assumed, not reconstructed: measurement rows (crash tests).

    A reconstruction row's POI is the expert's result; an instrumented test measures
    outcomes, while its POI and contact plane are the configuration the database author
    assumed to replay it (``outcome_source = 'measurement'``, schema of
    docs/data-format.md).
    """
    if "outcome_source" not in rec.columns:
        return np.zeros(len(rec), bool)
    return (rec["outcome_source"].astype(object) == OUTCOME_MEASUREMENT).to_numpy(bool)


def _vehicle_dimensions(participants: pd.DataFrame | None,
                        ids: np.ndarray) -> dict[str, np.ndarray]:
    """length, width and CG-to-front distance [m] per stacked vehicle (NaN if unknown)."""
    n = ids.shape[0]
    out = {k: np.full(2 * n, np.nan) for k in ("length", "width", "cg_to_front")}
    needed = {"case_id", "participant", "length", "width", "cg_to_front_axle", "front_overhang"}
    if participants is None or not needed <= set(participants.columns):
        return out
    p = participants.drop_duplicates(["case_id", "participant"]).set_index(
        ["case_id", "participant"])
    index = pd.MultiIndex.from_arrays([np.repeat(ids, 2), np.tile([1, 2], n)])
    p = p.reindex(index)
    out["length"] = p["length"].to_numpy(float)
    out["width"] = p["width"].to_numpy(float)
    out["cg_to_front"] = (p["cg_to_front_axle"] + p["front_overhang"]).to_numpy(float)
    return out


def _paired_table(values: Mapping[str, tuple[np.ndarray, np.ndarray]], group_case: np.ndarray,
                  margins: Mapping[str, float | None], alpha: float,
                  confidence: float) -> pd.DataFrame:
    """Paired comparisons per (outcome, group) with the case-level test and Holm."""
    masks = _group_masks(group_case)
    rows: list[dict[str, Any]] = []
    for name, (ref, mod) in values.items():
        o = OUTCOMES_BY_NAME[name]
        # per-case means of the vehicles: the unit of an independent sample
        ref_case, mod_case = ref.mean(axis=1), mod.mean(axis=1)
        for g, mask in masks.items():
            r, m = ref[mask].ravel(), mod[mask].ravel()
            res = paired_comparison(r, m, margin=margins.get(name), alpha=alpha,
                                    confidence=confidence, name=name)
            complete = np.isfinite(ref[mask]) & np.isfinite(mod[mask])
            case = paired_comparison(ref_case[mask], mod_case[mask], confidence=confidence)
            rows.append({
                "outcome": name, "label": o.label, "level": o.level, "unit": o.unit,
                "display_unit": o.display_unit, "display_factor": o.display_factor,
                "group": g, **asdict(res),
                "n_cases": int(np.count_nonzero(complete.any(axis=1))),
                "case_t_pvalue": case.t_pvalue, "case_ci_low": case.ci_low,
                "case_ci_high": case.ci_high, "n_cases_complete": case.n,
            })
    columns = (["outcome", "label", "level", "unit", "display_unit", "display_factor", "group"]
               + [f.name for f in fields(PairedComparison)]
               + ["n_cases", "case_t_pvalue", "case_ci_low", "case_ci_high", "n_cases_complete"])
    table = pd.DataFrame(rows, columns=columns)
    for col in ("t_pvalue", "wilcoxon_pvalue", "tost_pvalue"):
        table[f"{col}_holm"] = (holm_bonferroni(table[col].to_numpy(float))
                                if len(table) else np.zeros(0))
    return table


def _table1(paired: pd.DataFrame) -> pd.DataFrame:
    """The Momentum Based Impact Model paper's Table 1: paired t-tests of delta-v, EES and
    change of velocity angle for full and sliding impacts (same type in both), km/h and
    degrees.
    """
    rows = []
    kind = {GROUP_FULL: "full impacts", GROUP_SLIDING: "sliding impacts"}
    indexed = paired.set_index(["outcome", "group"]) if len(paired) else None
    for g in (GROUP_FULL, GROUP_SLIDING):
        for name in TABLE1_OUTCOMES:
            if indexed is None or (name, g) not in indexed.index:
                continue
            r = indexed.loc[(name, g)]
            f = float(r["display_factor"])
            rows.append({
                "parameter": f"{r['label']}, {kind[g]} [{r['display_unit']}]",
                "outcome": name, "group": g, "n": int(r["n"]),
                "mean_reconstruction": r["mean_reference"] * f, "mean_vfs": r["mean_model"] * f,
                "p_value": r["t_pvalue"],
                "mean_difference": r["mean_difference"] * f,
                "ci_low": r["ci_low"] * f, "ci_high": r["ci_high"] * f,
                "p_holm": r["t_pvalue_holm"], "wilcoxon_p": r["wilcoxon_pvalue"],
                "case_level_p": r["case_t_pvalue"],
                "tost_margin": r["tost_margin"] * f, "tost_p": r["tost_pvalue"],
                "equivalent": bool(r["equivalent"]),
            })
    return pd.DataFrame(rows, columns=[
        "parameter", "outcome", "group", "n", "mean_reconstruction", "mean_vfs", "p_value",
        "mean_difference", "ci_low", "ci_high", "p_holm", "wilcoxon_p", "case_level_p",
        "tost_margin", "tost_p", "equivalent"])


def _case_errors(cases: pd.DataFrame, values: Mapping[str, tuple[np.ndarray, np.ndarray]],
                 margins: Mapping[str, float | None], poi_distance: np.ndarray,
                 rest_distance: np.ndarray) -> pd.DataFrame:
    """Errors per compared case (absolute, relative), ranked by the largest
    margin-scaled error, worst first.
    """
    ok = (cases["status"] == STATUS_OK).to_numpy()
    out: dict[str, Any] = {c: cases[c].to_numpy(object)[ok]
                           for c in ("case_id", "reference_type", "vfs_type", "group")}
    n = int(np.count_nonzero(ok))
    scaled, labels = [], []
    for name, (ref, mod) in values.items():
        o = OUTCOMES_BY_NAME[name]
        r, m = ref[ok], mod[ok]
        d = m - r
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(r != 0.0, d / np.abs(r), np.nan)
        suffixes = ("1", "2") if o.level == "vehicle" else ("",)
        for j, s in enumerate(suffixes):
            out[f"reference_{name}{s}"] = r[:, j]
            out[f"vfs_{name}{s}"] = m[:, j]
            out[f"error_{name}{s}"] = d[:, j]
            out[f"abs_error_{name}{s}"] = np.abs(d[:, j])
            out[f"rel_error_{name}{s}"] = rel[:, j]
        margin = margins.get(name)
        if name in RANKING_OUTCOMES and margin:
            for j, s in enumerate(suffixes):
                scaled.append(np.abs(d[:, j]) / margin)
                labels.append(f"{name}{s}")
    poi = poi_distance.reshape(-1, 2)[ok]
    rest = rest_distance.reshape(-1, 2)[ok]
    for j in (0, 1):
        out[f"poi_distance{j + 1}"] = poi[:, j]
        out[f"rest_distance{j + 1}"] = rest[:, j]
    if scaled:
        stack = np.stack(scaled, axis=1)
        filled = np.where(np.isnan(stack), -np.inf, stack)
        worst = np.argmax(filled, axis=1)
        score = filled[np.arange(n), worst]
        score = np.where(np.isinf(score), np.nan, score)
        worst_label = np.asarray(np.where(np.isnan(score), None,
                                          np.array(labels, dtype=object)[worst]), dtype=object)
    else:
        score = np.full(n, np.nan)
        worst_label = np.full(n, None, dtype=object)
    out["score"] = score
    out["worst"] = worst_label
    df = pd.DataFrame(out)
    front = ["case_id", "score", "worst", "reference_type", "vfs_type", "group"]
    df = df[front + [c for c in df.columns if c not in front]]
    df = df.sort_values("score", ascending=False, na_position="last", kind="stable")
    df.insert(0, "rank", np.arange(1, n + 1))
    return df.reset_index(drop=True)


def parse_margins(text: str) -> dict[str, float]:
    """Margins from the command line, e.g. ``"delta_v=3,ees=5km/h,rest_x=0.5m"``.

    A bare number is in the report unit of the outcome (km/h, deg, m, deg/s,
    kJ); a number may carry one of the units km/h, m/s, deg, rad, m, deg/s,
    rad/s, kJ, J.  Returns SI values.

    Raises
    ------
    ParameterError
        For an unknown outcome, a unit that does not fit the outcome or a value
        that is not a positive number.
    """
    factors = unit_factors()  # unit -> (quantity, factor to SI)
    out: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, sep, value = item.partition("=")
        key, value = _ALIASES.get(key.strip(), key.strip()), value.strip()
        if not sep or key not in OUTCOMES_BY_NAME:
            raise ParameterError(f"margin {item!r}: expected OUTCOME=VALUE[UNIT] with OUTCOME "
                                 f"one of {list(OUTCOMES_BY_NAME)}")
        o = OUTCOMES_BY_NAME[key]
        match = re.fullmatch(r"([-+0-9.eE]+)\s*([A-Za-z/]*)", value)
        if match is None:
            raise ParameterError(f"margin {item!r}: {value!r} is not NUMBER[UNIT]")
        number, unit = match.group(1), match.group(2).lower()
        if unit:
            if unit not in factors or factors[unit][0] != o.quantity:
                raise ParameterError(f"margin {item!r}: unit {unit!r} does not fit {key} "
                                     f"(a {o.quantity}; report unit {o.display_unit})")
            factor = factors[unit][1]
        else:
            factor = 1.0 / o.display_factor
        try:
            v = float(number)
        except ValueError as exc:
            raise ParameterError(f"margin {item!r}: {number!r} is not a number") from exc
        if not (math.isfinite(v) and v > 0.0):
            raise ParameterError(f"margin {item!r} must be a positive number")
        out[key] = v * factor
    return out


__all__ = [
    "DEFAULT_MARGINS",
    "GROUPS",
    "GROUP_ALL",
    "GROUP_CHANGED",
    "GROUP_UNKNOWN",
    "GROUP_FULL",
    "GROUP_SLIDING",
    "OUTCOMES",
    "TABLE1_OUTCOMES",
    "ComparedOutcome",
    "Comparison",
    "compare_database",
    "compare_tables",
    "contingency_to_dict",
    "load_model_config",
    "parse_margins",
    "read_run_table",
    "resolve_margins",
]
