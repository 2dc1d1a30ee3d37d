"""The Euro NCAP AEB Car-to-Car matrix: geometry against the protocol, scoring, study.

Geometry is checked against the protocol file (scenarios/euro-ncap-c2c/protocol.toml) and
closed forms: speed grids, the overlap sign convention, CCRb's gap at brake onset and its
deceleration, contact of the outlines exactly at the protocol's impact location for the
straight tests, the paths meeting at the synchronisation point for CCFtap and CCCscp.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pandas as pd
import pytest

from vfs.analysis.euro_ncap import (
    assess_tests,
    band_colours,
    mitigation_or_avoidance_colours,
    points_of,
    run_measures,
    scenario_scores,
    speed_row,
)
from vfs.database import open_database
from vfs.database.plausibility import check_plausibility
from vfs.physics.geometry import outline_corners, outline_distance
from vfs.scenarios.euro_ncap import (
    build_euro_ncap_database,
    ccrb_impact_after_braking,
    lateral_offset,
    ncap_test_matrix,
    ncap_test_motions,
    read_protocol,
    turn_sync_angle,
    vehicles,
)
from vfs.units import KMH_PER_MS

PROTOCOL = read_protocol()
MATRIX = ncap_test_matrix(PROTOCOL)
VUT, GVT = vehicles(PROTOCOL)


def _tests(name: str) -> pd.DataFrame:
    return MATRIX[MATRIX["ncap_scenario"] == name]


def _gap(test: pd.Series, protocol: dict = PROTOCOL) -> tuple[np.ndarray, float, np.ndarray]:
    """Time axis, impact time and the outline distance [m] of a test's undisturbed record."""
    t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, protocol)
    o1 = outline_corners(m1.x, m1.y, m1.yaw, VUT.cg_to_front, VUT.cg_to_rear, VUT.width)
    o2 = outline_corners(m2.x, m2.y, m2.yaw, GVT.cg_to_front, GVT.cg_to_rear, GVT.width)
    return t, t_impact, outline_distance(o1, o2)


def test_speed_grids_and_matrix_size_follow_the_protocol() -> None:
    for name, sc in PROTOCOL["scenarios"].items():
        got = _tests(name)
        if sc.get("gvt_speed_per_vut_speed"):
            pairs = set(zip(sc["vut_speeds_kmh"], sc["gvt_speeds_kmh"], strict=True))
        else:
            pairs = {(v, g) for v in sc["vut_speeds_kmh"] for g in sc["gvt_speeds_kmh"]}
        n = (len(pairs) * len(sc.get("overlaps_pct", [100]))
             * len(sc.get("impact_location_pct", [0])) * len(sc.get("headways_m", [0]))
             * len(sc.get("gvt_decelerations_ms2", [0])))
        assert len(got) == n, name
        speeds = set(zip(np.round(got["ncap_vut_speed"] * KMH_PER_MS, 9),
                         np.round(got["ncap_gvt_speed"] * KMH_PER_MS, 9), strict=True))
        assert speeds == {(float(v), float(g)) for v, g in pairs}, name
        assert set(np.round(100 * got["ncap_overlap"], 9)) == {
            float(o) for o in sc.get("overlaps_pct", [100])}
    assert MATRIX["case_id"].tolist() == list(range(1, len(MATRIX) + 1))


@pytest.mark.parametrize("overlap", [-0.75, -0.5, 0.5, 0.75, 1.0])
@pytest.mark.parametrize("negative_side", ["left", "right"])
def test_overlap_width_and_sign_convention(overlap: float, negative_side: str) -> None:
    y = lateral_offset(overlap, VUT.width, GVT.width, negative_side)
    # overlapping width of the VUT [-w/2, w/2] and the GVT [y - W/2, y + W/2]
    lo, hi = max(-0.5 * VUT.width, y - 0.5 * GVT.width), min(0.5 * VUT.width, y + 0.5 * GVT.width)
    assert hi - lo == pytest.approx(abs(overlap) * VUT.width, abs=1e-12)
    if overlap < 1.0:
        left = (overlap < 0) == (negative_side == "left")
        assert (y > 0) == left  # ISO 8855: +y is the VUT's left


def test_ccrs_record_puts_negative_overlap_on_the_protocol_side() -> None:
    test = _tests("CCRs")
    row = test[test["ncap_overlap"] == -0.5].iloc[0]
    _, t_impact, _, m2 = ncap_test_motions(row, VUT, GVT, PROTOCOL)
    side = PROTOCOL["overlap"]["negative_side"]
    assert (m2.y[0] > 0) == (side == "left")
    flipped = copy.deepcopy(PROTOCOL)
    flipped["overlap"]["negative_side"] = "right" if side == "left" else "left"
    _, _, _, m2f = ncap_test_motions(row, VUT, GVT, flipped)
    np.testing.assert_allclose(m2f.y, -m2.y)


