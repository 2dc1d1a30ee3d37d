"""Euro NCAP AEB Car-to-Car assessment of a study on the test matrix (``--db euro-ncap-c2c``).

Pure functions over arrays and tables; the protocol (colour bands, points,
scenario maxima, measure of each scenario) comes from the protocol file of the
version the study's cases name (``ncap_protocol``: 2026 ``protocol.toml``, 2023
``protocol-2023.toml``) through :func:`vfs.scenarios.euro_ncap.read_protocol`.

Per test and system (the rules of Euro NCAP's 2026 rating tool,
``crash_avoidance/matrix_processing.py``): the measure the bands apply to (the
VUT's impact speed, or its impact speed relative to the GVT for rear tests with
a moving target, or the VUT's speed reduction for head-on tests), rounded to the
0.1 km/h of the protocols' speed measurement; the colour band, whose row is the
VUT's test speed (CCRm too); avoidance tests (CCFtap, CCCscp) are red on any
contact, a VUT hit while standing included (it entered the GVT's path); the
points.  Per scenario: the maximum points times the mean points of its tests
(``test_info``).  Total: the sum over the scenarios.  The forward-collision
warning's TTC is reported per test (the undisturbed impact time minus the
warning time); neither version's file scores it for Car-to-Car.  Speeds in km/h
here (the edge of the report), SI in the runs table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.errors import DataError, DataProblem
from vfs.scenarios.euro_ncap import MATRIX_COLUMNS, PROTOCOL_VERSIONS, read_protocol
from vfs.units import KMH_PER_MS

#: Colours from best to worst.
COLOURS = ("green", "yellow", "orange", "brown", "red")

#: Resolution of the protocols' speed measurement [km/h] (0.1 km/h); measures are rounded to it.
SPEED_RESOLUTION_KMH = 0.1


def is_euro_ncap_cases(cases: pd.DataFrame) -> bool:
    """True for a cases table of the Euro NCAP matrix (it carries ``ncap_scenario``)."""
    return "ncap_scenario" in cases.columns


def band_colours(values: npt.ArrayLike, bands: Sequence[Sequence[Any]]) -> np.ndarray:
    """Colour of each value by ``bands`` (``[[colour, upper bound], ...]``, bounds inclusive).

    >>> band_colours([0.0, 5.0, 50.0], [["green", 0.0], ["brown", 10.0], ["red", math.inf]])
    array(['green', 'brown', 'red'], dtype=object)
    """
    v = np.asarray(values, dtype=float)
    out = np.full(v.shape, bands[-1][0], dtype=object)
    done = np.zeros(v.shape, dtype=bool)
    for colour, upper in bands:
        hit = ~done & (v <= float(upper))
        out[hit] = colour
        done |= hit
    return out


def speed_row(vut_speed_kmh: float, rows: Sequence[float]) -> float:
    """The band row of a VUT test speed: the largest row at or below it (the first row below all).

    >>> speed_row(15.0, [10, 20, 30, 40, 50]), speed_row(80.0, [10, 20, 30, 40, 50])
    (10, 50)
    """
    below = [r for r in sorted(rows) if r <= vut_speed_kmh + 1e-9]
    return below[-1] if below else sorted(rows)[0]


def mitigation_or_avoidance_colours(impact_speed_kmh: npt.ArrayLike,
                                    vut_speed_kmh: npt.ArrayLike,
                                    table: Mapping[str, Sequence[Sequence[Any]]]) -> np.ndarray:
    """Colours of impact speeds [km/h] by the bands of each VUT test speed [km/h]."""
    rows = {float(k): v for k, v in table.items()}
    iv = np.asarray(impact_speed_kmh, dtype=float)
    vv = np.broadcast_to(np.asarray(vut_speed_kmh, dtype=float), iv.shape)
    out = np.empty(iv.shape, dtype=object)
    for i in np.ndindex(iv.shape):
        out[i] = band_colours([iv[i]], rows[speed_row(float(vv[i]), list(rows))])[0]
    return out


def points_of(colours: npt.ArrayLike, points: Mapping[str, float]) -> np.ndarray:
    """Points of each colour (protocol ``[assessment] points``)."""
    c = np.asarray(colours, dtype=object)
    return np.array([float(points[str(k)]) for k in c.ravel()], dtype=float).reshape(c.shape)


def run_measures(runs: pd.DataFrame) -> pd.DataFrame:
    """VUT impact speed, relative impact speed and speed reduction of each run [km/h].

    Parameters
    ----------
    runs : pandas.DataFrame
        Study runs (``collided``, ``impact_speed1``, ``vx1``, ``vy1``, ``vx2``,
        ``vy2`` [m/s]) joined with the cases' ``ncap_vut_speed`` [m/s].

    Returns
    -------
    pandas.DataFrame
        ``vut_impact_speed_kmh`` (0 without a collision), ``relative_impact_speed_kmh``
        (the closing speed along the VUT's velocity, >= 0), ``speed_reduction_kmh``
        (test speed minus VUT impact speed), all rounded to 0.1 km/h.
    """
    hit = runs["collided"].fillna(False).to_numpy(dtype=bool)
    v1 = np.where(hit, runs["impact_speed1"].to_numpy(dtype=float, na_value=np.nan), 0.0)
    vx1, vy1 = (runs[c].to_numpy(dtype=float, na_value=0.0) for c in ("vx1", "vy1"))
    vx2, vy2 = (runs[c].to_numpy(dtype=float, na_value=0.0) for c in ("vx2", "vy2"))
    norm = np.hypot(vx1, vy1)
    ux = np.divide(vx1, norm, out=np.zeros_like(norm), where=norm > 0)
    uy = np.divide(vy1, norm, out=np.zeros_like(norm), where=norm > 0)
    rel = np.where(hit, np.maximum((vx1 - vx2) * ux + (vy1 - vy2) * uy, 0.0), 0.0)
    test = runs["ncap_vut_speed"].to_numpy(dtype=float)

    def kmh(values: np.ndarray) -> np.ndarray:
        step = SPEED_RESOLUTION_KMH
        return np.round(np.round(values * KMH_PER_MS / step) * step, 1)

    return pd.DataFrame({"vut_impact_speed_kmh": kmh(v1),
                         "relative_impact_speed_kmh": kmh(rel),
                         "speed_reduction_kmh": kmh(test - v1)}, index=runs.index)


def fcw_ttc(runs: pd.DataFrame) -> np.ndarray:
    """TTC [s] of the forward-collision warning: undisturbed impact time minus warning time.

    The warning precedes any braking, so until it the VUT follows the
    undisturbed record and this is the record's time to collision at the
    warning.  NaN where the system gave no warning (or the runs have no
    ``warning_time1`` / the cases no ``ncap_impact_time``).
    """
    if "warning_time1" not in runs.columns or "ncap_impact_time" not in runs.columns:
        return np.full(len(runs), np.nan)
    warn = runs["warning_time1"].to_numpy(dtype=float, na_value=np.nan)
    return runs["ncap_impact_time"].to_numpy(dtype=float, na_value=np.nan) - warn


def protocols_of(cases: pd.DataFrame) -> dict[str, dict[str, Any]]:
    """The protocol of every version the cases name (column ``ncap_protocol``).

    Raises
    ------
    DataError
        No ``ncap_protocol`` column (a study on a build of the matrix before the
        versions; rerun it), or an unknown version.
    """
    if "ncap_protocol" not in cases.columns:
        raise DataError(DataProblem("cases", "ncap_protocol", None, None,
                                    "the study's cases do not name their Euro NCAP protocol "
                                    "version (a study on an older build of the matrix): rerun "
                                    "it on --db euro-ncap-c2c (2026) or euro-ncap-c2c-2023"))
    versions = sorted(set(cases["ncap_protocol"].astype(str)))
    unknown = [v for v in versions if v not in PROTOCOL_VERSIONS]
    if unknown:
        raise DataError(DataProblem("cases", "ncap_protocol", None, None,
                                    f"unknown Euro NCAP protocol version(s) {unknown}; known: "
                                    f"{', '.join(PROTOCOL_VERSIONS)}"))
    return {v: read_protocol(version=v) for v in versions}


#: Columns of the per-test result sheet (:func:`assess_tests`), in order.
TEST_COLUMNS = ("case_id", "system", "protocol", "scenario", "vut_speed_kmh", "gvt_speed_kmh",
                "overlap_pct", "impact_location_pct", "gvt_impact_location_pct", "gvt_side",
                "gvt_deceleration_ms2", "headway_m", "collided", "vut_impact_speed_kmh",
                "relative_impact_speed_kmh", "speed_reduction_kmh", "measure",
                "measure_kmh", "colour", "points", "fcw_ttc_s")


def assess_tests(runs: pd.DataFrame, cases: pd.DataFrame,
                 protocol: dict[str, Any] | None = None) -> pd.DataFrame:
    """Colour and points of every test and system of a study on a Euro NCAP matrix.

    Parameters
    ----------
    runs : pandas.DataFrame
        The study's runs table.
    cases : pandas.DataFrame
        The study's cases table (with the :data:`~vfs.scenarios.euro_ncap.MATRIX_COLUMNS`).
    protocol : dict, optional
        :func:`~vfs.scenarios.euro_ncap.read_protocol`'s result; default the file of
        the version the cases name.

    Returns
    -------
    pandas.DataFrame
        One row per case and system (baseline included), :data:`TEST_COLUMNS`:
        test parameters (km/h, %, m/s^2, m), the measures of :func:`run_measures`,
        ``measure`` (which one the scenario's bands use) and its value
        ``measure_kmh``, ``colour``, ``points``, ``fcw_ttc_s`` [s].

    Raises
    ------
    DataError
        The cases are not a Euro NCAP matrix, or name no or an unknown version.
    """
    if not is_euro_ncap_cases(cases):
        raise DataError(DataProblem("cases", "", None, None,
                                    "not a study on the Euro NCAP matrix (no ncap_scenario "
                                    "column; run vfs study --db euro-ncap-c2c)"))
    protocols = ({str(protocol["protocol"]["version"]): protocol} if protocol is not None
                 else protocols_of(cases))
    cols = ["case_id", *[c for c in MATRIX_COLUMNS if c in cases.columns]]
    table = runs.merge(cases[cols], on="case_id", how="inner", validate="many_to_one")
    table = table[table["error"].fillna("").astype(str) == ""].reset_index(drop=True)
    if "ncap_protocol" not in table.columns:
        table["ncap_protocol"] = next(iter(protocols))
    measures = run_measures(table)

    def col(name: str, scale: float = 1.0) -> np.ndarray:
        if name not in table.columns:
            return np.full(len(table), np.nan)
        return np.round(table[name].to_numpy(dtype=float, na_value=np.nan) * scale, 6)

    out = pd.DataFrame({
        "case_id": table["case_id"], "system": table["system"],
        "protocol": table["ncap_protocol"].astype(str), "scenario": table["ncap_scenario"],
        "vut_speed_kmh": col("ncap_vut_speed", KMH_PER_MS),
        "gvt_speed_kmh": col("ncap_gvt_speed", KMH_PER_MS),
        "overlap_pct": col("ncap_overlap", 100.0),
        "impact_location_pct": col("ncap_lateral_location", 100.0),
        "gvt_impact_location_pct": col("ncap_impact_location", 100.0),
        "gvt_side": col("ncap_gvt_side"),
        "gvt_deceleration_ms2": col("ncap_gvt_deceleration"),
        "headway_m": col("ncap_headway"),
        "collided": table["collided"].fillna(False).astype(bool),
        **{c: measures[c] for c in measures.columns}})
    out["measure"] = ""
    out["measure_kmh"] = np.nan
    out["colour"] = ""
    out["points"] = np.nan
    for version, proto in protocols.items():
        assessment = proto["assessment"]
        for name, sc in proto["scenarios"].items():
            rows = ((out["scenario"] == name) & (out["protocol"] == version)).to_numpy()
            if not rows.any():
                continue
            band = sc["band"]
            measure = sc["measure"].removesuffix("_kmh")
            value = out.loc[rows, f"{measure}_kmh"].to_numpy()
            if band == "mitigation":
                colours = band_colours(value, assessment["mitigation"]["reduction_bands"])
            elif band == "avoidance":
                # any contact is red: a VUT hit while standing entered the GVT's path
                contact = out.loc[rows, "collided"].to_numpy(dtype=bool)
                colours = band_colours(np.where(contact, np.inf, 0.0),
                                       assessment["avoidance"]["bands"])
            else:  # mitigation_or_avoidance: the row is the VUT's test speed (CCRm too)
                colours = mitigation_or_avoidance_colours(
                    value, out.loc[rows, "vut_speed_kmh"].to_numpy(),
                    assessment["mitigation_or_avoidance"])
            out.loc[rows, "measure"] = measure
            out.loc[rows, "measure_kmh"] = value
            out.loc[rows, "colour"] = colours
            out.loc[rows, "points"] = points_of(colours, assessment["points"])
    out["fcw_ttc_s"] = np.round(fcw_ttc(table), 3)
    return out[list(TEST_COLUMNS)]


def scenario_scores(tests: pd.DataFrame, protocol: dict[str, Any] | None = None
                    ) -> pd.DataFrame:
    """Score of every scenario and system, and the total.

    Returns
    -------
    pandas.DataFrame
        ``system``, ``protocol``, ``scenario`` (``"total"`` last), ``tests``,
        ``avoided`` (tests without a collision), ``mean_points`` [-],
        ``score``, ``max_score`` (protocol ``max_points``), ``score_pct``; one
        count per colour.
    """
    rows: list[dict[str, Any]] = []
    for (system, version), of_system in tests.groupby(["system", "protocol"], sort=False):
        proto = protocol if protocol is not None else read_protocol(version=str(version))
        total = {"score": 0.0, "max_score": 0.0, "tests": 0, "avoided": 0}
        for name, sc in proto["scenarios"].items():
            sub = of_system[of_system["scenario"] == name]
            if sub.empty:
                continue
            mean = float(sub["points"].mean())
            top = float(sc["max_points"])
            row = {"system": system, "protocol": version, "scenario": name,
                   "tests": len(sub), "avoided": int((~sub["collided"]).sum()),
                   "mean_points": mean, "score": top * mean, "max_score": top,
                   **{c: int((sub["colour"] == c).sum()) for c in COLOURS}}
            rows.append(row)
            for k in ("score", "max_score", "tests", "avoided"):
                total[k] += row[k]
        rows.append({"system": system, "protocol": version, "scenario": "total", **total,
                     "mean_points": math.nan,
                     **{c: int((of_system["colour"] == c).sum()) for c in COLOURS}})
    table = pd.DataFrame(rows)
    table["score_pct"] = 100.0 * table["score"] / table["max_score"]
    return table


def grid_column_label(test: pd.Series, with_gvt: bool = True) -> str:
    """The column of a test in its scenario's grid: GVT speed and lateral position or braking."""
    parts = [f"GVT {test['gvt_speed_kmh']:g}"] if with_gvt else []
    if not math.isnan(test["impact_location_pct"]):
        parts.append(f"IL {test['impact_location_pct']:g} %")
    elif not math.isnan(test["overlap_pct"]):
        parts.append(f"ov {test['overlap_pct']:+g} %")
    if not math.isnan(test["gvt_deceleration_ms2"]):
        parts.append(f"{test['gvt_deceleration_ms2']:g} m/s2 {test['headway_m']:g} m")
    if not math.isnan(test.get("gvt_side", math.nan)):
        parts.append("from right" if test["gvt_side"] > 0 else "from left")
    return " / ".join(parts) or "-"


def speed_grid(tests: pd.DataFrame, system: str, scenario: str
               ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """One scenario's grid of one system, as the rating tool lays out its matrices.

    Rows: the VUT speed [km/h] (with the GVT speed where each VUT speed has
    one, as in the head-on and rear tests); columns: :func:`grid_column_label`.

    Returns
    -------
    (values, colours) : pandas.DataFrame, pandas.DataFrame
        The measure [km/h] per cell (formatted ``"12.3"``) and its colour, indexed
        by the row label; empty frames when the system has no test of the
        scenario.  A cell without a test (N/A in the protocol's matrix) is empty.
    """
    sub = tests[(tests["system"] == system) & (tests["scenario"] == scenario)]
    if sub.empty:
        return pd.DataFrame(), pd.DataFrame()
    one_gvt = bool(sub.groupby("vut_speed_kmh")["gvt_speed_kmh"].nunique().max() == 1)
    rows = [f"{v:g} / GVT {g:g}" if one_gvt else f"{v:g}"
            for v, g in zip(sub["vut_speed_kmh"], sub["gvt_speed_kmh"], strict=True)]
    frame = pd.DataFrame({"row": rows,
                          "col": [grid_column_label(r, not one_gvt) for _, r in sub.iterrows()],
                          "value": sub["measure_kmh"].map(lambda v: f"{v:.1f}").to_numpy(),
                          "colour": sub["colour"].to_numpy()})
    values = frame.pivot_table(index="row", columns="col", values="value", aggfunc="first",
                               sort=False)
    colours = frame.pivot_table(index="row", columns="col", values="colour",
                                aggfunc="first", sort=False)
    return values.fillna(""), colours.fillna("")


__all__ = ["COLOURS", "SPEED_RESOLUTION_KMH", "TEST_COLUMNS", "assess_tests", "band_colours",
           "fcw_ttc", "grid_column_label", "is_euro_ncap_cases",
           "mitigation_or_avoidance_colours", "points_of", "protocols_of", "run_measures",
           "scenario_scores", "speed_grid", "speed_row"]
