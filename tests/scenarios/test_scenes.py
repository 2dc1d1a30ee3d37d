"""Synthetic accident scenes (vfs.scenarios.scenes and its parts): tables, fleet, paths, replay,
placement."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vfs.scenarios.scenes as sm
from vfs.database import Database, validate_database
from vfs.database.paths import paths_from_trajectories
from vfs.database.schema import TABLES, empty_table, normalise_table
from vfs.errors import ParameterError, SimulationError
from vfs.physics.geometry import AREA_TOLERANCE, outline_corners, outline_distance, overlap
from vfs.physics.paths import concat_paths
from vfs.physics.precrash import PrecrashParams, simulate_precrash
from vfs.physics.vehicle import validate_vehicle_values
from vfs.scenarios.catalogue import SCENARIO_TYPES, ScenarioSpec
from vfs.scenarios.fleet import FLEET, FleetClass, sample_fleet
from vfs.scenarios.placement import slide_to_contact
from vfs.scenarios.scenes import SceneTables, generate_scenes
from vfs.units import G

ALL_TYPES = {code: 1.0 for code in SCENARIO_TYPES}
HEAD_ON = (241, 242, 243, 264)
DT = 0.01
N_PER_TYPE = 24
NEAR_SHARE = 0.25


@pytest.fixture(scope="module")
def scenes() -> SceneTables:
    """A small mixed sample: every type, a quarter of them near misses."""
    return generate_scenes(N_PER_TYPE * len(ALL_TYPES), np.random.default_rng(20240601),
                           ALL_TYPES, near_miss_share=NEAR_SHARE, wet_share=0.4)


@pytest.fixture(scope="module")
def replay(scenes: SceneTables):
    """Full replay of every case with the pre-crash simulation (no controller)."""
    db = _database(scenes)
    ids = db.case_ids
    paths = concat_paths(paths_from_trajectories(db.trajectories, ids, 1),
                         paths_from_trajectories(db.trajectories, ids, 2))
    v1, v2 = db.vehicles()
    return simulate_precrash(v1, v2, paths, db.cases["road_friction"].to_numpy(),
                             params=PrecrashParams(extra_time=0.0))


def _database(scenes: SceneTables) -> Database:
    return Database(scenes.cases, scenes.participants, scenes.trajectories,
                    empty_table("reconstruction"),
                    meta={"schema_version": "1.0", "has_reconstruction": False})


def _at_t_star(scenes: SceneTables) -> pd.DataFrame:
    """Trajectory samples at t* of both participants, wide (suffix 1/2), in case order."""
    tr = scenes.trajectories.merge(scenes.design[["case_id", "t_star"]], on="case_id")
    at = tr[np.isclose(tr["t"], tr["t_star"], atol=1e-9)]
    wide = at.pivot(index="case_id", columns="participant",
                    values=["x", "y", "yaw", "speed"])
    wide.columns = [f"{name}{p}" for name, p in wide.columns]
    return wide.reindex(scenes.design["case_id"]).reset_index()


# ----------------------------------------------------------------------------
# Tables
# ----------------------------------------------------------------------------


def test_deterministic_for_a_seed_and_different_for_another():
    a = generate_scenes(21, np.random.default_rng(5), ALL_TYPES, near_miss_share=0.3)
    b = generate_scenes(21, np.random.default_rng(5), ALL_TYPES, near_miss_share=0.3)
    c = generate_scenes(21, np.random.default_rng(6), ALL_TYPES, near_miss_share=0.3)
    for name in SceneTables._fields:
        pd.testing.assert_frame_equal(getattr(a, name), getattr(b, name))
    assert not np.allclose(a.participants["mass"], c.participants["mass"])
    assert not a.trajectories["x"].equals(c.trajectories["x"])


def test_tables_are_normalised_and_valid(scenes):
    for name in ("cases", "participants", "trajectories"):
        frame = getattr(scenes, name)
        pd.testing.assert_frame_equal(normalise_table(frame, name), frame)
        assert list(frame.columns) == list(TABLES[name].column_names)
    assert validate_database(_database(scenes)) == []
    cases = scenes.cases
    assert cases["case_id"].tolist() == list(range(1, len(cases) + 1))
    assert (cases["weight"] == 1.0).all()
    assert (cases["road_curvature"][~cases["accident_type"].isin([242, 243])] == 0.0).all()
    assert (cases.loc[cases["accident_type"] == 242, "road_curvature"] < 0).all()
    assert (cases.loc[cases["accident_type"] == 243, "road_curvature"] > 0).all()
    assert cases["description"].str.len().min() > 20
    assert scenes.design["case_id"].tolist() == cases["case_id"].tolist()


def test_type_counts_follow_the_shares_and_the_order_is_shuffled():
    out = generate_scenes(10, np.random.default_rng(1), {241: 0.5, 601: 0.3, 321: 0.2})
    assert out.cases["accident_type"].value_counts().to_dict() == {241: 5, 601: 3, 321: 2}
    # largest remainder, ties by code: 7 cases over 3 equal shares -> 3, 2, 2
    counts = sm._largest_remainder(7, np.array([1.0, 1.0, 1.0]))
    assert counts.tolist() == [3, 2, 2]
    assert sm._largest_remainder(100, np.array([0.2, 0.0, 0.8])).tolist() == [20, 0, 80]


def test_every_type_with_its_share_and_near_misses(scenes):
    cases = scenes.cases
    counts = cases["accident_type"].value_counts()
    assert set(counts.index) == set(SCENARIO_TYPES)
    assert (counts == N_PER_TYPE).all()
    near = ~cases["collision"]
    assert near.groupby(cases["accident_type"]).sum().eq(round(N_PER_TYPE * NEAR_SHARE)).all()
    # not sorted by type
    assert not cases["accident_type"].is_monotonic_increasing
    design = scenes.design
    assert (design.loc[near.to_numpy(), "overlap"] <= -0.2 + 1e-12).all()
    assert (cases.loc[near, "description"].str.startswith("near miss")).all()


def test_first_case_id_and_sample_interval():
    out = generate_scenes(7, np.random.default_rng(3), ALL_TYPES, sample_interval=0.05,
                          first_case_id=1001)
    assert out.cases["case_id"].tolist() == list(range(1001, 1008))
    t_star = out.design["t_star"].to_numpy()
    assert np.allclose(np.round(t_star / 0.05) * 0.05, t_star)
    for _, g in out.trajectories.groupby(["case_id", "participant"]):
        assert np.allclose(np.diff(g["t"]), 0.05)


def test_zero_cases_give_empty_valid_tables():
    out = generate_scenes(0, np.random.default_rng(0), {241: 1.0})
    assert len(out.cases) == len(out.participants) == len(out.trajectories) == 0
    assert validate_database(_database(out)) == []


# ----------------------------------------------------------------------------
# Fleet and road
# ----------------------------------------------------------------------------


def test_fleet_masses_layouts_and_correlation():
    fleet = sample_fleet(3000, np.random.default_rng(9))
    # every vehicle column except the optional fixed-object flag (a sampled fleet is cars)
    assert list(fleet.columns) == [c for c in TABLES["participants"].column_names
                                   if c not in ("case_id", "participant", "fixed_object")]
    assert fleet["mass"].between(800.0, 2600.0).all()
    assert fleet["yaw_inertia"].isna().all()
    assert (fleet["vehicle_class"] == "car").all()
    for row in fleet.head(500).to_dict("records"):
        row["yaw_inertia"] = None
        assert validate_vehicle_values(row) == []
    ratio = fleet["cg_to_front_axle"] / fleet["wheelbase"]
    assert ratio.between(0.38, 0.48).all()
    margin = fleet["width"] - fleet["track_width"]
    assert margin.between(0.2, 0.3).all()
    assert fleet["front_overhang"].add(fleet["wheelbase"]).lt(fleet["length"]).all()
    assert np.corrcoef(fleet["mass"], fleet["length"])[0, 1] > 0.4
    assert sum(c.share for c in FLEET) == pytest.approx(1.0)
    assert fleet["cg_height"].max() > 0.62  # SUVs and vans sit higher
    assert fleet.equals(sample_fleet(3000, np.random.default_rng(9)))


def test_participants_are_valid_fleet_vehicles(scenes):
    parts = scenes.participants
    assert parts["mass"].between(800.0, 2600.0).all()
    assert parts["yaw_inertia"].isna().all()
    assert scenes.design["segment1"].isin([c.name for c in FLEET]).all()


def test_wet_and_dry_roads(scenes):
    cases = scenes.cases
    wet = cases["road_surface"] == "wet"
    assert wet.any() and (~wet).any()
    assert cases.loc[wet, "road_friction"].between(0.4, 0.65).all()
    assert cases.loc[~wet, "road_friction"].between(0.7, 1.0).all()
    assert cases["road_surface"].isin(["dry", "wet"]).all()


# ----------------------------------------------------------------------------
# Records
# ----------------------------------------------------------------------------


def test_records_time_axis(scenes):
    tr = scenes.trajectories
    design = scenes.design.set_index("case_id")
    g = tr.groupby(["case_id", "participant"])
    first, last, size = g["t"].min(), g["t"].max(), g["t"].size()
    assert (first == 0.0).all()
    cid = first.index.get_level_values("case_id")
    t_star = design.loc[cid, "t_star"].to_numpy()
    assert (t_star >= 5.0 - 1e-9).all() and (t_star <= 6.0 + 1e-9).all()
    assert np.allclose(np.round(t_star / DT) * DT, t_star)
    after = np.where(design.loc[cid, "collision"], 0.3, 1.0)
    assert np.allclose(last.to_numpy(), t_star + after)
    assert np.array_equal(size.to_numpy(), np.round(last.to_numpy() / DT).astype(int) + 1)
    dt = g["t"].diff().dropna()
    assert np.allclose(dt, DT, atol=1e-9)


def test_positions_consistent_with_speeds(scenes):
    tr = scenes.trajectories
    for (_, _), rec in tr.groupby(["case_id", "participant"]):
        chord = np.hypot(np.diff(rec["x"]), np.diff(rec["y"])).sum()
        v, t = rec["speed"].to_numpy(), rec["t"].to_numpy()
        travelled = np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t))
        if travelled < 1e-9:  # a standing lead
            assert chord < 1e-9
            continue
        assert chord == pytest.approx(travelled, rel=0.01)
    assert (tr["speed"] >= 0.0).all()


def test_braking_is_in_the_records(scenes):
    tr = scenes.trajectories.merge(scenes.design, on="case_id")
    for p in (1, 2):
        rec = tr[tr["participant"] == p]
        braking = rec[f"brake{p}"].to_numpy()
        start = rec[f"brake_start{p}"].to_numpy()
        decel = rec[f"brake_deceleration{p}"].to_numpy()
        t = rec["t"].to_numpy()
        accel = rec["accel"].to_numpy()
        assert np.isnan(start[~braking]).all()
        assert (accel[~braking] == 0.0).all()
        before = braking & (t <= start)
        assert (accel[before] == 0.0).all()
        assert (-accel[braking] <= decel[braking] + 1e-9).all()
        assert (decel[braking] <= rec["road_friction"].to_numpy()[braking] * G + 1e-9).all()
        assert np.nanmax(scenes.design[f"brake_start{p}"] - scenes.design["t_star"]) < -0.19
    design = scenes.design
    assert ((design["t_star"] - design["brake_start1"]).dropna() <= 1.5 + 1e-9).all()
    # braking took speed off, late braking leaves at least 30 % (standing leads aside)
    assert (design["impact_speed1"] >= 0.3 * design["travel_speed1"] - 1e-9).all()
    assert (design["impact_speed1"] < design["travel_speed1"])[design["brake1"]].all()


def test_speed_ranges_per_type(scenes):
    design = scenes.design
    for code, spec in SCENARIO_TYPES.items():
        d = design[design["accident_type"] == code]
        for p in (1, 2):
            lo, hi = getattr(spec, f"speed{p}")
            v = d[f"travel_speed{p}"]
            if code == 601 and p == 2:
                v = v[~d["standing2"]]
            assert v.between(lo - 1e-9, hi + 1e-9).all(), (code, p)
    rear = design[design["accident_type"] == 601]
    standing = rear["standing2"].to_numpy()
    assert standing.any() and (~standing).any()
    tr = scenes.trajectories
    ids = rear.loc[standing, "case_id"]
    lead = tr[tr["case_id"].isin(ids) & (tr["participant"] == 2)]
    assert (lead["speed"] == 0.0).all()
    assert (lead.groupby("case_id")["x"].nunique() == 1).all()


# ----------------------------------------------------------------------------
# Replay and impact geometry
# ----------------------------------------------------------------------------


def test_replay_collides_at_t_star_or_passes(scenes, replay):
    design = scenes.design
    crash = design["collision"].to_numpy()
    t_star = design["t_star"].to_numpy()
    assert replay.collided[crash].all()
    assert np.abs(replay.contact_time[crash] - t_star[crash]).max() <= 0.25
    assert not replay.collided[~crash].any()
    assert (replay.min_distance[~crash] >= 0.1).all()
    # the generator's own (windowed) replay agrees with the full one
    assert np.allclose(design["contact_time"].to_numpy()[crash], replay.contact_time[crash],
                       atol=1e-3)


def test_impact_headings_per_type(scenes):
    at = _at_t_star(scenes)
    design = scenes.design
    rel = np.degrees(np.abs(np.angle(np.exp(1j * (at["yaw2"] - at["yaw1"])))))
    assert np.allclose(np.radians(rel), np.abs(design["relative_heading"]), atol=1e-9)
    types = design["accident_type"].to_numpy()
    assert (np.abs(rel[np.isin(types, HEAD_ON)] - 180.0) <= 25.0).all()
    assert (rel[types == 601] <= 15.0).all()
    assert ((rel[types == 321] >= 70.0 - 1e-6) & (rel[types == 321] <= 110.0 + 1e-6)).all()
    turn = design[types == 211]
    assert (np.degrees(turn["turn_angle"]).between(15.0, 75.0)).all()
    expected = 180.0 - np.degrees(turn["turn_angle"] - turn["heading_offset2"])  # 2 evades
    assert np.allclose(rel[types == 211], expected, atol=1e-6)
    for code in HEAD_ON:
        d = design[design["accident_type"] == code]
        angle = d["drift_angle"] if code != 264 else d["steer_back_angle"]
        assert np.degrees(angle).between(0.0, 12.0 + 1e-9).all()
        assert np.degrees(d["heading_offset1"]).abs().between(0.0, 12.0 + 1e-9).all()


def test_designed_overlap_and_gap_perpendicular_to_the_relative_velocity(scenes):
    """The slide keeps the projection perpendicular to v2 - v1: overlap/gap are exact."""
    at = _at_t_star(scenes)
    design = scenes.design
    parts = scenes.participants
    dims = {}
    for p in (1, 2):
        rows = parts[parts["participant"] == p].set_index("case_id").loc[design["case_id"]]
        front = (rows["front_overhang"] + rows["cg_to_front_axle"]).to_numpy()
        dims[p] = (front, rows["length"].to_numpy() - front, rows["width"].to_numpy())
    vel = {p: at[f"speed{p}"].to_numpy()[:, None] * np.column_stack(
        [np.cos(at[f"yaw{p}"]), np.sin(at[f"yaw{p}"])]) for p in (1, 2)}
    w = vel[2] - vel[1]
    d = w / np.hypot(w[:, 0], w[:, 1])[:, None]
    e = np.column_stack([-d[:, 1], d[:, 0]])
    corners = {p: outline_corners(at[f"x{p}"], at[f"y{p}"], at[f"yaw{p}"], *dims[p])
               for p in (1, 2)}
    proj = {p: (corners[p] * e[:, None, :]).sum(axis=2) for p in (1, 2)}
    types = design["accident_type"].to_numpy()
    crash = design["collision"].to_numpy()
    # faces: front-right/front-left corners (0, 1), rear corners (2, 3)
    for code in (*HEAD_ON, 601):
        sel = (types == code) & crash
        face2 = [0, 1] if code != 601 else [2, 3]
        f1, f2 = proj[1][sel][:, [0, 1]], proj[2][sel][:, face2]
        common = np.minimum(f1.max(1), f2.max(1)) - np.maximum(f1.min(1), f2.min(1))
        narrow = np.minimum(np.ptp(f1, axis=1), np.ptp(f2, axis=1))
        assert np.allclose(common / narrow, design["overlap"][sel], atol=1e-6)
    near = ~crash
    gap = np.maximum(proj[1][near].min(1) - proj[2][near].max(1),
                     proj[2][near].min(1) - proj[1][near].max(1))
    assert np.allclose(gap, -design["overlap"][near], atol=1e-6)


def test_scenes_are_rotated_and_translated(scenes):
    design = scenes.design
    assert np.ptp(design["scene_rotation"]) > 3.0
    assert np.abs(design["x1"]).max() > 100.0


def test_lane_positions_are_plausible(scenes):
    design = scenes.design
    lane = design[["lane1", "lane2"]]
    assert lane.abs().max().max() < 3.5
    turn = design[design["accident_type"] == 211]
    assert turn["lane1"].between(-2.6, -0.2).all()
    assert design["plausible"].all()


# ----------------------------------------------------------------------------
# Specs and arguments
# ----------------------------------------------------------------------------


def test_specs_override_and_new_codes():
    fast = dataclasses.replace(SCENARIO_TYPES[241], speed1=(35.0, 36.0), brake_prob=(0.0, 0.0))
    bend = dataclasses.replace(SCENARIO_TYPES[242], description="custom bend", bend=1)
    out = generate_scenes(12, np.random.default_rng(4), {241: 1.0, 244: 1.0},
                          specs={241: fast, 244: bend})
    d = out.design
    sel = d["accident_type"] == 241
    assert d.loc[sel, "impact_speed1"].between(35.0, 36.0).all()
    assert (out.cases.loc[d["accident_type"] == 244, "road_curvature"] > 0).all()
    assert out.cases["description"].str.contains("custom bend").sum() == 6
    assert SCENARIO_TYPES[241].speed1 != (35.0, 36.0)  # the preset is unchanged


@pytest.mark.parametrize("kwargs", [
    {"n": -1}, {"n": 2.5}, {"type_shares": {}}, {"type_shares": {999: 1.0}},
    {"type_shares": {241: -1.0}}, {"type_shares": {241: 0.0}}, {"near_miss_share": 1.5},
    {"wet_share": -0.1}, {"sample_interval": 0.2}, {"sample_interval": 0.0},
    {"first_case_id": 1.5}, {"specs": {241: "fast"}}, {"rng": 42},
])
def test_bad_arguments_raise(kwargs):
    args = {"n": 3, "rng": np.random.default_rng(0), "type_shares": {241: 1.0}} | kwargs
    n, rng, shares = args.pop("n"), args.pop("rng"), args.pop("type_shares")
    with pytest.raises(ParameterError):
        generate_scenes(n, rng, shares, **args)


def test_bad_specs_and_fleet_arguments_raise():
    with pytest.raises(ParameterError):
        ScenarioSpec("x", "sideswipe", "text")
    with pytest.raises(ParameterError):
        dataclasses.replace(SCENARIO_TYPES[241], overlap=(0.8, 0.2))
    with pytest.raises(ParameterError):
        dataclasses.replace(SCENARIO_TYPES[241], brake_prob=(1.2, 0.0))
    with pytest.raises(ParameterError):
        FleetClass("bad", 0.1, mass=(900.0, 1000.0), length=(3.0, 3.2), width=(1.6, 1.7),
                   wheelbase=(2.5, 2.6), front_overhang=(0.7, 0.8), cg_ratio=(0.4, 0.45))
    with pytest.raises(ParameterError):
        sample_fleet(-2, np.random.default_rng(0))
    with pytest.raises(ParameterError):
        sample_fleet(2, np.random.RandomState(0))  # noqa: NPY002 - legacy API is rejected


def test_cases_failing_the_replay_are_redrawn_then_reported(monkeypatch):
    calls = []
    real = sm._replay

    def flaky(batch, rows, dt):  # the first replay rejects every case
        res = real(batch, rows, dt)
        calls.append(rows.size)
        if len(calls) == 1:
            return sm._Replay(np.zeros_like(res.collided), res.contact_time, res.min_distance)
        return res

    monkeypatch.setattr(sm, "_replay", flaky)
    out = generate_scenes(4, np.random.default_rng(8), {601: 1.0})
    assert calls == [4, 4]
    assert (out.design["attempts"] == 2).all()

    def never(batch, rows, dt):
        res = real(batch, rows, dt)
        return sm._Replay(np.zeros_like(res.collided), res.contact_time, res.min_distance)

    monkeypatch.setattr(sm, "_replay", never)
    with pytest.raises(SimulationError, match=r"case_id \[7, 8, 9\]"):
        generate_scenes(3, np.random.default_rng(8), {601: 1.0}, first_case_id=7)


# ----------------------------------------------------------------------------
# Contact placement (property test)
# ----------------------------------------------------------------------------

_length = st.floats(2.0, 6.0)
_width = st.floats(1.0, 2.5)
_coord = st.floats(-6.0, 6.0)
_angle = st.floats(-math.pi, math.pi)


@settings(max_examples=200, deadline=None)
@given(x=_coord, y=_coord, yaw1=_angle, yaw2=_angle, direction=_angle, l1=_length,
       l2=_length, w1=_width, w2=_width, f1=st.floats(0.3, 0.7), f2=st.floats(0.3, 0.7))
def test_slide_to_contact_makes_rectangles_touch(x, y, yaw1, yaw2, direction, l1, l2, w1, w2,
                                                 f1, f2):
    fixed = outline_corners([0.0], [0.0], [yaw1], [f1 * l1], [(1 - f1) * l1], [w1])
    moving = outline_corners([x], [y], [yaw2], [f2 * l2], [(1 - f2) * l2], [w2])
    d = np.array([[math.cos(direction), math.sin(direction)]])
    lam = slide_to_contact(fixed, moving, d)[0]
    e = np.array([-d[0, 1], d[0, 0]])
    p1, p2 = fixed[0] @ e, moving[0] @ e
    common = min(p1.max(), p2.max()) - max(p1.min(), p2.min())  # overlap across the path
    if np.isnan(lam):
        assert common <= 1e-9  # the paths never meet
        return
    placed = moving + lam * d[:, None, :]
    assert overlap(fixed, placed).area[0] <= 1e3 * AREA_TOLERANCE
    assert outline_distance(fixed, placed)[0] <= 1e-7
    if common > 0.05:  # moving on penetrates, moving back separates
        assert overlap(fixed, placed + 0.02 * d[:, None, :]).area[0] > AREA_TOLERANCE
        assert outline_distance(fixed, placed - 0.02 * d[:, None, :])[0] > 0.0