def test_sign_convention_of_the_sources() -> None:
    """v3.0.2 as implemented by BeamNG: a negative overlap offsets the VUT to the GVT's left,
    so the GVT lies to the VUT's right (ISO 8855 -y); head-on impact locations on the VUT's
    left, where the oncoming lane is in right-hand traffic."""
    assert PROTOCOL["overlap"]["negative_side"] == "right"
    for name in ("CCRs", "CCRm", "CCFhos"):
        for _, test in _tests(name).iterrows():
            if abs(test["ncap_overlap"]) >= 1.0:
                continue
            _, _, _, m2 = ncap_test_motions(test, VUT, GVT, PROTOCOL)
            # negative: GVT to the right (y < 0); positive: to the left (y > 0)
            assert np.sign(m2.y[0]) == np.sign(test["ncap_overlap"]), (name, test["ncap_overlap"])
    assert (_tests("CCFhos")["ncap_overlap"] > 0).all()  # the VUT's left


@pytest.mark.parametrize("name", ["CCRs", "CCRm", "CCFhos", "CCCscp"])
def test_outlines_touch_exactly_at_the_impact_time(name: str) -> None:
    for _, test in _tests(name).iterrows():
        t, t_impact, gap = _gap(test)
        k = int(np.argmin(np.abs(t - t_impact)))
        assert t[k] == pytest.approx(t_impact)
        assert gap[k] == pytest.approx(0.0, abs=1e-9)
        assert np.all(gap[:k] > 0.0)
        # closing speed: the gap shrinks at the relative speed along the VUT's path (rear,
        # head-on) or at the VUT's speed (crossing: the GVT's side is parallel to its path)
        v, g = test["ncap_vut_speed"], test["ncap_gvt_speed"]
        rate = {"CCRs": v - g, "CCRm": v - g, "CCFhos": v + g, "CCCscp": v}[name]
        assert gap[k - 1] == pytest.approx(rate * (t[k] - t[k - 1]), rel=1e-6)


def test_ccrb_gap_at_brake_onset_deceleration_and_impact() -> None:
    sc = PROTOCOL["scenarios"]["CCRb"]
    seen = set()
    for _, test in _tests("CCRb").iterrows():
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, PROTOCOL)
        t_brake = float(sc["steady_before_braking_s"])
        dec, headway = test["ncap_gvt_deceleration"], test["ncap_headway"]
        seen.add((dec, headway))
        k = int(round(t_brake / PROTOCOL["protocol"]["time_step_s"]))
        gap = (m2.x - GVT.cg_to_rear) - (m1.x + VUT.cg_to_front)
        assert gap[k] == pytest.approx(headway)
        assert np.all(np.abs(gap[:k + 1] - headway) < 1e-9)  # steady following at equal speed
        moving = (t > t_brake) & (m2.speed > 0)
        assert np.all(m2.accel[moving] == -dec)
        slope = np.diff(m2.speed)[moving[1:] & moving[:-1]] / np.diff(t)[0]
        np.testing.assert_allclose(slope, -dec, rtol=1e-9)
        # undisturbed impact at the closed form: gap 0 at t_impact, positive before
        assert t_impact - t_brake == pytest.approx(ccrb_impact_after_braking(
            headway, test["ncap_gvt_speed"], dec))
        tau = t_impact - t_brake
        s_gvt = (headway + test["ncap_gvt_speed"] * tau - 0.5 * dec * tau**2
                 if tau < test["ncap_gvt_speed"] / dec
                 else headway + test["ncap_gvt_speed"] ** 2 / (2 * dec))
        assert s_gvt == pytest.approx(test["ncap_vut_speed"] * tau)
        before = t < t_impact - 1e-9
        assert np.all(gap[before] > 0.0)
    assert seen == {(float(d), float(h)) for d in sc["gvt_decelerations_ms2"]
                    for h in sc["headways_m"]}


