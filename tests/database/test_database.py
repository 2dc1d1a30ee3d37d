"""Tests of vfs.database: schema, validation, Parquet/CSV/PCM round trips, selection, CLI."""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from vfs.cli.db import add_parsers
from vfs.database import (
    SCHEMA_VERSION,
    Database,
    PcmDefaults,
    TargetExistsError,
    export_pcm,
    import_pcm,
    load_csv_folder,
    load_database,
    save_csv_folder,
    save_database,
    select_cases,
    validate_database,
)
from vfs.database.docs import stale_blocks
from vfs.database.schema import TABLES, normalise_table
from vfs.database.validation import MAX_REPORTED_ROWS
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.physics.vehicle import yaw_inertia_axle_product
from vfs.scenarios.example_database import make_example_database
from vfs.units import G

DOC = Path(__file__).resolve().parents[2] / "docs" / "data-format.md"


# ----------------------------------------------------------------------------
# Fixtures and helpers
# ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def example_db() -> Database:
    return make_example_database(n_cases=4, seed=0)


@pytest.fixture
def saved_db(example_db: Database, tmp_path: Path) -> Path:
    return save_database(example_db, tmp_path / "db")


def corrupted(db: Database, table: str, change: Callable[[pd.DataFrame], pd.DataFrame]) -> Database:
    """Copy of ``db`` with ``change`` applied to a copy of one table."""
    return dataclasses.replace(db, **{table: change(getattr(db, table).copy())})


def load_error(db: Database, folder: Path) -> DataError:
    """Save without validation, load with validation, return the DataError."""
    save_database(db, folder, validate=False)
    with pytest.raises(DataError) as info:
        load_database(folder)
    return info.value


def find_problem(
    error: DataError, table: str, column: str, case_id: object, *fragments: str
) -> DataProblem:
    """The problem of ``error`` naming table, column and case id, also in the message."""
    text = str(error)
    for problem in error.problems:
        line = str(problem)
        if (problem.table == table and problem.column == column and problem.case_id == case_id
                and all(f in problem.message for f in fragments)):
            assert line in text
            assert f"table '{table}'" in line
            if column:
                assert f"column '{column}'" in line
            if case_id is not None:
                assert f"case_id {case_id!r}" in line
            return problem
    raise AssertionError(f"no problem ({table}, {column}, {case_id}, {fragments}) in:\n{text}")


def rows_of(df: pd.DataFrame, case_id: int, participant: int | None = None) -> pd.Series:
    mask = df["case_id"] == case_id
    if participant is not None:
        mask &= df["participant"] == participant
    return mask


