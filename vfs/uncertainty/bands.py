"""Monte-Carlo bands of the collision outcomes and their summary statistics.

The Collision Calculation Uncertainty paper (Krzemien et al., uncertainty of vehicle
collision calculations) shows that impact speeds back-calculated from a Kudlich-Slibar
impact and a post-impact motion by different methods deviate by up to +-13 % even for a
documented crash test and up to +-28 % when the road friction is sampled; it samples the
unknowns uniformly by Monte-Carlo and keeps the combinations consistent with the rest
positions. :func:`run_uncertainty` propagates the uncertain inputs
(:mod:`vfs.uncertainty.config`, :mod:`vfs.uncertainty.sampling`) through the model
(:mod:`vfs.uncertainty.model`) and reports, per case and outcome, the median, the 5-95 %
band and the relative half-width (p95 - p5) / (2 median), the "+- %" of the Collision
Calculation Uncertainty paper; :func:`band_summary` and :func:`coverage` summarise the bands
over the cases.  SI units inside; km/h and degrees only in reports.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import pandas as pd

from vfs.blas import one_blas_thread
from vfs.physics.impact import IMPACT_FULL, IMPACT_NONE, IMPACT_SLIDING, impact_type_names
from vfs.uncertainty.cases import CaseSet, recorded_outcomes
from vfs.uncertainty.config import INPUT_NAMES, INPUTS, UncertaintyConfig, default_config
from vfs.uncertainty.model import evaluate, nominal_runs
from vfs.uncertainty.outcomes import OUTCOME_NAMES, OUTCOMES, SI_UNITS
from vfs.uncertainty.sampling import (
    DEFAULT_SAMPLING,
    ResolvedInputs,
    make_rng,
    resolve_inputs,
    sample_inputs,
)
from vfs.units import wrap_angle


def unwrap_circular(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Directions [rad] unwrapped to within pi of the reference (broadcast)."""
    return reference + wrap_angle(values - reference)


#: Quantiles of the band.
BAND = (0.05, 0.50, 0.95)


class UncertaintyResult(NamedTuple):
    """Result of :func:`run_uncertainty`.

    Attributes
    ----------
    bands : pandas.DataFrame
        One row per case and outcome (SI units): ``case_id``, ``outcome``,
        ``unit``, ``kind``, ``nominal_type``, ``nominal`` (the model at the
        nominal inputs), ``recorded`` (the reconstruction), ``mean``, ``sd``,
        ``p5``, ``p50``, ``p95``, ``half_width`` = (p95 - p5) / 2,
        ``rel_half_width`` = (p95 - p5) / (2 p50) (ratio outcomes only),
        ``n`` (finite samples), ``recorded_in_band``.
    cases : pandas.DataFrame
        One row per case: ``case_id``, ``accident_type``, ``road_surface``,
        ``recorded_type``, ``nominal_type``, ``p_full``, ``p_sliding``,
        ``p_none``, ``p_not_at_rest``, ``p_geometry_fallback``,
        ``penetration_nominal`` [s], ``penetration_estimated``.
    inputs : pandas.DataFrame
        The distribution of each input (text), how many cases use the
        database's sd, the share of clipped values.
    samples : pandas.DataFrame or None
        Every run (``sample``, ``case_id``, the inputs, the outcomes,
        ``impact_type``), when requested.
    n_samples : int
    seed : int or None
    seconds : float
        Wall time of sampling, model and statistics.
    config : UncertaintyConfig
    sampling : str
        Sampling method (:data:`vfs.uncertainty.sampling.SAMPLING_METHODS`).
    """

    bands: pd.DataFrame
    cases: pd.DataFrame
    inputs: pd.DataFrame
    samples: pd.DataFrame | None
    n_samples: int
    seed: int | None
    seconds: float
    config: UncertaintyConfig
    sampling: str = "random"

    def summary(self, by: str = "nominal_type") -> pd.DataFrame:
        """Relative half-widths over the cases (:func:`band_summary`)."""
        return band_summary(self.bands, by=by)


def input_table(resolved: ResolvedInputs, config: UncertaintyConfig,
                clipped: np.ndarray | None = None, n_runs: int = 0) -> pd.DataFrame:
    """Description of the input distributions actually used (for reports)."""
    rows = []
    for k, info in enumerate(INPUTS):
        spec = config.inputs[info.name]
        text = spec.distribution.describe()
        if spec.surface:
            text += "; " + "; ".join(f"{s}: {d.describe()}" for s, d in spec.surface.items())
        rows.append({
            "input": info.name, "label": info.label, "unit": info.unit,
            "distribution": text, "varied": bool(resolved.varied[k]),
            "database_sd_cases": int(resolved.from_database[k].sum()),
            "clipped_share": (float(clipped[k]) / n_runs) if clipped is not None and n_runs
            else 0.0,
            "description": info.description,
        })
    return pd.DataFrame(rows)


