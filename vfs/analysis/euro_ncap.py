"""Euro NCAP AEB Car-to-Car assessment of a study on the test matrix (``--db euro-ncap-c2c``).

Pure functions over arrays and tables; the protocol (colour bands, points,
scenario maxima, measure of each scenario) comes from
``scenarios/euro-ncap-c2c/protocol.toml`` through
:func:`vfs.scenarios.euro_ncap.read_protocol`.

Per test and system: the measure the bands apply to (the VUT's impact speed, or
its impact speed relative to the GVT for rear tests with a moving target, or the
VUT's speed reduction for head-on tests), rounded to the 0.1 km/h of the
protocols' speed measurement; the colour band; the points.  Per scenario: the
maximum points times the mean points of its tests.  Total: the sum over the
scenarios.  Speeds in km/h here (the edge of the report), SI in the runs table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.errors import DataError, DataProblem
from vfs.scenarios.euro_ncap import MATRIX_COLUMNS, read_protocol
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


def assess_tests(runs: pd.DataFrame, cases: pd.DataFrame,
                 protocol: dict[str, Any] | None = None) -> pd.DataFrame:
    """Colour and points of every test and system of a study on the Euro NCAP matrix.

    Parameters
    ----------
    runs : pandas.DataFrame
        The study's runs table.
    cases : pandas.DataFrame
        The study's cases table (with the :data:`~vfs.scenarios.euro_ncap.MATRIX_COLUMNS`).
    protocol : dict, optional
        :func:`~vfs.scenarios.euro_ncap.read_protocol`'s result.

    Returns
    -------
    pandas.DataFrame
        One row per case and system (baseline included): ``scenario``,
        ``vut_speed_kmh``, ``gvt_speed_kmh``, ``overlap_pct``, the measures of
        :func:`run_measures`, ``measure_kmh`` (the one the scenario's bands use),
        ``colour``, ``points``.

    Raises
    ------
    DataError
        The cases are not the Euro NCAP matrix.
    """
    if not is_euro_ncap_cases(cases):
        raise DataError(DataProblem("cases", "", None, None,
                                    "not a study on the Euro NCAP matrix (no ncap_scenario "
                                    "column; run vfs study --db euro-ncap-c2c)"))
    protocol = read_protocol() if protocol is None else protocol
    cols = ["case_id", *[c for c in MATRIX_COLUMNS if c in cases.columns]]
    table = runs.merge(cases[cols], on="case_id", how="inner", validate="many_to_one")
    table = table[table["error"].fillna("").astype(str) == ""].reset_index(drop=True)
    measures = run_measures(table)
    assessment = protocol["assessment"]
    out = pd.DataFrame({
        "case_id": table["case_id"], "system": table["system"],
        "scenario": table["ncap_scenario"],
        "vut_speed_kmh": np.round(table["ncap_vut_speed"] * KMH_PER_MS, 6),
        "gvt_speed_kmh": np.round(table["ncap_gvt_speed"] * KMH_PER_MS, 6),
        "overlap_pct": np.round(100.0 * table["ncap_overlap"], 6),
        "collided": table["collided"].fillna(False).astype(bool),
        **{c: measures[c] for c in measures.columns}})
    out["measure_kmh"] = np.nan
    out["colour"] = ""
    for name, sc in protocol["scenarios"].items():
        rows = (out["scenario"] == name).to_numpy()
        if not rows.any():
            continue
        band = sc["band"]
        if band == "mitigation":
            value = out.loc[rows, "speed_reduction_kmh"].to_numpy()
            colours = band_colours(value, assessment["mitigation"]["reduction_bands"])
        else:
            value = out.loc[rows, f"{sc['measure'].removesuffix('_kmh')}_kmh"].to_numpy()
            if band == "avoidance":
                colours = band_colours(value, assessment["avoidance"]["bands"])
            else:
                row_speed = out.loc[rows, "vut_speed_kmh"].to_numpy()
                if sc.get("band_row", "vut_speed") == "relative_test_speed":
                    row_speed = row_speed - out.loc[rows, "gvt_speed_kmh"].to_numpy()
                colours = mitigation_or_avoidance_colours(
                    value, row_speed, assessment["mitigation_or_avoidance"])
        out.loc[rows, "measure_kmh"] = value
        out.loc[rows, "colour"] = colours
    out["points"] = points_of(out["colour"].to_numpy(), assessment["points"])
    return out


def scenario_scores(tests: pd.DataFrame, protocol: dict[str, Any] | None = None
                    ) -> pd.DataFrame:
    """Score of every scenario and system, and the total.

    Returns
    -------
    pandas.DataFrame
        ``system``, ``scenario`` (``"total"`` last), ``tests``, ``avoided``
        (tests without a collision), ``mean_points`` [-], ``score``, ``max_score``
        (protocol ``max_points``), ``score_pct``; one count per colour.
    """
    protocol = read_protocol() if protocol is None else protocol
    rows: list[dict[str, Any]] = []
    for system, of_system in tests.groupby("system", sort=False):
        total = {"score": 0.0, "max_score": 0.0, "tests": 0, "avoided": 0}
        for name, sc in protocol["scenarios"].items():
            sub = of_system[of_system["scenario"] == name]
            if sub.empty:
                continue
            mean = float(sub["points"].mean())
            top = float(sc["max_points"])
            row = {"system": system, "scenario": name, "tests": len(sub),
                   "avoided": int((~sub["collided"]).sum()), "mean_points": mean,
                   "score": top * mean, "max_score": top,
                   **{c: int((sub["colour"] == c).sum()) for c in COLOURS}}
            rows.append(row)
            for k in ("score", "max_score", "tests", "avoided"):
                total[k] += row[k]
        rows.append({"system": system, "scenario": "total", **total,
                     "mean_points": math.nan,
                     **{c: int((of_system["colour"] == c).sum()) for c in COLOURS}})
    table = pd.DataFrame(rows)
    table["score_pct"] = 100.0 * table["score"] / table["max_score"]
    return table


def speed_grid(tests: pd.DataFrame, system: str, scenario: str) -> pd.DataFrame:
    """One scenario's colours as a VUT speed x (overlap, GVT speed) grid of one system."""
    sub = tests[(tests["system"] == system) & (tests["scenario"] == scenario)]
    if sub.empty:
        return pd.DataFrame()
    label = sub["gvt_speed_kmh"].map(lambda g: f"GVT {g:g}") + " / " + sub["overlap_pct"].map(
        lambda o: f"{o:+g} %")
    cell = sub["colour"] + " " + sub["measure_kmh"].map(lambda v: f"{v:.1f}")
    return pd.DataFrame({"vut": sub["vut_speed_kmh"], "col": label, "cell": cell}).pivot_table(
        index="vut", columns="col", values="cell", aggfunc="first", sort=False)


__all__ = ["COLOURS", "SPEED_RESOLUTION_KMH", "assess_tests", "band_colours",
           "is_euro_ncap_cases", "mitigation_or_avoidance_colours", "points_of",
           "scenario_scores", "speed_grid", "speed_row", "run_measures"]
