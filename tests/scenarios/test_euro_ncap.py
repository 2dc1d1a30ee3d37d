"""The Euro NCAP Car-to-Car matrices (2026 default, 2023): geometry, paths, scoring, study.

Geometry is checked against the protocol files (scenarios/euro-ncap-c2c/protocol.toml,
protocol-2023.toml) and closed forms: speed grids, the 2026 impact-location convention (0 %
the VUT's right edge, 50 % full overlap) and the 2023 overlap sign, contact of the outlines
exactly at the impact time, CCRb's gap at brake onset, the CCFtap clothoid-arc-clothoid
path (radius, clothoid length, 90 deg), the CCCscp impact point (the VUT's front centre at
25 % of the GVT's length), the 2023 start-from-stop row, the CCFhol lane change (width,
length, end at TTC 1.5 s, peak lateral acceleration).  Scoring against the worked examples
of Euro NCAP's 2026 rating tool (its tests/crash_avoidance/test_impact_speed_tolerance.py)
and the rules it implements (CCRm band row by the VUT's speed; a hit VUT in CCFtap is red).
"""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pandas as pd
import pytest

from vfs.analysis.euro_ncap import (
    assess_tests,
    mitigation_or_avoidance_colours,
    points_of,
    run_measures,
    scenario_scores,
    speed_row,
)
from vfs.database import open_database
from vfs.database.plausibility import check_plausibility
from vfs.errors import DefinitionError
from vfs.physics.geometry import outline_corners, outline_distance
from vfs.scenarios.euro_ncap import (
    PROTOCOL_VERSIONS,
    TurnPath,
    build_euro_ncap_database,
    ccrb_impact_after_braking,
    impact_location_offset,
    lane_change_lateral,
    lane_change_length,
    lateral_offset,
    ncap_test_matrix,
    ncap_test_motions,
    protocol_path,
    read_protocol,
    turn_path,
    vehicles,
)
from vfs.units import KMH_PER_MS

PROTOCOLS = {v: read_protocol(version=v) for v in PROTOCOL_VERSIONS}
MATRICES = {v: ncap_test_matrix(p) for v, p in PROTOCOLS.items()}
P26, P23 = PROTOCOLS["2026"], PROTOCOLS["2023"]
VUT, GVT = vehicles(P26)


def _tests(name: str, version: str = "2026") -> pd.DataFrame:
    m = MATRICES[version]
    return m[m["ncap_scenario"] == name]


def _gap(test: pd.Series, protocol: dict) -> tuple[np.ndarray, float, np.ndarray]:
    """Time axis, impact time and the outline distance [m] of a test's undisturbed record."""
    t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, protocol)
    o1 = outline_corners(m1.x, m1.y, m1.yaw, VUT.cg_to_front, VUT.cg_to_rear, VUT.width)
    o2 = outline_corners(m2.x, m2.y, m2.yaw, GVT.cg_to_front, GVT.cg_to_rear, GVT.width)
    return t, t_impact, outline_distance(o1, o2)


def _at(t: np.ndarray, when: float) -> int:
    return int(np.argmin(np.abs(t - when)))


# ------------------------------------------------------------------------------ grids

@pytest.mark.parametrize("version", list(PROTOCOL_VERSIONS))
def test_speed_grids_and_matrix_size_follow_the_protocol(version: str) -> None:
    protocol = PROTOCOLS[version]
    lateral = ("impact_locations_pct" if protocol["lateral"]["convention"] == "impact_location"
               else "overlaps_pct")
    for name, sc in protocol["scenarios"].items():
        got = _tests(name, version)
        if sc.get("gvt_speed_per_vut_speed"):
            pairs = set(zip(sc["vut_speeds_kmh"], sc["gvt_speeds_kmh"], strict=True))
        else:
            pairs = {(v, g) for v in sc["vut_speeds_kmh"] for g in sc["gvt_speeds_kmh"]}
        pairs -= {tuple(p) for p in sc.get("exclude_pairs_kmh", [])}
        sides = sc.get("gvt_from", ["right"]) if sc["kind"] == "crossing" else [0]
        n = (len(pairs) * len(sc.get(lateral, [0]))
             * len(sc.get("headways_m", sc.get("headway_times_s", [0])))
             * len(sc.get("gvt_decelerations_ms2", [0])) * len([sides] if isinstance(sides, str)
                                                              else sides))
        assert len(got) == n, name
        speeds = set(zip(np.round(got["ncap_vut_speed"] * KMH_PER_MS, 9),
                         np.round(got["ncap_gvt_speed"] * KMH_PER_MS, 9), strict=True))
        assert speeds == {(float(v), float(g)) for v, g in pairs}, name
        assert (got["ncap_protocol"] == version).all()
    assert MATRICES[version]["case_id"].tolist() == list(range(1, len(MATRICES[version]) + 1))