def test_ccftap_paths_meet_at_the_impact_point() -> None:
    lane = PROTOCOL["protocol"]["lane_width_m"]
    for _, test in _tests("CCFtap").iterrows():
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, PROTOCOL)
        k = int(np.argmin(np.abs(t - t_impact)))
        front1 = np.array([m1.x[k] + VUT.cg_to_front * math.cos(m1.yaw[k]),
                           m1.y[k] + VUT.cg_to_front * math.sin(m1.yaw[k])])
        front2 = np.array([m2.x[k] + GVT.cg_to_front * math.cos(m2.yaw[k]),
                           m2.y[k] + GVT.cg_to_front * math.sin(m2.yaw[k])])
        np.testing.assert_allclose(front1, front2, atol=1e-9)
        assert front1[1] == pytest.approx(lane)  # on the GVT's lane centreline
        radius = test["ncap_turn_radius"]
        assert m1.yaw[k] == pytest.approx(turn_sync_angle(radius, VUT.cg_to_front, lane))
        on_arc = (m1.yaw > 1e-9) & (m1.yaw < 0.5 * math.pi - 1e-9)
        np.testing.assert_allclose(np.hypot(m1.x[on_arc], m1.y[on_arc] - radius), radius)
        _, _, gap = _gap(test)
        assert gap[0] > 0.0 and gap[k] == 0.0  # apart at the start, in contact at the point


def test_ccftap_turn_radius_per_vut_speed() -> None:
    sc = PROTOCOL["scenarios"]["CCFtap"]
    radius = dict(zip(sc["vut_speeds_kmh"], sc["turn_radii_m"], strict=True))
    for _, test in _tests("CCFtap").iterrows():
        speed = round(test["ncap_vut_speed"] * KMH_PER_MS, 9)
        assert test["ncap_turn_radius"] == radius[speed]


def test_cccscp_hits_the_gvt_side_at_the_impact_location() -> None:
    for _, test in _tests("CCCscp").iterrows():
        t, t_impact, m1, m2 = ncap_test_motions(test, VUT, GVT, PROTOCOL)
        k = int(np.argmin(np.abs(t - t_impact)))
        assert m1.x[k] + VUT.cg_to_front == pytest.approx(0.0)  # VUT front centre at (0, 0)
        assert m2.x[k] - 0.5 * GVT.width == pytest.approx(0.0)  # the GVT's side at x = 0
        heading = math.copysign(1.0, math.sin(m2.yaw[k]))
        front_y = m2.y[k] + heading * GVT.cg_to_front
        assert heading * front_y == pytest.approx(test["ncap_impact_location"] * GVT.length)


def test_head_on_lane_change_ends_in_the_vut_lane() -> None:
    sc = PROTOCOL["scenarios"]["CCFhol"]
    lane = PROTOCOL["protocol"]["lane_width_m"]
    for _, test in _tests("CCFhol").iterrows():
        t, t_impact, _, m2 = ncap_test_motions(test, VUT, GVT, PROTOCOL)
        target = lateral_offset(test["ncap_overlap"], VUT.width, GVT.width,
                                PROTOCOL["overlap"]["negative_side"])
        assert m2.y[0] == pytest.approx(target + lane)
        done = t >= t_impact - sc["lane_change_end_before_impact_s"] - 1e-9
        np.testing.assert_allclose(m2.y[done], target, atol=1e-12)
        _, _, gap = _gap(test)
        k = int(np.argmin(np.abs(t - t_impact)))
        assert gap[k] == pytest.approx(0.0, abs=1e-9) and np.all(gap[:k] > 0)


# ------------------------------------------------------------------------------ scoring

def test_band_colours_by_hand() -> None:
    bands = PROTOCOL["assessment"]["mitigation_or_avoidance"]
    # VUT 50 km/h: 0 green, 10 yellow (inclusive), 10.1 orange, 30 brown, 30.1 red
    got = mitigation_or_avoidance_colours([0.0, 10.0, 10.1, 30.0, 30.1], 50.0, bands)
    assert got.tolist() == ["green", "yellow", "orange", "brown", "red"]
    # 80 km/h uses the 50 km/h row; 35 km/h the 30 km/h row; 15 km/h the 10 km/h row
    assert mitigation_or_avoidance_colours([25.0], 80.0, bands).tolist() == ["brown"]
    assert mitigation_or_avoidance_colours([5.0, 10.5], 35.0, bands).tolist() == ["brown", "red"]
    assert mitigation_or_avoidance_colours([0.0, 0.1], 15.0, bands).tolist() == ["green", "red"]
    assert speed_row(45.0, [10, 20, 30, 40, 50]) == 40
    assert band_colours([10.0, 20.0, 25.0], PROTOCOL["assessment"]["mitigation"][
        "reduction_bands"]).tolist() == ["red", "orange", "green"]
    pts = points_of(["green", "yellow", "orange", "brown", "red"],
                    PROTOCOL["assessment"]["points"])
    np.testing.assert_array_equal(pts, [1.0, 0.75, 0.5, 0.25, 0.0])


def _runs(case_ids: list[int], system: str, impact_kmh: list[float],
          gvt_vx: float = 0.0) -> pd.DataFrame:
    v = np.array(impact_kmh) / KMH_PER_MS
    hit = v > 0
    return pd.DataFrame({"case_id": case_ids, "system": system, "error": "",
                         "collided": hit, "impact_speed1": np.where(hit, v, np.nan),
                         "vx1": v, "vy1": 0.0, "vx2": gvt_vx, "vy2": 0.0})


