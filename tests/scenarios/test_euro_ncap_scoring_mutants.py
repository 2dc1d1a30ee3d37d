"""Euro NCAP scoring written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): measures for a VUT driving in any direction,
the band row by VUT minus GVT speed (CCRm), several scenarios and systems in one table,
the rounding to the protocol's 0.1 km/h, and the totals.  Expected colours follow from the
protocol file's bands (scenarios/euro-ncap-c2c/protocol.toml), read here, not typed in.
"""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from vfs.analysis.euro_ncap import (
    COLOURS,
    assess_tests,
    band_colours,
    is_euro_ncap_cases,
    mitigation_or_avoidance_colours,
    points_of,
    run_measures,
    scenario_scores,
    speed_row,
)
from vfs.errors import DataError
from vfs.scenarios.euro_ncap import ncap_test_matrix, read_protocol
from vfs.units import KMH_PER_MS

PROTOCOL = read_protocol()
MATRIX = ncap_test_matrix(PROTOCOL)
BANDS = PROTOCOL["assessment"]["mitigation_or_avoidance"]
POINTS = PROTOCOL["assessment"]["points"]


def measures(vut_kmh: float, impact_kmh: float, gvt_kmh: float, heading: float,
             gvt_heading: float | None = None, collided: bool = True) -> pd.Series:
    """run_measures of one run: VUT and GVT velocity vectors at ``heading`` [rad]."""
    g = heading if gvt_heading is None else gvt_heading
    v1, v2 = impact_kmh / KMH_PER_MS, gvt_kmh / KMH_PER_MS
    runs = pd.DataFrame({"collided": [collided], "impact_speed1": [v1 if collided else np.nan],
                         "vx1": [v1 * np.cos(heading)], "vy1": [v1 * np.sin(heading)],
                         "vx2": [v2 * np.cos(g)], "vy2": [v2 * np.sin(g)],
                         "ncap_vut_speed": [vut_kmh / KMH_PER_MS]})
    return run_measures(runs).iloc[0]


@pytest.mark.parametrize("heading", [0.0, np.pi / 2, np.pi, -2.3, 0.7])
def test_relative_impact_speed_in_every_direction(heading: float) -> None:
    """The closing speed along the VUT's velocity does not depend on the heading."""
    got = measures(50.0, 36.0, 18.0, heading)
    assert got["vut_impact_speed_kmh"] == pytest.approx(36.0)
    assert got["relative_impact_speed_kmh"] == pytest.approx(18.0)
    assert got["speed_reduction_kmh"] == pytest.approx(14.0)
    # a GVT crossing at right angles adds nothing along the VUT's direction
    assert measures(50.0, 36.0, 30.0, heading, heading + np.pi / 2)[
        "relative_impact_speed_kmh"] == pytest.approx(36.0)
    # an oncoming GVT adds its speed; one faster ahead gives 0 (not negative)
    assert measures(50.0, 36.0, 20.0, heading, heading + np.pi)[
        "relative_impact_speed_kmh"] == pytest.approx(56.0)
    assert measures(50.0, 20.0, 30.0, heading)["relative_impact_speed_kmh"] == 0.0


def test_measures_without_collision_and_rounding() -> None:
    none = measures(50.0, 30.0, 10.0, 0.4, collided=False)
    assert none["vut_impact_speed_kmh"] == 0.0 and none["relative_impact_speed_kmh"] == 0.0
    assert none["speed_reduction_kmh"] == pytest.approx(50.0)
    # rounded to the 0.1 km/h of the speed measurement
    assert measures(50.0, 36.04, 0.0, 0.0)["vut_impact_speed_kmh"] == pytest.approx(36.0)
    assert measures(50.0, 36.06, 0.0, 0.0)["vut_impact_speed_kmh"] == pytest.approx(36.1)
    assert measures(50.0, 36.06, 0.0, 0.0)["speed_reduction_kmh"] == pytest.approx(13.9)
    # a VUT at rest: no direction, no relative speed; a missing collided flag is no collision
    runs = pd.DataFrame({"collided": [None, True], "impact_speed1": [5.0, 0.0],
                         "vx1": [1.0, 0.0], "vy1": [0.0, 0.0], "vx2": [0.0, -3.0],
                         "vy2": [0.0, 0.0], "ncap_vut_speed": [10.0, 10.0]})
    got = run_measures(runs)
    assert got["vut_impact_speed_kmh"].tolist() == [0.0, 0.0]
    assert got["relative_impact_speed_kmh"].tolist() == [0.0, 0.0]
    # missing velocities count as 0: no VUT direction (relative 0); a GVT at rest
    runs = pd.DataFrame({"collided": [True, True], "impact_speed1": [10.0, 10.0],
                         "vx1": [np.nan, 0.0], "vy1": [np.nan, -10.0], "vx2": [2.0, np.nan],
                         "vy2": [-3.0, np.nan], "ncap_vut_speed": [12.0, 12.0]})
    got = run_measures(runs)
    assert got["relative_impact_speed_kmh"].tolist() == [0.0, 36.0]
    assert got["speed_reduction_kmh"].tolist() == [7.2, 7.2]