def test_grid_shapes_of_each_version() -> None:
    # 2026 standard range (V26): CCCscp VUT 20-60 x GVT 20-60 from both sides;
    # CCFhos/CCFhol VUT 30-80 x impact location 75 / 50 / 25 %; CCRb 30-80 x 5 locations
    ccc = _tests("CCCscp")
    assert len(ccc) == 2 * 25 and set(ccc["ncap_gvt_side"]) == {1.0, -1.0}
    assert len(_tests("CCRb")) == 6 * 5 and len(_tests("CCFtap")) == 9
    assert sorted(set(np.round(_tests("CCFhos")["ncap_lateral_location"] * 100, 9))) == [
        25.0, 50.0, 75.0]
    # 2023: the CCCscp grid has a start-from-stop row: 30 combinations (issue 38)
    ccc = _tests("CCCscp", "2023")
    assert len(ccc) == 30 and (ccc["ncap_vut_speed"] == 0).sum() == 5
    assert "CCFhos" not in P23["scenarios"]
    # the 2026 total of maxima: R26 TOTAL_SCORES Standard, 1.2 + 2.4 + 1.6 + 2 + 2 + 4 + 6
    assert sum(sc["max_points"] for sc in P26["scenarios"].values()) == pytest.approx(19.2)


# --------------------------------------------------------------------- lateral positions

@pytest.mark.parametrize("location", [0.0, 0.25, 0.5, 0.75, 1.0])
def test_2026_impact_location_convention(location: float) -> None:
    """0 % = the VUT's right edge, 50 % = full overlap, 100 % = its left edge (ISO +y left)."""
    y = impact_location_offset(location, VUT.width)
    assert y == pytest.approx(-0.5 * VUT.width + location * VUT.width)
    # overlapping width of the two fronts: full at 50 %, half the VUT at 0 and 100 %
    lo, hi = max(-0.5 * VUT.width, y - 0.5 * GVT.width), min(0.5 * VUT.width, y + 0.5 * GVT.width)
    assert hi - lo == pytest.approx(VUT.width - abs(y))  # equal widths
    if location == 0.5:
        assert hi - lo == pytest.approx(VUT.width)


def test_head_on_records_put_the_gvt_where_its_impact_location_says() -> None:
    for name in ("CCFhos", "CCFhol", "CCRs"):
        for _, test in _tests(name).iterrows():
            t, t_impact, _, m2 = ncap_test_motions(test, VUT, GVT, P26)
            k = _at(t, t_impact)
            loc = test["ncap_lateral_location"]
            assert m2.y[k] == pytest.approx((loc - 0.5) * VUT.width, abs=1e-9), (name, loc)
            # 25 %: the GVT on the VUT's right (y < 0), 75 %: on its left
            assert np.sign(m2.y[k]) == np.sign(loc - 0.5) or loc == 0.5


@pytest.mark.parametrize("overlap", [-0.75, -0.5, 0.5, 0.75, 1.0])
@pytest.mark.parametrize("negative_side", ["left", "right"])
def test_2023_overlap_width_and_sign_convention(overlap: float, negative_side: str) -> None:
    y = lateral_offset(overlap, VUT.width, GVT.width, negative_side)
    lo, hi = max(-0.5 * VUT.width, y - 0.5 * GVT.width), min(0.5 * VUT.width, y + 0.5 * GVT.width)
    assert hi - lo == pytest.approx(abs(overlap) * VUT.width, abs=1e-12)
    if overlap < 1.0:
        left = (overlap < 0) == (negative_side == "left")
        assert (y > 0) == left