def run_cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="vfs")
    add_parsers(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return int(args.func(args))


# ----------------------------------------------------------------------------
# The example database and the Database API
# ----------------------------------------------------------------------------


def test_example_database_is_valid_and_shaped(example_db: Database) -> None:
    assert validate_database(example_db) == []
    assert example_db.n_cases == 4
    assert example_db.meta["schema_version"] == SCHEMA_VERSION
    traj = example_db.trajectory(1001, 1)
    assert len(traj) == 501
    assert traj["t"].iloc[0] == 0.0 and traj["t"].iloc[-1] == 5.0
    np.testing.assert_allclose(np.diff(traj["t"]), 0.01, atol=1e-12)
    assert set(example_db.cases["accident_type"]) == {241, 601}


def test_example_reconstruction_is_physically_consistent(example_db: Database) -> None:
    """Oracles of the collinear impact: momentum conserved, energy lost, Delta-v ratio."""
    rec = example_db.reconstruction.set_index("case_id")
    v1, v2 = example_db.vehicles()
    m1 = pd.Series(v1.mass, index=example_db.case_ids)
    m2 = pd.Series(v2.mass, index=example_db.case_ids)
    momentum_before = m1 * rec["vx1"] + m2 * rec["vx2"]
    momentum_after = m1 * rec["vx1_post"] + m2 * rec["vx2_post"]
    np.testing.assert_allclose(momentum_after, momentum_before, rtol=1e-12)
    kinetic_before = 0.5 * (m1 * rec["vx1"] ** 2 + m2 * rec["vx2"] ** 2)
    kinetic_after = 0.5 * (m1 * rec["vx1_post"] ** 2 + m2 * rec["vx2_post"] ** 2)
    np.testing.assert_allclose(kinetic_before - kinetic_after, rec["energy_loss"], rtol=1e-9)
    np.testing.assert_allclose(m1 * rec["delta_v1"], m2 * rec["delta_v2"], rtol=1e-12)
    # EES: E_def = m EES^2 / 2 summed over both vehicles is the energy loss
    np.testing.assert_allclose(0.5 * (m1 * rec["ees1"] ** 2 + m2 * rec["ees2"] ** 2),
                               rec["energy_loss"], rtol=1e-12)
    # slide to rest: d = v'^2 / (2 mu g)
    mu = example_db.cases.set_index("case_id")["road_friction"]
    np.testing.assert_allclose(np.abs(rec["rest_x1"] - rec["x1"]),
                               rec["vx1_post"] ** 2 / (2 * mu * G), rtol=1e-12)
    # the trajectories end at the impact configuration
    for case_id in example_db.case_ids:
        last = example_db.trajectory(case_id, 2).iloc[-1]
        assert last["x"] == pytest.approx(rec.loc[case_id, "x2"], abs=1e-9)


def test_vehicles_aligned_and_default_inertia(example_db: Database) -> None:
    v1, v2 = example_db.vehicles()
    parts = example_db.participants
    for k, case_id in enumerate(example_db.case_ids):
        row2 = parts[rows_of(parts, case_id, 2)].iloc[0]
        assert v2.mass[k] == row2["mass"]
        # yaw_inertia of participant 2 is NaN -> default formula I = m L1 L2 (the Front-to-Side
        # Energy Balance paper)
        expected = yaw_inertia_axle_product(row2["mass"], row2["cg_to_front_axle"],
                                            row2["wheelbase"] - row2["cg_to_front_axle"],
                                            row2["length"], row2["width"], row2["wheelbase"])
        assert v2.yaw_inertia[k] == pytest.approx(float(expected))
        assert v1.yaw_inertia[k] == parts[rows_of(parts, case_id, 1)]["yaw_inertia"].iloc[0]


def test_subset_and_errors(example_db: Database) -> None:
    sub = example_db.subset([1003, 1001])
    assert list(sub.case_ids) == [1001, 1003]  # table order kept
    assert set(sub.trajectories["case_id"]) == {1001, 1003}
    assert len(sub.reconstruction) == 2
    with pytest.raises(DataError, match="unknown case_id"):
        example_db.subset([1001, 4242])
    with pytest.raises(DataError, match="no trajectory"):
        example_db.trajectory(1001, 3)


# ----------------------------------------------------------------------------
# Round trips
# ----------------------------------------------------------------------------


def test_parquet_csv_round_trip_identical(example_db: Database, tmp_path: Path) -> None:
    save_database(example_db, tmp_path / "pq")
    from_parquet = load_database(tmp_path / "pq")
    save_csv_folder(from_parquet, tmp_path / "csv")
    from_csv = load_csv_folder(tmp_path / "csv")
    for name in TABLES:
        pd.testing.assert_frame_equal(getattr(from_parquet, name), getattr(example_db, name),
                                      check_exact=True)
        pd.testing.assert_frame_equal(getattr(from_csv, name), getattr(from_parquet, name),
                                      check_exact=True)
    assert from_csv.meta == from_parquet.meta == example_db.meta
    assert from_csv.cases["road_surface"].dtype == "str"
    assert from_csv.cases["collision"].dtype == bool
    assert from_csv.trajectories["accel"].isna().sum() == 4 * 501  # participant 2: unknown


def test_extra_and_uncertainty_columns_survive(example_db: Database, tmp_path: Path) -> None:
    db = corrupted(example_db, "reconstruction", lambda df: df.assign(
        zz_new_outcome=np.arange(len(df), dtype=float), pdof1_sd=2.0, aa_note="x"))
    save_database(db, tmp_path / "pq")
    save_csv_folder(load_database(tmp_path / "pq"), tmp_path / "csv")
    loaded = load_csv_folder(tmp_path / "csv")
    columns = list(loaded.reconstruction.columns)
    # every required column and every optional one with a default (the optional
    # post-impact inputs have none: absent means the run-out's defaults)
    schema = [c.name for c in TABLES["reconstruction"].columns
              if c.required or c.default is not None]
    assert columns[:len(schema)] == schema
    # uncertainty columns in the schema order of their base columns, then extras sorted
    assert columns[len(schema):] == ["delta_v1_sd", "delta_v2_sd", "pdof1_sd", "aa_note",
                                     "zz_new_outcome"]
    np.testing.assert_array_equal(loaded.reconstruction["zz_new_outcome"], [0, 1, 2, 3])


def test_save_replaces_atomically_and_protects_other_folders(
    example_db: Database, tmp_path: Path
) -> None:
    target = tmp_path / "db"
    save_database(example_db, target)
    save_database(example_db.subset([1002]), target)  # replace an existing database
    assert load_database(target).n_cases == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"]  # no temporary folders left
    other = tmp_path / "thesis"
    other.mkdir()
    (other / "chapter1.tex").write_text("keep me")
    with pytest.raises(TargetExistsError):
        save_database(example_db, other)
    assert (other / "chapter1.tex").read_text() == "keep me"


def test_save_refuses_invalid_database(example_db: Database, tmp_path: Path) -> None:
    bad = corrupted(example_db, "cases", lambda df: df.assign(road_friction=3.0))
    with pytest.raises(DataError, match="not writing an invalid database"):
        save_database(bad, tmp_path / "db")
    assert not (tmp_path / "db").exists()


def test_pcm_round_trip(example_db: Database, tmp_path: Path) -> None:
    export_pcm(example_db, tmp_path / "pcm")
    assert sorted(p.name for p in (tmp_path / "pcm").iterdir()) == [
        "dynamics.csv", "global_data.csv", "participant_data.csv"]
    imported = import_pcm(tmp_path / "pcm")
    for name in ("participants", "trajectories", "cases"):
        pd.testing.assert_frame_equal(getattr(imported, name), getattr(example_db, name),
                                      check_exact=False, rtol=0.0, atol=1e-9)
    assert imported.reconstruction.empty
    assert list(imported.reconstruction.columns) == list(TABLES["reconstruction"].column_names)
    assert imported.meta["has_reconstruction"] is False
    report = imported.meta["pcm_import"]
    assert "participants.yaw_inertia" in report["defaults_used"]  # empty IZZ of participant 2
    assert report["skipped_cases"] == [] and report["renumbered_cases"] == []
    # the imported database is a valid vfs database and can be saved and loaded
    save_database(imported, tmp_path / "db")
    assert load_database(tmp_path / "db").meta["has_reconstruction"] is False


def test_pcm_import_with_defaults(tmp_path: Path) -> None:
    folder = tmp_path / "gidas"
    folder.mkdir()
    (folder / "PARTICIPANT_DATA.csv").write_text(
        "FALL;BETNR;WIDTH;LENGTH;DISTCGFA;WEIGHT;WHEELBASE;IZZ\n"
        "7;5;1.8;4.5;1.2;1500;2.7;2500\n"
        "7;9;1.7;4.2;1.1;1200;2.5;0\n"
        "8;1;1.7;4.2;1.1;1200;2.5;0\n"  # single-vehicle case: skipped
    )
    step = np.round(np.arange(0.0, 0.35, 0.05), 10)
    lines = ["FALL;BETNR;STEP;XPOS;YPOS;VX;VY;PSI"]
    for betnr, sign in ((5, 1.0), (9, -1.0)):
        lines += [f"7;{betnr};{t:.2f};{sign * 10 * t};0.5;10;0.5;{0 if sign > 0 else np.pi}"
                  for t in step]
    lines += ["8;1;0.0;0;0;1;0;0", "8;1;0.1;0.1;0;1;0;0"]
    (folder / "dynamics.csv").write_text("\n".join(lines) + "\n")
    db = import_pcm(folder)
    assert list(db.case_ids) == [7]
    assert sorted(db.participants["participant"]) == [1, 2]
    report = db.meta["pcm_import"]
    assert report["skipped_cases"] == [8] and report["renumbered_cases"] == [7]
    defaults = PcmDefaults()
    for column in ("participants.cg_height", "participants.front_overhang",
                   "participants.track_width", "participants.vehicle_class",
                   "cases.accident_type", "cases.road_friction", "trajectories.accel"):
        assert column in report["defaults_used"]
    part1 = db.participants.iloc[0]
    assert part1["front_overhang"] == pytest.approx(0.5 * (4.5 - 2.7))
    assert part1["cg_height"] == defaults.cg_height
    assert part1["vehicle_class"] == defaults.vehicle_class
    assert np.isnan(db.participants["yaw_inertia"].iloc[1])  # IZZ = 0 means unknown
    assert db.cases["accident_type"].iloc[0] == defaults.accident_type
    assert db.cases["road_friction"].iloc[0] == defaults.road_friction
    np.testing.assert_allclose(db.trajectories["speed"], np.hypot(10.0, 0.5))
    np.testing.assert_allclose(db.trajectory(7, 1)["t"], step)


def test_pcm_import_reports_missing_columns(tmp_path: Path) -> None:
    folder = tmp_path / "pcm"
    folder.mkdir()
    (folder / "participant_data.csv").write_text("FALL,BETNR,WIDTH\n1,1,1.8\n")
    with pytest.raises(DataError) as info:
        import_pcm(folder)
    find_problem(info.value, "participant_data", "DISTCGFA", None, "missing")
    find_problem(info.value, "dynamics", "", None, "missing")


def test_pcm_defaults_are_validated() -> None:
    with pytest.raises(ParameterError, match="accident_type"):
        PcmDefaults(accident_type=42)
    with pytest.raises(ParameterError, match="road_surface"):
        PcmDefaults(road_surface="gravel")


# ----------------------------------------------------------------------------
# Case selection with duckdb
# ----------------------------------------------------------------------------


def test_where_selection_on_parquet(example_db: Database, saved_db: Path) -> None:
    where = "accident_type = 241 AND road_friction < 1.2"
    db = load_database(saved_db, where=where)
    assert list(db.case_ids) == [1001, 1003]
    assert set(db.participants["case_id"]) == set(db.trajectories["case_id"]) == {1001, 1003}
    assert list(db.reconstruction["case_id"]) == [1001, 1003]
    in_memory = select_cases(example_db, where)
    for name in TABLES:
        pd.testing.assert_frame_equal(getattr(db, name), getattr(in_memory, name))
    none = load_database(saved_db, where="accident_type = 999")
    assert none.n_cases == 0 and none.trajectories.empty
    assert none.cases.dtypes.to_dict() == example_db.cases.dtypes.to_dict()


@pytest.mark.parametrize("where", ["no_such_column = 1", "accident_type = = 241",
                                   "1 = 1); DROP TABLE x; SELECT (1"])
def test_where_sql_error_is_data_error(saved_db: Path, example_db: Database, where: str) -> None:
    with pytest.raises(DataError) as info:
        load_database(saved_db, where=where)
    assert repr(where) in str(info.value)
    with pytest.raises(DataError):
        select_cases(example_db, where)


# ----------------------------------------------------------------------------
# Corruptions: one DataError naming table, column and case id each
# ----------------------------------------------------------------------------


def test_missing_column(example_db: Database, tmp_path: Path) -> None:
    db = corrupted(example_db, "participants", lambda df: df.drop(columns="wheelbase"))
    error = load_error(db, tmp_path / "db")
    # a missing column concerns every row: no row or case id to name
    find_problem(error, "participants", "wheelbase", None, "required column missing")


def test_value_out_of_range_names_range(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        df.loc[df["case_id"] == 1002, "road_friction"] = 2.5
        return df

    error = load_error(corrupted(example_db, "cases", change), tmp_path / "db")
    problem = find_problem(error, "cases", "road_friction", 1002, "outside the allowed range")
    assert "[0.05, 1.5]" in problem.message and "2.5" in problem.message
    assert problem.row == 1


def test_negative_mass(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        df.loc[rows_of(df, 1003, 2), "mass"] = -1200.0
        return df

    error = load_error(corrupted(example_db, "participants", change), tmp_path / "db")
    problem = find_problem(error, "participants", "mass", 1003, "negative value")
    assert "[50, 60000]" in problem.message


def test_orphaned_participant(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        extra = df.iloc[[0]].assign(case_id=9999)
        return pd.concat([df, extra], ignore_index=True)

    error = load_error(corrupted(example_db, "participants", change), tmp_path / "db")
    find_problem(error, "participants", "case_id", 9999, "orphaned")


def test_duplicate_case_id(example_db: Database, tmp_path: Path) -> None:
    db = corrupted(example_db, "cases", lambda df: pd.concat([df, df.iloc[[0]]],
                                                             ignore_index=True))
    error = load_error(db, tmp_path / "db")
    problem = find_problem(error, "cases", "case_id", 1001, "duplicate case_id")
    assert problem.row in (0, 4)


def test_nan_in_trajectory(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        df.loc[np.flatnonzero(rows_of(df, 1002, 1))[10], "x"] = np.nan
        return df

    error = load_error(corrupted(example_db, "trajectories", change), tmp_path / "db")
    find_problem(error, "trajectories", "x", 1002, "missing value")


def test_non_monotonic_time(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        rows = np.flatnonzero(rows_of(df, 1004, 2))
        df.loc[rows[[20, 21]], "t"] = df.loc[rows[[21, 20]], "t"].to_numpy()
        return df

    error = load_error(corrupted(example_db, "trajectories", change), tmp_path / "db")
    find_problem(error, "trajectories", "t", 1004, "increase strictly", "earlier")


def test_duplicate_time_and_coarse_sampling(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        rows = np.flatnonzero(rows_of(df, 1001, 1))
        df.loc[rows[5], "t"] = df.loc[rows[4], "t"]
        keep = np.ones(len(df), bool)
        keep[np.flatnonzero(rows_of(df, 1003, 2))[100:120]] = False  # a 0.21 s gap
        return df[keep]

    error = load_error(corrupted(example_db, "trajectories", change), tmp_path / "db")
    find_problem(error, "trajectories", "t", 1001, "duplicate time")
    find_problem(error, "trajectories", "t", 1003, "exceeds the allowed 0.1 s")


def test_case_with_one_participant(example_db: Database, tmp_path: Path) -> None:
    db = corrupted(example_db, "participants", lambda df: df[~rows_of(df, 1001, 2)])
    error = load_error(db, tmp_path / "db")
    find_problem(error, "participants", "participant", 1001, "no participant 2")
    find_problem(error, "trajectories", "participant", 1001, "no row in table 'participants'")


def test_wrong_schema_version(example_db: Database, tmp_path: Path) -> None:
    db = dataclasses.replace(example_db, meta={**example_db.meta, "schema_version": "0.9"})
    error = load_error(db, tmp_path / "db")
    # meta.json concerns the whole database: no case id
    find_problem(error, "meta", "schema_version", None, "unknown schema_version '0.9'")


def test_missing_meta_json(saved_db: Path) -> None:
    (saved_db / "meta.json").unlink()
    with pytest.raises(DataError) as info:
        load_database(saved_db)
    find_problem(info.value, "meta", "schema_version", None, "meta.json not found")
    assert load_database(saved_db, validate=False).n_cases == 4


def test_text_in_numeric_column_from_csv(example_db: Database, tmp_path: Path) -> None:
    save_csv_folder(example_db, tmp_path / "csv")
    file = tmp_path / "csv" / "participants.csv"
    lines = file.read_text().splitlines()
    fields = lines[3].split(",")  # data row 2 = case 1002, participant 1
    fields[2] = "heavy"
    lines[3] = ",".join(fields)
    file.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError) as info:
        load_csv_folder(tmp_path / "csv")
    find_problem(info.value, "participants", "mass", 1002, "'heavy' is not a number")


def test_layout_inconsistency(example_db: Database, tmp_path: Path) -> None:
    def change(df: pd.DataFrame) -> pd.DataFrame:
        df.loc[rows_of(df, 1002, 2), "track_width"] = 2.5  # wider than the vehicle
        return df

    error = load_error(corrupted(example_db, "participants", change), tmp_path / "db")
    find_problem(error, "participants", "track_width", 1002, "exceeds width")


def test_collision_reconstruction_consistency(example_db: Database, tmp_path: Path) -> None:
    def near_miss(df: pd.DataFrame) -> pd.DataFrame:
        df.loc[df["case_id"] == 1003, "collision"] = False
        return df

    db = corrupted(example_db, "cases", near_miss)
    db = corrupted(db, "reconstruction", lambda df: df[df["case_id"] != 1002])
    error = load_error(db, tmp_path / "db")
    find_problem(error, "reconstruction", "case_id", 1002, "collision=True but no reconstruction")
    find_problem(error, "reconstruction", "case_id", 1003, "collision=False")
    # without reconstruction (e.g. a PCM import) the check is skipped
    flagged = dataclasses.replace(db, meta={**db.meta, "has_reconstruction": False})
    assert validate_database(flagged) == []


def test_all_problems_reported_at_once(example_db: Database, tmp_path: Path) -> None:
    db = corrupted(example_db, "cases", lambda df: df.assign(accident_type=42))
    db = corrupted(db, "trajectories", lambda df: df.assign(speed=-1.0))
    error = load_error(db, tmp_path / "db")
    assert sum(p.column == "accident_type" for p in error.problems) == 4
    speed = [p for p in error.problems if p.column == "speed"]
    # 4008 bad rows: the first MAX_REPORTED_ROWS listed, then one summary
    assert len(speed) == MAX_REPORTED_ROWS + 1
    assert speed[-1].message.startswith(f"... and {4008 - MAX_REPORTED_ROWS} more rows")


def test_normalise_fills_defaults_and_orders_columns() -> None:
    raw = pd.DataFrame({"collision": ["true", "False"], "case_id": [2.0, 1.0],
                        "extra": [1, 2], "road_surface": ["dry", None]})
    norm = normalise_table(raw, "cases")
    assert list(norm.columns) == ["case_id", "road_surface", "weight", "collision",
                                  "description", "extra"]
    assert norm["case_id"].dtype == np.int64 and norm["collision"].tolist() == [True, False]
    assert norm["weight"].tolist() == [1.0, 1.0] and norm["road_surface"].tolist() == ["dry", ""]


# ----------------------------------------------------------------------------
# Documentation and command line
# ----------------------------------------------------------------------------


def test_doc_tables_in_sync_with_schema() -> None:
    assert stale_blocks(DOC) == [], "run: python -m vfs.database.docs docs/data-format.md"


def test_cli_validate(saved_db: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["db", "validate", str(saved_db)]) == 0
    assert capsys.readouterr().out.startswith("OK: 4 cases")
    meta = json.loads((saved_db / "meta.json").read_text())
    (saved_db / "meta.json").write_text(json.dumps({**meta, "schema_version": "7"}))
    assert run_cli(["db", "validate", str(saved_db)]) == 1
    assert "unknown schema_version '7'" in capsys.readouterr().out
    assert run_cli(["db", "validate", "default"]) == 0  # the bundled database
    assert capsys.readouterr().out.startswith("OK: 600 cases")


def test_cli_convert_and_import(
    saved_db: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_cli(["db", "convert", str(saved_db), str(tmp_path / "csv"), "--to", "csv"]) == 0
    assert run_cli(["db", "convert", str(tmp_path / "csv"), str(tmp_path / "pcm"),
                    "--to", "pcm"]) == 0
    assert run_cli(["db", "import-pcm", str(tmp_path / "pcm"), str(tmp_path / "back")]) == 0
    assert "imported 4 cases" in capsys.readouterr().out
    assert run_cli(["db", "validate", str(tmp_path / "back")]) == 0
    assert run_cli(["db", "validate", str(tmp_path / "pcm")]) == 0
    assert run_cli(["db", "validate", str(tmp_path)]) == 1  # not a database folder