def _band_quantiles(values: np.ndarray) -> np.ndarray:
    """numpy.nanquantile at :data:`BAND` along axis 0 of (S, N) values, (3, N).

    The columns without NaN go through numpy.quantile in one call (the same
    interpolation, so the same numbers: nanquantile hands each NaN-free column
    to it one by one, which costs ten times more); only the others through
    nanquantile.
    """
    clean = ~np.isnan(values).any(axis=0)
    if clean.all():
        return np.quantile(values, BAND, axis=0)
    q = np.empty((len(BAND),) + values.shape[1:])
    q[:, clean] = np.quantile(values[:, clean], BAND, axis=0)
    q[:, ~clean] = np.nanquantile(values[:, ~clean], BAND, axis=0)
    return q


def _quantiles(values: np.ndarray, kind: str) -> dict[str, np.ndarray]:
    """Band statistics along axis 0 of (S, N) arrays (NaN-aware)."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices are reported as NaN
        q = _band_quantiles(values)
        mean = np.nanmean(values, axis=0)
        sd = np.nanstd(values, axis=0, ddof=1) if values.shape[0] > 1 else \
            np.full(values.shape[1:], np.nan)
    p5, p50, p95 = q
    half = 0.5 * (p95 - p5)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where((kind == "ratio") & (p50 > 0), half / np.where(p50 > 0, p50, 1.0),
                       np.nan)
    return {"mean": mean, "sd": sd, "p5": p5, "p50": p50, "p95": p95, "half_width": half,
            "rel_half_width": rel, "n": np.isfinite(values).sum(axis=0)}


@one_blas_thread
def run_uncertainty(cases: CaseSet, config: UncertaintyConfig | None = None,
                    n_samples: int = 1000, seed: int | np.random.Generator | None = 0,
                    keep_samples: bool = False, sampling: str = DEFAULT_SAMPLING,
                    ) -> UncertaintyResult:
    """Monte-Carlo bands of every outcome for every case.

    Parameters
    ----------
    cases : CaseSet
    config : UncertaintyConfig, optional
        Input distributions (default :func:`default_config`).
    n_samples : int
        Samples S per case (M = S x N model runs, solved as one vectorised batch).
    seed : int or numpy.random.Generator
        Source of all randomness (reproducible for an int seed).
    keep_samples : bool
        Also return every run as :attr:`UncertaintyResult.samples`.
    sampling : {"random", "sobol", "lhs"}
        Plain Monte Carlo or randomised quasi-Monte Carlo
        (:func:`vfs.uncertainty.sampling.unit_samples`); default
        :data:`vfs.uncertainty.sampling.DEFAULT_SAMPLING`.

    Returns
    -------
    UncertaintyResult
    """
    t0 = time.perf_counter()
    config = config or default_config()
    rng, seed_int = make_rng(seed)
    resolved = resolve_inputs(cases, config)
    x = sample_inputs(resolved, int(n_samples), rng, sampling)
    runs = evaluate(cases, x, config,
                    show=f"running the model for {cases.size} case(s) x {n_samples} samples")
    nom = nominal_runs(cases, config)
    rec = recorded_outcomes(cases)
    n, s = cases.size, int(n_samples)
    nominal_type = impact_type_names(nom.impact_type)
    frames = []
    for o in OUTCOMES:
        vals = runs.outcomes[o.name].reshape(s, n)
        nominal = nom.outcomes[o.name]
        recorded = rec[o.name]
        if o.kind == "circular":
            ref = np.where(np.isfinite(nominal), nominal, 0.0)
            vals = unwrap_circular(vals, ref[None, :])
            recorded = unwrap_circular(recorded, ref)
        q = _quantiles(vals, o.kind)
        frames.append(pd.DataFrame({
            "case_id": cases.case_id, "outcome": o.name, "unit": SI_UNITS[o.quantity],
            "kind": o.kind, "nominal_type": nominal_type, "nominal": nominal,
            "recorded": recorded, **q,
            "recorded_in_band": np.where(np.isfinite(recorded) & np.isfinite(q["p5"]),
                                         (recorded >= q["p5"]) & (recorded <= q["p95"]),
                                         np.nan),
        }))
    bands = pd.concat(frames, ignore_index=True)
    kind = runs.impact_type.reshape(s, n)
    rest = runs.at_rest.reshape(s, n, 2).all(axis=2)
    rtype = cases.reconstruction["impact_type"].astype(str).to_numpy() \
        if "impact_type" in cases.reconstruction.columns else np.full(n, "")
    case_table = pd.DataFrame({
        "case_id": cases.case_id, "accident_type": cases.accident_type,
        "road_surface": cases.road_surface, "recorded_type": rtype,
        "nominal_type": nominal_type,
        "p_full": (kind == IMPACT_FULL).mean(axis=0),
        "p_sliding": (kind == IMPACT_SLIDING).mean(axis=0),
        "p_none": (kind == IMPACT_NONE).mean(axis=0),
        "p_not_at_rest": (~rest).mean(axis=0),
        "p_geometry_fallback": runs.geometry_fallback.reshape(s, n).mean(axis=0),
        "penetration_nominal": cases.penetration,
        "penetration_estimated": cases.penetration_estimated,
    })
    samples = None
    if keep_samples:
        samples = pd.DataFrame(x.values, columns=list(INPUT_NAMES))
        samples.insert(0, "case_id", cases.case_id[x.rows])
        samples.insert(0, "sample", np.repeat(np.arange(s), n))
        for name in OUTCOME_NAMES:
            samples[name] = runs.outcomes[name]
        samples["impact_type"] = impact_type_names(runs.impact_type)
    inputs = input_table(resolved, config, x.clipped, x.rows.shape[0])
    return UncertaintyResult(bands, case_table, inputs, samples, s, seed_int,
                             time.perf_counter() - t0, config, sampling)


def band_summary(bands: pd.DataFrame, by: str | None = "nominal_type") -> pd.DataFrame:
    """Relative half-widths of the ratio outcomes summarised over the cases.

    Columns: ``outcome``, the group (``by``; ``all`` for every case),
    ``n_cases``, ``median_rel_half_width``, ``p90_rel_half_width``,
    ``max_rel_half_width``, ``median_half_width`` [SI], and the share of
    cases whose recorded value lies in the band (``recorded_in_band``).
    """
    data = bands[bands["kind"] != "indicator"]
    groups = [("all", data)]
    if by:
        groups += [(str(k), g) for k, g in data.groupby(by, sort=True)]
    rows = []
    for label, g in groups:
        for name, h in g.groupby("outcome", sort=False):
            rel = h["rel_half_width"].to_numpy(float)
            rel = rel[np.isfinite(rel)]
            inband = h["recorded_in_band"].to_numpy(float)
            inband = inband[np.isfinite(inband)]
            rows.append({
                "outcome": name, "group": label, "n_cases": len(h),
                "median_rel_half_width": float(np.median(rel)) if rel.size else np.nan,
                "p90_rel_half_width": float(np.quantile(rel, 0.9)) if rel.size else np.nan,
                "max_rel_half_width": float(rel.max()) if rel.size else np.nan,
                "median_half_width": float(np.nanmedian(h["half_width"])) if len(h) else np.nan,
                "recorded_in_band": float(inband.mean()) if inband.size else np.nan,
            })
    order = {name: k for k, name in enumerate(OUTCOME_NAMES)}
    out = pd.DataFrame(rows)
    out["_o"] = out["outcome"].map(order)
    return out.sort_values(["group", "_o"], kind="stable").drop(columns="_o").reset_index(
        drop=True)


def coverage(bands: pd.DataFrame, outcomes: Sequence[str] | None = None) -> pd.DataFrame:
    """Share of cases whose recorded value lies inside the 5-95 % band, per outcome.

    With a database whose reconstruction is the truth this is the coverage of
    the band (nominal 90 % when the input distributions describe the truth's
    deviation from the nominal values).
    """
    data = bands if outcomes is None else bands[bands["outcome"].isin(list(outcomes))]
    data = data[np.isfinite(data["recorded_in_band"].to_numpy(float))]
    return data.groupby("outcome", sort=False)["recorded_in_band"].agg(["mean", "count"]) \
        .rename(columns={"mean": "coverage", "count": "n_cases"}).reset_index()


__all__ = [
    "BAND", "UncertaintyResult", "band_summary", "coverage", "input_table", "run_uncertainty",
    "unwrap_circular",
]