def test_2023_record_puts_negative_overlap_on_the_protocol_side() -> None:
    test = _tests("CCRs", "2023")
    row = test[test["ncap_overlap"] == -0.5].iloc[0]
    _, _, _, m2 = ncap_test_motions(row, VUT, GVT, P23)
    assert P23["lateral"]["negative_side"] == "right" and m2.y[0] < 0
    flipped = copy.deepcopy(P23)
    flipped["lateral"]["negative_side"] = "left"
    _, _, _, m2f = ncap_test_motions(row, VUT, GVT, flipped)
    np.testing.assert_allclose(m2f.y, -m2.y)


@pytest.mark.parametrize("version,name", [("2026", "CCRs"), ("2026", "CCRm"),
                                          ("2026", "CCFhos"), ("2026", "CCCscp"),
                                          ("2023", "CCRs"), ("2023", "CCCscp")])
def test_outlines_touch_exactly_at_the_impact_time(version: str, name: str) -> None:
    protocol = PROTOCOLS[version]
    for _, test in _tests(name, version).iterrows():
        t, t_impact, gap = _gap(test, protocol)
        k = _at(t, t_impact)
        assert t[k] == pytest.approx(t_impact)
        assert gap[k] == pytest.approx(0.0, abs=1e-9)
        assert np.all(gap[:k] > 0.0)
        v, g = test["ncap_vut_speed"], test["ncap_gvt_speed"]
        if name == "CCCscp" and v == 0:
            continue  # start from stop: the closing rate is the VUT's speed at impact
        rate = {"CCRs": v - g, "CCRm": v - g, "CCFhos": v + g, "CCCscp": v}[name]
        assert gap[k - 1] == pytest.approx(rate * (t[k] - t[k - 1]), rel=1e-6)


def test_ccrb_gap_at_brake_onset_deceleration_and_impact() -> None:
    """2026 CCRb (V26): time headway 1 s, 4 m/s2 down to 2 km/h; gap and impact closed forms."""
    sc = P26["scenarios"]["CCRb"]
    final = sc["gvt_final_speed_kmh"] / KMH_PER_MS
    for _, test in _tests("CCRb").iterrows():
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, P26)
        t_brake = float(sc["steady_before_braking_s"])
        v, dec = test["ncap_vut_speed"], test["ncap_gvt_deceleration"]
        headway = test["ncap_headway"]
        assert headway == pytest.approx(v * sc["headway_times_s"][0])  # space = speed x 1 s
        assert dec == 4.0 and test["ncap_gvt_speed"] == v
        k = _at(t, t_brake)
        gap = (m2.x - GVT.cg_to_rear) - (m1.x + VUT.cg_to_front)
        assert gap[k] == pytest.approx(headway)
        assert np.all(np.abs(gap[:k + 1] - headway) < 1e-9)
        moving = (t > t_brake) & (m2.speed > final + 1e-9)
        assert np.all(m2.accel[moving] == -dec)
        # brakes down to 2 km/h, then keeps it
        want = np.maximum(v - dec * np.maximum(t - t_brake, 0.0), final)
        np.testing.assert_allclose(m2.speed, want, atol=1e-12)
        tau = t_impact - t_brake
        assert tau == pytest.approx(ccrb_impact_after_braking(headway, v, dec, final))
        t_b = (v - final) / dec
        s_gvt = (headway + v * tau - 0.5 * dec * tau**2 if tau <= t_b
                 else headway + v * t_b - 0.5 * dec * t_b**2 + final * (tau - t_b))
        assert s_gvt == pytest.approx(v * tau)
        assert np.all(gap[t < t_impact - 1e-9] > 0.0)


# ------------------------------------------------------------------------------ CCFtap