def test_speed_rows_and_band_edges() -> None:
    rows = [30, 10, 50, 20, 40]  # unsorted on purpose
    assert speed_row(5.0, rows) == 10  # below all: the first row
    assert speed_row(30.0, rows) == 30 and speed_row(29.9999, rows) == 20
    assert speed_row(30.0 - 1e-12, rows) == 30  # measurement noise below the row
    assert (30.0 - 1e-9) + 1e-9 == 30.0  # the slack's edge is included (closed)
    assert speed_row(30.0 - 1e-9, rows) == 30
    assert speed_row(200.0, rows) == 50
    bands = [["green", 0.0], ["brown", 10.0], ["red", np.inf]]
    np.testing.assert_array_equal(band_colours([0.0, 1e-9, 10.0, 10.0 + 1e-9], bands),
                                  ["green", "brown", "brown", "red"])
    # values above every bound fall into the last band's colour
    three = [["green", 0.0], ["yellow", 5.0], ["brown", 10.0]]
    assert band_colours([11.0, 3.0], three).tolist() == ["brown", "yellow"]
    # element-wise rows: each value by its own VUT speed
    got = mitigation_or_avoidance_colours([5.0, 5.0, 5.0], [50.0, 40.0, 30.0], BANDS)
    assert got.tolist() == [band_colours([5.0], BANDS[str(v)])[0] for v in (50, 40, 30)]
    assert got.tolist() == ["yellow", "orange", "brown"]


def case_of(scenario: str, vut_kmh: float, gvt_kmh: float | None = None) -> int:
    m = MATRIX[(MATRIX["ncap_scenario"] == scenario)
               & np.isclose(MATRIX["ncap_vut_speed"] * KMH_PER_MS, vut_kmh)]
    if gvt_kmh is not None:
        m = m[np.isclose(m["ncap_gvt_speed"] * KMH_PER_MS, gvt_kmh)]
    return int(m["case_id"].iloc[0])


def runs_for(rows: list[tuple[int, str, float, float]]) -> pd.DataFrame:
    """Runs (case id, system, VUT impact speed [km/h], GVT speed [km/h]); the VUT drives
    along -y (south) with the GVT ahead in the same direction."""
    out = []
    for case_id, system, impact, gvt in rows:
        v, g = impact / KMH_PER_MS, gvt / KMH_PER_MS
        out.append({"case_id": case_id, "system": system, "error": "", "collided": impact > 0,
                    "impact_speed1": v if impact > 0 else np.nan, "vx1": 0.0, "vy1": -v,
                    "vx2": 0.0, "vy2": -g})
    return pd.DataFrame(out)


