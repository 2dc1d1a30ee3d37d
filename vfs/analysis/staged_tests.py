"""Staged tests in ``vfs compare``: the model's delta-v, heading-change and rest-position errors
per test and vehicle, beside other codes' published errors on the same tests.

Definitions: docs/compare.md, "Staged tests".
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from vfs.database.schema import OUTCOME_MEASUREMENT
from vfs.units import wrap_angle

#: Prefix of the reconstruction's extra columns that hold another code's published error on
#: a staged test: ``paper_<code>_<metric>{i}``, metric one of :data:`STAGED_METRICS`.
PAPER_ERROR_PREFIX = "paper_"
#: The staged-test error metrics (columns of :attr:`Comparison.staged`), with their units.
STAGED_METRICS: dict[str, str] = {
    "delta_v_error": "-",  # |model - measured| / measured delta-v
    "heading_change_error": "rad",  # |model - measured| change of heading, impact to rest
    "range_error": "-",  # |model rest - measured rest| / measured impact-to-rest distance
}


def staged_test_errors(reconstruction: pd.DataFrame, vfs: pd.DataFrame) -> pd.DataFrame:
    """Per staged test and vehicle: the model's delta-v, heading-change and rest-position errors.

    For the reconstruction rows with ``outcome_source = measurement`` (instrumented or
    staged tests) and each vehicle i:

    * ``delta_v_error`` = |delta_v (model) - delta_v (measured)| / delta_v (measured) [-];
    * ``heading_change_error`` = |wrap((rest_yaw - yaw) model - (rest_yaw - yaw)
      measured)| [rad], the change of heading from the impact to rest, each from its own
      impact pose;
    * ``range_error`` = |rest (model) - rest (measured)| / |rest (measured) - CG at
      impact (measured)| [-], the rest-position error in units of the measured run-out.

    NaN where a value was not measured.  Extra reconstruction columns
    ``paper_<code>_<metric>{i}`` (a published error of another code on the same test) are
    carried as ``<code>_<metric>``.

    Parameters
    ----------
    reconstruction : pandas.DataFrame
        Normalised reconstruction table (SI; angles in rad).
    vfs : pandas.DataFrame
        The simulation's results table (:func:`vfs.simulation.results_table`).

    Returns
    -------
    pandas.DataFrame
        ``case_id``, ``vehicle``, measured and model ``delta_v`` [m/s],
        ``heading_change`` [rad], ``runout_range`` [m] (measured impact-to-rest
        distance), ``rest_distance`` [m], the three errors and the papers' errors.
    """
    base = ["case_id", "vehicle", "measured_delta_v", "model_delta_v", "delta_v_error",
            "measured_heading_change", "model_heading_change", "heading_change_error",
            "runout_range", "rest_distance", "range_error"]
    if "outcome_source" not in reconstruction.columns:
        return pd.DataFrame(columns=base)
    rec = reconstruction[reconstruction["outcome_source"] == OUTCOME_MEASUREMENT]
    if rec.empty:
        return pd.DataFrame(columns=base)
    ids = rec["case_id"].to_numpy()
    model = vfs.drop_duplicates("case_id").set_index("case_id").reindex(ids)

    def col(df: pd.DataFrame, name: str) -> np.ndarray:
        if name not in df.columns:
            return np.full(len(df), np.nan)
        return pd.to_numeric(df[name], errors="coerce").to_numpy(float)

    paper = sorted({c[len(PAPER_ERROR_PREFIX):-1] for c in rec.columns
                    if c.startswith(PAPER_ERROR_PREFIX) and c[-1:] in ("1", "2")
                    and any(c[:-1].endswith(m) for m in STAGED_METRICS)})
    frames = []
    for i in (1, 2):
        dv_m, dv_s = col(rec, f"delta_v{i}"), col(model, f"delta_v{i}")
        turn_m = col(rec, f"rest_yaw{i}") - col(rec, f"yaw{i}")
        turn_s = col(model, f"rest_yaw{i}") - col(model, f"yaw{i}")
        rest_m = np.stack([col(rec, f"rest_x{i}"), col(rec, f"rest_y{i}")], axis=1)
        rest_s = np.stack([col(model, f"rest_x{i}"), col(model, f"rest_y{i}")], axis=1)
        start = np.stack([col(rec, f"x{i}"), col(rec, f"y{i}")], axis=1)
        runout = np.hypot(*(rest_m - start).T)
        miss = np.hypot(*(rest_s - rest_m).T)
        with np.errstate(divide="ignore", invalid="ignore"):
            frame = {
                "case_id": ids, "vehicle": i,
                "measured_delta_v": dv_m, "model_delta_v": dv_s,
                "delta_v_error": np.abs(dv_s - dv_m) / dv_m,
                "measured_heading_change": turn_m, "model_heading_change": turn_s,
                "heading_change_error": np.abs(wrap_angle(turn_s - turn_m)),
                "runout_range": runout, "rest_distance": miss,
                "range_error": np.where(runout > 0.0, miss / runout, np.nan),
            }
        for name in paper:
            frame[name] = col(rec, f"{PAPER_ERROR_PREFIX}{name}{i}")
        frames.append(pd.DataFrame(frame))
    return pd.concat(frames, ignore_index=True).sort_values(["case_id", "vehicle"],
                                                            ignore_index=True)


def staged_summary(staged: pd.DataFrame) -> pd.DataFrame:
    """Mean of each error over the tests and vehicles that have it: ``code`` ("vfs" or a
    paper's code), ``metric``, ``n``, ``mean`` (SI: fractions and rad).
    """
    rows = []
    for metric in STAGED_METRICS:
        for name in staged.columns:
            if name != metric and not name.endswith("_" + metric):
                continue
            values = pd.to_numeric(staged[name], errors="coerce").to_numpy(float)
            ok = np.isfinite(values)
            code = "vfs" if name == metric else name[: -len(metric) - 1]
            rows.append({"code": code, "metric": metric, "n": int(ok.sum()),
                         "mean": float(values[ok].mean()) if ok.any() else float("nan")})
    return pd.DataFrame(rows, columns=["code", "metric", "n", "mean"])