@pytest.mark.parametrize("radius,clothoid", [(14.75, 5.56), (9.0, 2.78), (11.75, 0.0)])
def test_turn_path_is_clothoid_arc_clothoid_through_90_degrees(radius: float,
                                                               clothoid: float) -> None:
    path = TurnPath(radius, clothoid)
    s = np.linspace(-2.0, path.length + 2.0, 4001)
    x, y, psi = path.position(s)
    assert psi[0] == 0.0 and psi[-1] == pytest.approx(0.5 * math.pi)
    # curvature from the positions (d psi / ds of the chord directions) against the definition
    kappa = path.curvature(s)
    assert kappa.max() == pytest.approx(1.0 / radius)
    on_arc = (s > clothoid + 0.05) & (s < clothoid + path.arc - 0.05)
    np.testing.assert_allclose(np.gradient(psi, s)[on_arc], 1.0 / radius, rtol=1e-6)
    # the arc part lies on a circle of the radius about its centre
    xc, yc, pc = path.position(np.array([clothoid + 0.5 * path.arc]))
    centre = (xc[0] - radius * math.sin(pc[0]), yc[0] + radius * math.cos(pc[0]))
    np.testing.assert_allclose(np.hypot(x[on_arc] - centre[0], y[on_arc] - centre[1]),
                               radius, atol=1e-6)
    if clothoid > 0:  # curvature linear along the clothoids
        first = (s > 0.01) & (s < clothoid - 0.01)
        np.testing.assert_allclose(kappa[first], s[first] / (radius * clothoid), rtol=1e-12)
    # unit speed along the path: positions change by the arc length
    step = np.hypot(np.diff(x), np.diff(y))
    np.testing.assert_allclose(step, np.diff(s), rtol=1e-4)


def test_ccftap_radius_clothoid_and_meeting_point() -> None:
    sc = P26["scenarios"]["CCFtap"]
    radius = dict(zip(sc["vut_speeds_kmh"], sc["turn_radii_m"], strict=True))
    alpha = dict(zip(sc["vut_speeds_kmh"], sc["clothoid_angles_deg"], strict=True))
    assert radius[20] == 14.75  # 2026 at 20 km/h (issue 38, Frontal Collisions v1.1)
    lane = P26["protocol"]["lane_width_m"]
    for _, test in _tests("CCFtap").iterrows():
        v_kmh = round(test["ncap_vut_speed"] * KMH_PER_MS, 9)
        path = turn_path(test, P26)
        assert path.radius == radius[v_kmh] and path.start_radius == 1500.0
        # each clothoid turns through alpha, the arc through beta = 90 - 2 alpha (V26)
        assert math.degrees(path.clothoid_angle) == pytest.approx(alpha[v_kmh])
        assert math.degrees(path.arc / path.radius) == pytest.approx(90 - 2 * alpha[v_kmh])
        s = np.linspace(0.0, path.length, 20001)
        assert path.heading(np.array([path.length]))[0] == pytest.approx(0.5 * math.pi)
        np.testing.assert_allclose(np.gradient(path.heading(s), s), path.curvature(s),
                                   atol=2e-3)
        assert path.curvature(np.array([0.0]))[0] == pytest.approx(1 / 1500.0)
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, P26)
        k = _at(t, t_impact)
        front1 = np.array([m1.x[k] + VUT.cg_to_front * math.cos(m1.yaw[k]),
                           m1.y[k] + VUT.cg_to_front * math.sin(m1.yaw[k])])
        front2 = np.array([m2.x[k] + GVT.cg_to_front * math.cos(m2.yaw[k]),
                           m2.y[k] + GVT.cg_to_front * math.sin(m2.yaw[k])])
        np.testing.assert_allclose(front1, front2, atol=1e-6)
        assert front1[1] == pytest.approx(lane, abs=1e-6)
        _, _, gap = _gap(test, P26)
        assert gap[0] > 0.0 and gap[k] == 0.0


# ------------------------------------------------------------------------------ CCCscp