def test_measures_relative_speed_and_reduction() -> None:
    runs = _runs([1], "x", [36.0], gvt_vx=5.0)
    runs["ncap_vut_speed"] = 50.0 / KMH_PER_MS
    got = run_measures(runs).iloc[0]
    assert got["vut_impact_speed_kmh"] == pytest.approx(36.0)
    assert got["relative_impact_speed_kmh"] == pytest.approx(36.0 - 18.0)
    assert got["speed_reduction_kmh"] == pytest.approx(14.0)


def test_scenario_score_by_hand() -> None:
    cases = MATRIX.drop(columns=["kind", "accident_type"])
    ccrs = _tests("CCRs")
    # CCRs at 50 km/h: avoided (green, 1) and 25 km/h impact (brown, 0.25)
    ids = ccrs[np.isclose(ccrs["ncap_vut_speed"] * KMH_PER_MS, 50.0)]["case_id"].tolist()[:2]
    tests = assess_tests(_runs(ids, "aeb", [0.0, 25.0]), cases, PROTOCOL)
    assert tests["colour"].tolist() == ["green", "brown"]
    scores = scenario_scores(tests, PROTOCOL).set_index("scenario")
    top = PROTOCOL["scenarios"]["CCRs"]["max_points"]
    assert scores.loc["CCRs", "score"] == pytest.approx(top * (1.0 + 0.25) / 2)
    assert scores.loc["total", "score"] == pytest.approx(top * 0.625)
    assert scores.loc["total", "max_score"] == pytest.approx(top)


# ------------------------------------------------------------------------ database, study

def test_bundled_database_is_the_build_of_the_protocol_file() -> None:
    bundled = open_database("euro-ncap-c2c")
    fresh = build_euro_ncap_database(PROTOCOL)
    for name, table in fresh.tables().items():
        pd.testing.assert_frame_equal(getattr(bundled, name)[table.columns], table,
                                      check_dtype=False)
    assert bundled.meta["equip"] == "1" and bundled.meta["has_reconstruction"] is False
    # speeds agree with the positions, yaw with the direction of travel, road-vehicle limits
    found = check_plausibility(fresh)
    assert not found.errors and not found.warnings


def test_study_report_and_side_by_side_on_part_of_the_matrix(tmp_path, capsys) -> None:
    from vfs.cli import main as vfs_main
    from vfs.report.euro_ncap import SCORES_FILE, TESTS_FILE, study_tables
    from vfs.study import load_study

    ccrs = _tests("CCRs")
    ids = ccrs[ccrs["ncap_overlap"] == 1.0]["case_id"].head(3).tolist()
    study = tmp_path / "s"
    assert vfs_main(["study", "--db", "euro-ncap-c2c", "--systems", "ideal", "--out",
                     str(study), "--engine", "serial",
                     "--where", f"case_id IN ({', '.join(map(str, ids))})"]) == 0
    assert load_study(study).manifest["equip"] == "1"  # the database's meta: the VUT only
    tests, scores = study_tables(study)
    base = tests[tests["system"] == "baseline"]
    # undisturbed: every test collides at its test speed (red)
    np.testing.assert_allclose(base["vut_impact_speed_kmh"], base["vut_speed_kmh"], atol=0.1)
    assert (base["colour"] == "red").all()
    ideal = tests[tests["system"] == "ideal"]
    assert (~ideal["collided"]).all() and (ideal["colour"] == "green").all()
    assert scores.set_index(["system", "scenario"]).loc[("ideal", "CCRs"), "score_pct"] == 100

    assert vfs_main(["report", "effectiveness", str(study), "--no-case-pages",
                     "--bootstrap", "50"]) == 0
    report = (study / "report" / "report.md").read_text(encoding="utf-8")
    assert "## Euro NCAP AEB Car-to-Car" in report
    assert (study / "report" / TESTS_FILE).is_file() and (study / "report" / SCORES_FILE).is_file()

    out = tmp_path / "sbs"
    assert vfs_main(["report", "side-by-side", "--ncap", str(study), "--accidents", str(study),
                     "--out", str(out), "--bootstrap", "50"]) == 0
    table = pd.read_csv(out / "side_by_side.csv").set_index("system")
    assert table.loc["ideal", "ncap_CCRs_pct"] == 100
    assert table.loc["ideal", "acc_avoided_share"] == pytest.approx(1.0)
    assert (out / "side_by_side.md").is_file() and (out / "side_by_side.html").is_file()
    capsys.readouterr()