def test_several_scenarios_and_systems_in_one_assessment() -> None:
    cases = MATRIX.drop(columns=["kind", "accident_type"])
    ccrs = case_of("CCRs", 50.0)
    ccrm = case_of("CCRm", 50.0, 20.0)  # band row by VUT minus GVT speed: 30 km/h
    tap = case_of("CCFtap", 20.0)
    hos = case_of("CCFhos", 50.0)
    rows = [
        (ccrs, "aeb", 15.0, 0.0),  # 50 km/h row: 15 -> orange
        (ccrm, "aeb", 25.0, 20.0),  # relative 5 on the 30 km/h row: brown (50 row: yellow)
        (tap, "aeb", 0.0, 0.0),  # avoided: green
        (hos, "aeb", 35.0, 0.0),  # reduction 15: orange
        (ccrs, "none", 50.0, 0.0),  # 50 on the 50 row: red
        (ccrm, "none", 50.0, 20.0),  # relative 30 on the 30 row: red
        (tap, "none", 20.0, 0.0),  # any impact: red
        (hos, "none", 20.0, 0.0),  # reduction 30: green
    ]
    runs = runs_for(rows)
    runs.loc[len(runs)] = {**runs.iloc[0].to_dict(), "error": "diverged"}  # dropped
    tests = assess_tests(runs, cases, PROTOCOL)
    assert len(tests) == 8
    # CCRm's band row: by VUT minus GVT speed (30 km/h) or by the VUT speed (50 km/h), as the
    # protocol file says
    by_relative = PROTOCOL["scenarios"]["CCRm"].get("band_row") == "relative_test_speed"
    ccrm_row = "30" if by_relative else "50"
    expected = [
        band_colours([15.0], BANDS["50"])[0], band_colours([5.0], BANDS[ccrm_row])[0], "green",
        band_colours([15.0], PROTOCOL["assessment"]["mitigation"]["reduction_bands"])[0],
        "red", band_colours([30.0], BANDS[ccrm_row])[0], "red", "green"]
    assert [expected[k] for k in (0, 2, 3, 4, 6, 7)] == ["orange", "green", "orange", "red",
                                                          "red", "green"]
    assert tests["colour"].tolist() == expected
    np.testing.assert_allclose(tests["measure_kmh"], [15.0, 5.0, 0.0, 15.0, 50.0, 30.0, 20.0,
                                                      30.0])
    np.testing.assert_array_equal(tests["points"], points_of(expected, POINTS))
    assert tests["scenario"].tolist() == ["CCRs", "CCRm", "CCFtap", "CCFhos"] * 2
    np.testing.assert_allclose(tests["gvt_speed_kmh"], [0.0, 20.0, 30.0, 50.0] * 2)
    overlap = cases.set_index("case_id").loc[tests["case_id"], "ncap_overlap"].to_numpy()
    np.testing.assert_allclose(tests["overlap_pct"], 100.0 * overlap)
    assert tests["collided"].tolist() == [True, True, False, True] + [True] * 4

    scores = scenario_scores(tests, PROTOCOL)
    assert scores["system"].tolist() == ["aeb"] * 5 + ["none"] * 5
    for system, of_system in scores.groupby("system"):
        body = of_system[of_system["scenario"] != "total"].set_index("scenario")
        total = of_system[of_system["scenario"] == "total"].iloc[0]
        sub = tests[tests["system"] == system].set_index("scenario")
        for name in body.index:
            top = PROTOCOL["scenarios"][name]["max_points"]
            assert body.loc[name, "score"] == pytest.approx(top * sub.loc[name, "points"])
            assert body.loc[name, "max_score"] == top
            assert body.loc[name, "tests"] == 1
            assert body.loc[name, "avoided"] == int(not sub.loc[name, "collided"])
            assert [body.loc[name, c] for c in COLOURS] == [
                int(c == sub.loc[name, "colour"]) for c in COLOURS]
        assert total["score"] == pytest.approx(body["score"].sum())
        assert total["max_score"] == pytest.approx(body["max_score"].sum())
        assert total["tests"] == 4 and total["avoided"] == body["avoided"].sum()
        assert total["score_pct"] == pytest.approx(100 * total["score"] / total["max_score"])
        assert sum(int(total[c]) for c in COLOURS) == 4
        assert np.isnan(total["mean_points"])
    aeb_total = scores[(scores["system"] == "aeb") & (scores["scenario"] == "total")].iloc[0]
    assert (aeb_total["green"], aeb_total["orange"]) == (1, 2)


def test_a_scenario_mean_over_several_tests() -> None:
    cases = MATRIX.drop(columns=["kind", "accident_type"])
    ids = [case_of("CCRs", v) for v in (30.0, 40.0, 50.0)]
    runs = runs_for([(ids[0], "aeb", 5.0, 0.0), (ids[1], "aeb", 0.0, 0.0),
                     (ids[2], "aeb", 25.0, 0.0)])
    tests = assess_tests(runs, cases, PROTOCOL)
    assert tests["colour"].tolist() == ["brown", "green", "brown"]
    scores = scenario_scores(tests, PROTOCOL).set_index("scenario")
    mean = float(points_of(["brown", "green", "brown"], POINTS).mean())
    assert scores.loc["CCRs", "mean_points"] == pytest.approx(mean)
    assert scores.loc["CCRs", "avoided"] == 1 and scores.loc["CCRs", "tests"] == 3


def test_not_the_matrix_is_an_error() -> None:
    assert is_euro_ncap_cases(MATRIX) and not is_euro_ncap_cases(pd.DataFrame({"case_id": [1]}))
    with pytest.raises(DataError, match="Euro NCAP"):
        assess_tests(runs_for([(1, "aeb", 0.0, 0.0)]), pd.DataFrame({"case_id": [1]}), PROTOCOL)


def test_the_protocol_given_is_the_one_used() -> None:
    """A changed protocol (points, maxima) changes the assessment: it is not re-read."""
    protocol = copy.deepcopy(PROTOCOL)
    protocol["assessment"]["points"]["green"] = 0.9
    protocol["scenarios"]["CCRs"]["max_points"] = 3.0
    cases = MATRIX.drop(columns=["kind", "accident_type"])
    runs = runs_for([(case_of("CCRs", 50.0), "aeb", 0.0, 0.0)])
    runs["collided"] = None  # missing: no collision
    tests = assess_tests(runs, cases, protocol)
    assert tests["points"].tolist() == [0.9] and tests["collided"].tolist() == [False]
    scores = scenario_scores(tests, protocol).set_index("scenario")
    assert scores.loc["CCRs", "score"] == pytest.approx(2.7)
    assert scores.loc["CCRs", "max_score"] == 3.0