@pytest.mark.parametrize("version", list(PROTOCOL_VERSIONS))
def test_cccscp_front_centre_hits_the_gvt_at_25_percent_of_its_length(version: str) -> None:
    protocol = PROTOCOLS[version]
    for _, test in _tests("CCCscp", version).iterrows():
        assert test["ncap_impact_location"] == pytest.approx(0.25)
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, protocol)
        k = _at(t, t_impact)
        assert m1.x[k] + VUT.cg_to_front == pytest.approx(0.0)  # VUT front centre at (0, 0)
        assert m2.x[k] - 0.5 * GVT.width == pytest.approx(0.0)  # the GVT's near side at x = 0
        heading = math.copysign(1.0, math.sin(m2.yaw[k]))
        gvt_front = m2.y[k] + heading * GVT.cg_to_front
        # the point (0, 0) lies 25 % of the GVT's length behind its front
        assert abs(gvt_front - 0.0) == pytest.approx(0.25 * GVT.length)
        assert heading * gvt_front > 0  # the front is past the VUT's path


def test_start_from_stop_accelerates_from_standstill_to_the_impact_point() -> None:
    sc = P23["scenarios"]["CCCscp"]
    a, d = sc["start_from_stop_accel_ms2"], sc["start_from_stop_distance_m"]
    for _, test in _tests("CCCscp", "2023").iterrows():
        if test["ncap_vut_speed"] > 0:
            continue
        t, t_impact, m1, _ = ncap_test_motions(test, VUT, GVT, P23)
        k = _at(t, t_impact)
        assert m1.speed[0] == 0.0 and m1.x[0] == pytest.approx(-VUT.cg_to_front - d)
        assert m1.speed[k] == pytest.approx(math.sqrt(2 * a * d))  # v^2 = 2 a d
        assert m1.x[k] + VUT.cg_to_front == pytest.approx(0.0)


# ------------------------------------------------------------------------------ CCFhol

def test_lane_change_profile_width_and_peak() -> None:
    for length, g_kmh in ((44.0, 50.0), (60.0, 70.0), (78.0, 90.0), (88.0, 100.0)):
        duration = length / (g_kmh / KMH_PER_MS)
        tau = np.linspace(0.0, duration, 200001)
        y, v, a = lane_change_lateral(tau, duration, 3.5, 1.5)
        assert y[0] == 0.0 and y[-1] == pytest.approx(3.5, abs=1e-12)
        assert v[0] == 0.0 and v[-1] == pytest.approx(0.0, abs=1e-12)
        assert np.abs(a).max() == pytest.approx(1.5)
        # the closed-form integration agrees with differentiating the displacement
        np.testing.assert_allclose(np.gradient(y, tau), v, atol=1e-6)
        np.testing.assert_allclose(np.gradient(v, tau)[1:-1], a[1:-1], atol=1e-3)


def test_ccfhol_lane_change_length_end_ttc_and_lateral_acceleration() -> None:
    sc = P26["scenarios"]["CCFhol"]
    lane = sc["lane_change_width_m"]
    assert lane == 3.5 and sc["lane_change_end_ttc_s"] == 1.5
    assert {float(k): v for k, v in sc["lane_change_lengths_m"].items()} == {
        50.0: 44.0, 70.0: 60.0, 90.0: 78.0, 100.0: 88.0}
    dt = P26["protocol"]["time_step_s"]
    for _, test in _tests("CCFhol").iterrows():
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, P26)
        target = impact_location_offset(test["ncap_lateral_location"], VUT.width)
        assert m2.y[0] == pytest.approx(target + lane)  # one lane to the VUT's left
        moving = np.flatnonzero(np.abs(np.diff(m2.y)) > 1e-12)
        start, end = t[moving[0]], t[moving[-1] + 1]
        # ends at TTC 1.5 s: the fronts' gap over the closing speed
        k_end = _at(t, t_impact - 1.5)
        assert end <= t[k_end] + 1e-9 and end > t[k_end] - dt - 1e-9
        gap = (m2.x[k_end] - GVT.cg_to_front) - (m1.x[k_end] + VUT.cg_to_front)
        assert gap / (test["ncap_vut_speed"] + test["ncap_gvt_speed"]) == pytest.approx(1.5)
        # over the protocol's length: the GVT's longitudinal travel during the manoeuvre
        length = lane_change_length(test, P26)
        travel = test["ncap_gvt_speed"] * (t_impact - 1.5 - start)
        assert travel == pytest.approx(length, abs=test["ncap_gvt_speed"] * dt)
        # peak lateral acceleration about 1.5 m/s2 (second difference of the record)
        lat = np.diff(m2.y, 2) / dt**2
        assert np.abs(lat).max() == pytest.approx(1.5, rel=0.05)
        done = t >= t_impact - 1.5 - 1e-9
        np.testing.assert_allclose(m2.y[done], target, atol=1e-9)
        _, _, g = _gap(test, P26)
        k = _at(t, t_impact)
        assert g[k] == pytest.approx(0.0, abs=1e-9) and np.all(g[:k] > 0)


