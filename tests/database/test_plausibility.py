"""Physical plausibility checks: each rule has a failing and a passing database."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vfs.cli import main
from vfs.database import open_database
from vfs.database.plausibility import PlausibilityLimits, check_plausibility
from vfs.errors import DataError
from vfs.units import KMH_PER_MS


@pytest.fixture(scope="module")
def db():
    return open_database("default", where="case_id <= 40")


def _with(db, **tables):
    return dataclasses.replace(db, **tables)


def _messages(problems):
    return " | ".join(str(p) for p in problems)


def test_bundled_and_generated_databases_are_plausible(db):
    for name in ("default", "crash-tests"):
        found = check_plausibility(open_database(name))
        assert found.errors == [] and found.warnings == [], name
    from vfs.scenarios.generator import generate_database

    for preset in ("study36", "clean"):
        found = check_plausibility(generate_database(preset, seed=5)[0])
        assert found.errors == [] and found.warnings == [], preset


def test_a_position_jump_is_an_error(db):
    tr = db.trajectories.copy()
    row = tr.index[(tr.case_id == 5) & (tr.participant == 1)][20]
    tr.loc[row, "x"] += 1000.0
    found = check_plausibility(_with(db, trajectories=tr))
    assert any(p.column == "x" and p.case_id == 5 and "jump" in p.message for p in found.errors)
    # loading rejects it: nothing implausible is simulated
    from vfs.database import validate_database

    assert any("jump" in p.message for p in validate_database(_with(db, trajectories=tr)))
    # a step of a few metres more than the speeds allow is noise, not a jump
    tr = db.trajectories.copy()
    tr.loc[row, "x"] += 3.0
    found = check_plausibility(_with(db, trajectories=tr))
    assert not any("jump" in p.message for p in found.errors)
    assert any(p.case_id == 5 and p.column == "speed" for p in found.warnings)


@pytest.mark.parametrize("scope", ["one case", "all cases"])
def test_speeds_in_kmh_are_an_error(db, scope):
    tr = db.trajectories.copy()
    mask = (tr.case_id == 7) if scope == "one case" else np.ones(len(tr), bool)
    tr.loc[mask, "speed"] *= KMH_PER_MS
    found = check_plausibility(_with(db, trajectories=tr))
    kmh = [p for p in found.errors if p.column == "speed" and "km/h" in p.message]
    assert kmh and (scope == "all cases" or {p.case_id for p in kmh} == {7})
    assert "3.60 x" in kmh[0].message


@pytest.mark.parametrize("scope", ["one case", "all cases"])
def test_yaw_in_degrees_is_an_error(db, scope):
    tr = db.trajectories.copy()
    mask = (tr.case_id == 9) if scope == "one case" else np.ones(len(tr), bool)
    tr.loc[mask, "yaw"] = np.degrees(tr.loc[mask, "yaw"])
    found = check_plausibility(_with(db, trajectories=tr))
    deg = [p for p in found.errors if p.column == "yaw" and "degrees" in p.message]
    assert deg and (scope == "all cases" or {p.case_id for p in deg} == {9})


def test_a_reversing_vehicle_is_a_warning_not_an_error(db):
    tr = db.trajectories.copy()
    mask = tr.case_id == 11
    tr.loc[mask, "yaw"] = tr.loc[mask, "yaw"] + np.pi  # driving backwards
    found = check_plausibility(_with(db, trajectories=tr))
    assert not any(p.case_id == 11 and p.column == "yaw" for p in found.errors)
    assert any(p.case_id == 11 and "direction of travel" in p.message for p in found.warnings)


def test_limits_of_road_vehicles(db):
    lim = PlausibilityLimits()
    tr = db.trajectories.copy()
    rows = tr.index[(tr.case_id == 3) & (tr.participant == 2)]
    # a speed of 120 m/s held for the whole record (positions consistent with it)
    t = tr.loc[rows, "t"].to_numpy()
    tr.loc[rows, "speed"] = 120.0
    tr.loc[rows, "x"] = tr.loc[rows[0], "x"] + 120.0 * (t - t[0])
    tr.loc[rows, "y"] = tr.loc[rows[0], "y"]
    tr.loc[rows, "yaw"] = 0.0
    found = check_plausibility(_with(db, trajectories=tr))
    assert any(p.case_id == 3 and f"limit {lim.speed_error:g} m/s" in p.message
               for p in found.errors)
    # 70 m/s only warns
    tr.loc[rows, "speed"] = 70.0
    tr.loc[rows, "x"] = tr.loc[rows[0], "x"] + 70.0 * (t - t[0])
    found = check_plausibility(_with(db, trajectories=tr))
    assert not any(p.case_id == 3 and "limit" in p.message for p in found.errors)
    assert any(p.case_id == 3 and f"warning limit {lim.speed_warning:g}" in p.message
               for p in found.warnings)


def test_impact_time_outside_the_trajectories_and_far_poses(db):
    rec = db.reconstruction.copy()
    rec.loc[rec.index[0], "t_impact"] = 500.0
    rec.loc[rec.index[1], "x1"] += 20.0
    found = check_plausibility(_with(db, reconstruction=rec))
    first, second = rec["case_id"].iloc[0], rec["case_id"].iloc[1]
    assert any(p.case_id == first and p.column == "t_impact" for p in found.errors)
    assert any(p.case_id == second and p.column == "x1" and "20.00 m" in p.message
               for p in found.warnings)


def test_empty_database_fails_validate_but_an_empty_selection_loads(tmp_path, capsys):
    from vfs.database import save_database

    empty = open_database("default", where="case_id < 0")
    assert empty.n_cases == 0  # a selection may match nothing
    assert check_plausibility(empty, require_cases=False).errors == []
    assert "empty" in _messages(check_plausibility(empty).errors)
    save_database(empty, tmp_path / "empty")
    assert main(["db", "validate", str(tmp_path / "empty")]) == 1
    assert "the database is empty" in capsys.readouterr().out


def test_validate_strict_turns_warnings_into_errors(db, tmp_path, capsys):
    from vfs.database import save_database

    tr = db.trajectories.copy()
    tr.loc[tr.case_id == 11, "yaw"] += np.pi
    save_database(_with(db, trajectories=tr), tmp_path / "rev")
    assert main(["db", "validate", str(tmp_path / "rev")]) == 0
    assert "plausibility warning" in capsys.readouterr().out
    assert main(["db", "validate", str(tmp_path / "rev"), "--strict"]) == 1
    tr.loc[tr.case_id == 7, "speed"] *= KMH_PER_MS
    with pytest.raises(DataError, match="km/h"):
        save_database(_with(db, trajectories=tr), tmp_path / "kmh")


def _interpolate_reference(traj, p, case_ids, times):
    """Linear interpolation between the as-of samples of pandas.merge_asof (backward and
    forward by case): the reference of the sort-based matching in the checks."""
    import pandas as pd

    sub = traj.loc[traj["participant"] == p, ["case_id", "t", "x", "y"]]
    want = pd.DataFrame({"case_id": case_ids, "t": times, "_k": np.arange(case_ids.size)})
    want = want.sort_values("t")
    side = {}
    for direction, tag in (("backward", "0"), ("forward", "1")):
        known = sub.rename(columns={"x": f"x{tag}", "y": f"y{tag}"}).assign(
            **{f"t{tag}": sub["t"]}).sort_values("t")
        side[tag] = pd.merge_asof(want, known, on="t", by="case_id",
                                  direction=direction).sort_values("_k")
    t0, x0, y0 = (side["0"][c].to_numpy(float) for c in ("t0", "x0", "y0"))
    t1, x1, y1 = (side["1"][c].to_numpy(float) for c in ("t1", "x1", "y1"))
    t = np.asarray(times, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(t1 > t0, (t - t0) / (t1 - t0), 0.0)
    w = np.nan_to_num(np.clip(w, 0.0, 1.0))
    return x0 + w * (x1 - x0), y0 + w * (y1 - y0)


@pytest.mark.parametrize("seed", range(40))
def test_positions_at_impact_times_match_merge_asof_interpolation(seed):
    import pandas as pd

    from vfs.database import plausibility

    rng = np.random.default_rng(seed)
    rows = []
    for case in range(int(rng.integers(1, 8))):
        for p in (1, 2):
            if p == 2 and rng.random() < 0.2:
                continue  # a case without participant 2: NaN positions
            t = np.sort(rng.choice(np.arange(0.0, 10.0, 0.5), size=int(rng.integers(1, 7)),
                                   replace=False))
            rows += [(case * 7 + 3, p, ti, rng.normal(), rng.normal()) for ti in t]
    traj = pd.DataFrame(rows, columns=["case_id", "participant", "t", "x", "y"])
    traj = traj.sample(frac=1.0, random_state=seed).reset_index(drop=True)  # any row order
    ids = rng.choice(traj["case_id"].unique(), size=int(rng.integers(1, 9)))
    times = rng.choice(np.arange(-1.0, 11.0, 0.25), size=ids.size)  # on samples, between, out
    for p in (1, 2):
        got = plausibility._interpolate(traj, p, ids, times)  # noqa: SLF001
        want = _interpolate_reference(traj, p, ids, times)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