# ------------------------------------------------------------------------------ scoring

def _runs(case_ids: list[int], system: str, impact_kmh: list[float],
          gvt_vx: float = 0.0, collided: list[bool] | None = None) -> pd.DataFrame:
    v = np.array(impact_kmh, dtype=float) / KMH_PER_MS
    hit = v > 0 if collided is None else np.array(collided)
    return pd.DataFrame({"case_id": case_ids, "system": system, "error": "",
                         "collided": hit, "impact_speed1": np.where(hit, v, np.nan),
                         "vx1": v, "vy1": 0.0, "vx2": gvt_vx, "vy2": 0.0})


def _cases(version: str = "2026") -> pd.DataFrame:
    return MATRICES[version].drop(columns=["kind", "accident_type"])


def test_band_table_of_the_rating_tool_worked_example() -> None:
    """R26 test_impact_speed_tolerance, sec 4.2.4 table at 60 km/h: green 0, yellow <= 10,
    orange <= 20, brown <= 30, red > 30 (measured colours, no tolerance)."""
    bands = P26["assessment"]["mitigation_or_avoidance"]
    values = [0.0, 5.0, 12.0, 12.1, 18.1, 22.0, 27.9, 28.1, 32.0, 32.1, 40.0]
    want = ["green", "yellow", "orange", "orange", "orange", "brown", "brown", "brown", "red",
            "red", "red"]
    assert mitigation_or_avoidance_colours(values, 60.0, bands).tolist() == want
    assert mitigation_or_avoidance_colours([10.0, 10.1], 30.0, bands).tolist() == ["brown",
                                                                                  "red"]
    assert speed_row(45.0, [10, 20, 30, 40, 50]) == 40
    pts = points_of(["green", "yellow", "orange", "brown", "red"], P26["assessment"]["points"])
    np.testing.assert_array_equal(pts, [1.0, 0.75, 0.5, 0.25, 0.0])


def test_ccftap_impact_and_a_hit_standing_vut_are_red() -> None:
    """R26 test_avoidance_impact_speed_has_no_tolerance: CCFtap at 1.5 km/h is red; the VUT
    must not enter the GVT's path, so a VUT standing in it and hit is red too."""
    ids = _tests("CCFtap")["case_id"].tolist()[:3]
    runs = _runs(ids, "aeb", [1.5, 0.0, 0.0], collided=[True, True, False])
    tests = assess_tests(runs, _cases(), P26)
    assert tests["colour"].tolist() == ["red", "red", "green"]
    assert tests["vut_impact_speed_kmh"].tolist() == [1.5, 0.0, 0.0]


def test_ccfhos_speed_reduction_of_11_kmh_is_orange() -> None:
    """R26 test_mitigation_speed_reduction_has_no_tolerance (Figure 5-2): 11 km/h orange."""
    test = _tests("CCFhos").iloc[[0]]
    v = test["ncap_vut_speed"].iloc[0] * KMH_PER_MS
    tests = assess_tests(_runs(test["case_id"].tolist(), "aeb", [v - 11.0]), _cases(), P26)
    assert tests["speed_reduction_kmh"].iloc[0] == pytest.approx(11.0)
    assert tests["colour"].iloc[0] == "orange"


def test_ccrm_band_row_is_the_vut_speed() -> None:
    """R26 matrix_processing: the row of CCRm's bands is the VUT speed (not VUT - GVT)."""
    ccrm = _tests("CCRm")
    ids = [int(ccrm[np.isclose(ccrm["ncap_vut_speed"] * KMH_PER_MS, v)]["case_id"].iloc[0])
           for v in (30.0, 40.0)]
    gvt = 20.0 / KMH_PER_MS
    # relative impact speeds 10 and 15 km/h: VUT impact speeds 30 and 35 km/h
    runs = _runs(ids, "aeb", [30.0, 35.0], gvt_vx=gvt)
    tests = assess_tests(runs, _cases(), P26)
    np.testing.assert_allclose(tests["relative_impact_speed_kmh"], [10.0, 15.0])
    # row 30: brown <= 10; row 40: brown <= 20 (by the relative test speed, rows 10 and 20,
    # both would be red)
    assert tests["colour"].tolist() == ["brown", "brown"]


def test_measures_relative_speed_and_reduction() -> None:
    runs = _runs([1], "x", [36.0], gvt_vx=5.0)
    runs["ncap_vut_speed"] = 50.0 / KMH_PER_MS
    got = run_measures(runs).iloc[0]
    assert got["vut_impact_speed_kmh"] == pytest.approx(36.0)
    assert got["relative_impact_speed_kmh"] == pytest.approx(36.0 - 18.0)
    assert got["speed_reduction_kmh"] == pytest.approx(14.0)


def test_scenario_score_is_the_mean_points_times_the_maximum() -> None:
    """R26 test_info: standard score = sum of points / number of test points x maximum."""
    ccrs = _tests("CCRs")
    ids = ccrs[np.isclose(ccrs["ncap_vut_speed"] * KMH_PER_MS, 50.0)]["case_id"].tolist()[:2]
    tests = assess_tests(_runs(ids, "aeb", [0.0, 25.0]), _cases(), P26)
    assert tests["colour"].tolist() == ["green", "brown"]
    scores = scenario_scores(tests).set_index("scenario")
    top = P26["scenarios"]["CCRs"]["max_points"]
    assert scores.loc["CCRs", "score"] == pytest.approx(top * (1.0 + 0.25) / 2)
    assert scores.loc["total", "max_score"] == pytest.approx(top)
    assert (scores["protocol"] == "2026").all()


def test_fcw_ttc_is_the_undisturbed_impact_time_minus_the_warning_time() -> None:
    test = _tests("CCRs").iloc[[0]]
    runs = _runs(test["case_id"].tolist(), "aeb", [0.0])
    runs["warning_time1"] = 3.2
    cases = _cases().assign(ncap_impact_time=5.0)
    got = assess_tests(runs, cases, P26)
    assert got["fcw_ttc_s"].iloc[0] == pytest.approx(1.8)


# ------------------------------------------------------------------- protocol file errors

@pytest.mark.parametrize("table", ["assessment.avoidance", "assessment", "lateral",
                                   "scenarios.CCFhol.lane_change_lengths_m"])
def test_protocol_file_missing_a_table_gives_a_clear_error(tmp_path, table: str) -> None:
    with open(protocol_path("2026"), "rb") as f:
        data = tomllib.load(f)
    *parents, last = table.split(".")
    node = data
    for key in parents:
        node = node[key]
    del node[last]
    text = protocol_path("2026").read_text(encoding="utf-8")
    # rewrite the file without that table: tomllib has no writer, so drop it from the text
    file = tmp_path / "protocol.toml"
    if table == "assessment.avoidance":
        text = text.replace("[assessment.avoidance]", "[assessment.avoidance_gone]")
    elif table == "assessment":
        text = text.replace("[assessment]", "[assessment_gone]").replace(
            "[assessment.", "[assessment_gone.")
    elif table == "lateral":
        text = text.replace("[lateral]", "[lateral_gone]")
    else:
        text = text.replace("lane_change_lengths_m =", "lane_change_lengths_gone =")
    file.write_text(text, encoding="utf-8")
    with pytest.raises(DefinitionError) as err:
        read_protocol(file)
    assert table in str(err.value) and str(file) in str(err.value)


# ------------------------------------------------------------------------ database, study

@pytest.mark.parametrize("version", list(PROTOCOL_VERSIONS))
def test_bundled_database_is_the_build_of_the_protocol_file(version: str) -> None:
    name = PROTOCOL_VERSIONS[version][0]
    bundled = open_database(name)
    fresh = build_euro_ncap_database(PROTOCOLS[version])
    for tname, table in fresh.tables().items():
        stored = getattr(bundled, tname)
        # optional columns the build leaves empty (the post-impact inputs) need not be stored
        empty = [c for c in table.columns if c not in stored.columns]
        assert table[empty].isna().all().all(), empty
        kept = [c for c in table.columns if c in stored.columns]
        pd.testing.assert_frame_equal(stored[kept], table[kept], check_dtype=False)
    assert bundled.meta["equip"] == "1" and bundled.meta["has_reconstruction"] is False
    assert bundled.meta["ncap_protocol"] == version and bundled.meta["name"] == name
    found = check_plausibility(fresh)
    assert not found.errors and not found.warnings


def test_study_report_and_side_by_side_on_part_of_the_matrix(tmp_path, capsys) -> None:
    from vfs.cli import main as vfs_main
    from vfs.report.euro_ncap import SCORES_FILE, TESTS_FILE, study_tables
    from vfs.study import load_study

    ccrs = _tests("CCRs")
    ids = ccrs[ccrs["ncap_lateral_location"] == 0.5]["case_id"].head(3).tolist()
    study = tmp_path / "s"
    assert vfs_main(["study", "--db", "euro-ncap-c2c", "--systems", "ideal", "--out",
                     str(study), "--engine", "serial",
                     "--where", f"case_id IN ({', '.join(map(str, ids))})"]) == 0
    assert load_study(study).manifest["equip"] == "1"
    tables = study_tables(study)
    assert tables is not None
    tests, scores = tables
    base = tests[tests["system"] == "baseline"]
    np.testing.assert_allclose(base["vut_impact_speed_kmh"], base["vut_speed_kmh"], atol=0.1)
    assert (base["colour"] == "red").all() and (base["protocol"] == "2026").all()
    ideal = tests[tests["system"] == "ideal"]
    assert (~ideal["collided"]).all() and (ideal["colour"] == "green").all()
    assert scores.set_index(["system", "scenario"]).loc[("ideal", "CCRs"), "score_pct"] == 100

    assert vfs_main(["report", "effectiveness", str(study), "--no-case-pages",
                     "--bootstrap", "50"]) == 0
    report = (study / "report" / "report.md").read_text(encoding="utf-8")
    assert "## Euro NCAP Car-to-Car" in report and "Result sheet: ideal" in report
    html = (study / "report" / "report.html").read_text(encoding="utf-8")
    assert 'band-green">' in html
    sheet = pd.read_csv(study / "report" / TESTS_FILE)
    assert {"measure_kmh", "colour", "points", "fcw_ttc_s"} <= set(sheet.columns)
    assert (study / "report" / SCORES_FILE).is_file()

    out = tmp_path / "sbs"
    assert vfs_main(["report", "side-by-side", "--ncap", str(study), "--accidents", str(study),
                     "--out", str(out), "--bootstrap", "50"]) == 0
    table = pd.read_csv(out / "side_by_side.csv").set_index("system")
    assert table.loc["ideal", "ncap_CCRs_pct"] == 100
    assert str(table.loc["ideal", "ncap_protocol"]) == "2026"
    assert table.loc["ideal", "acc_avoided_share"] == pytest.approx(1.0)
    # the figure (test score against accident benefit) above two tables that fit the page
    assert (out / "side_by_side.png").stat().st_size > 10_000
    md = (out / "side_by_side.md").read_text(encoding="utf-8")
    assert md.index("(side_by_side.png)") < md.index("## Euro NCAP") < md.index("## Accidents")
    assert max(len(line) for line in md.splitlines() if line.startswith("| ideal")) < 200
    capsys.readouterr()
