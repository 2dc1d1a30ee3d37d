"""Post-impact inputs of the reconstruction table (``post_*`` columns).

Read from Parquet and from CSV (degrees in the files, rad in memory), carried into the
run-out (a case given locked wheels stops where a locked car stops), rejected with table,
column, case id and the allowed range when out of range, and without them the simulation
is the same bit for bit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from vfs.database import open_database, save_database
from vfs.database.io import load_csv_folder, load_database, save_csv_folder
from vfs.database.post_impact import post_impact_inputs
from vfs.database.schema import POST_IMPACT_COLUMNS, TABLES
from vfs.database.validation import validate_database, validate_table
from vfs.errors import DataError, ParameterError
from vfs.physics.runout import PostImpactInputs
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases

CASES = "case_id <= 4"


@pytest.fixture(scope="module")
def small():
    return open_database("default", where=CASES)


def _with_post(db, values: dict[str, object]):
    rec = db.reconstruction.copy()
    for name, value in values.items():
        rec[name] = value
    return dataclasses.replace(db, reconstruction=rec).normalised()


GIVEN = {"post_brake_fl1": 1.0, "post_brake_rr1": 0.2, "post_driver_brake1": 0.5,
         "post_drag_rl2": 0.1, "post_steer2": math.radians(20.0), "post_steer_onset2": 0.4}


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_post_impact_columns_survive_writing_and_reading(small, tmp_path, fmt):
    db = _with_post(small, GIVEN)
    if fmt == "parquet":
        back = load_database(save_database(db, tmp_path / "db"))
    else:
        back = load_csv_folder(save_csv_folder(db, tmp_path / "db"))
        text = (tmp_path / "db" / "reconstruction.csv").read_text()
        assert ",post_steer2," in text.splitlines()[0] + ","
        # the file holds degrees, as every angle column
        assert float(pd.read_csv(tmp_path / "db" / "reconstruction.csv")["post_steer2"][0]) \
            == pytest.approx(20.0)
    for name, value in GIVEN.items():
        np.testing.assert_allclose(back.reconstruction[name].to_numpy(float), value,
                                   rtol=1e-15, err_msg=name)
    post = post_impact_inputs(back.reconstruction, back.case_ids)
    assert post is not None and post.given
    brake = post.wheel_brake((0.8, 0.8, 0.8, 0.8))
    # vehicle 1: FL locked, RR 0.2, the others the driver's 0.5; vehicle 2: the default
    np.testing.assert_array_equal(brake[:, 0], np.tile([1.0, 0.5, 0.5, 0.2], (4, 1)))
    np.testing.assert_array_equal(brake[:, 1], 0.8)
    np.testing.assert_array_equal(post.wheel_drag()[:, 1], np.tile([0, 0, 0.1, 0], (4, 1)))
    np.testing.assert_allclose(post.steer()[:, 1], math.radians(20.0), rtol=1e-15)
    np.testing.assert_array_equal(post.onset(), [[0.0, 0.4]] * 4)


def test_parquet_field_metadata_names_the_unit(small, tmp_path):
    import pyarrow.parquet as pq

    folder = save_database(_with_post(small, GIVEN), tmp_path / "db")
    schema = pq.read_schema(folder / "reconstruction.parquet")
    meta = schema.field("post_steer2").metadata
    assert meta is not None and b"deg" in meta[b"unit"]
    assert schema.field("post_drag_rl2").metadata[b"unit"] == b"-"


@pytest.mark.parametrize("spec", POST_IMPACT_COLUMNS, ids=lambda c: c.name)
def test_a_bad_value_of_each_post_impact_column_is_rejected(small, spec):
    bad = spec.hi + (1.0 if spec.unit != "rad" else 0.5)
    db = _with_post(small, {spec.name: [np.nan, bad, np.nan, np.nan]})
    problems = [p for p in validate_database(db) if p.column == spec.name]
    assert len(problems) == 1
    p = problems[0]
    assert p.table == "reconstruction" and p.case_id == db.reconstruction["case_id"][1]
    assert spec.allowed_text() in p.message
    text = str(p)
    assert "reconstruction" in text and spec.name in text and str(p.case_id) in text
    low = spec.lo - 0.5
    problems = validate_table("reconstruction",
                              _with_post(small, {spec.name: low}).reconstruction)
    assert {p.column for p in problems} == {spec.name}


def test_a_bad_post_impact_value_refuses_to_load(small, tmp_path):
    db = _with_post(small, {"post_brake_fl1": 1.5})
    with pytest.raises(DataError, match="post_brake_fl1"):
        save_database(db, tmp_path / "db")


def test_schema_documents_unit_and_default_of_every_post_impact_column():
    spec = TABLES["reconstruction"]
    for col in POST_IMPACT_COLUMNS:
        assert spec.column(col.name) is col and not col.required and col.nullable
        assert "absent" in col.description and col.unit in ("-", "rad", "s")
    assert spec.column("post_steer1").stored_unit == "deg"


def _run(db, **kwargs):
    batch = CaseBatch.from_database(db)
    return batch, results_table(batch, simulate_cases(batch, params=SimulationParams(**kwargs)))


def test_without_values_the_simulation_is_the_same_bit_for_bit(small):
    plain = _run(small)[1]
    empty = {c.name: np.nan for c in POST_IMPACT_COLUMNS}
    batch, nan_table = _run(_with_post(small, empty))
    assert batch.post_impact is None
    pd.testing.assert_frame_equal(plain, nan_table, check_exact=True)
    # the defaults written out are the defaults
    defaults = {f"post_driver_brake{i}": 0.8 for i in (1, 2)}
    defaults.update({c.name: 0.0 for c in POST_IMPACT_COLUMNS
                     if c.name.startswith(("post_drag", "post_steer"))})
    batch, given = _run(_with_post(small, defaults))
    assert batch.post_impact is not None
    pd.testing.assert_frame_equal(plain, given, check_exact=True)


def test_locked_wheels_from_the_data_shorten_the_run_out(small):
    plain = _run(small)[1]
    locked = {f"post_driver_brake{i}": 1.0 for i in (1, 2)}
    table = _run(_with_post(small, locked))[1]
    for i in (1, 2):
        assert (table[f"runout_distance{i}"] <= plain[f"runout_distance{i}"] + 1e-9).all()
        assert (table[f"delta_v{i}"] == plain[f"delta_v{i}"]).all()  # the impact is the same
    assert (table["runout_distance1"] < plain["runout_distance1"]).any()


def test_steering_from_the_data_reaches_the_run_out_with_and_without_the_pair_check(small):
    steer = {"post_steer1": math.radians(25.0), "post_driver_brake1": 0.0}
    a = _run(_with_post(small, steer))[1]
    b = _run(_with_post(small, steer), secondary_collisions=False)[1]
    plain = _run(small)[1]
    for col in ("rest_x1", "rest_y1", "rest_yaw1", "rest_x2", "rest_y2"):
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)
    assert not np.allclose(a["rest_yaw1"], plain["rest_yaw1"])


def test_post_impact_inputs_check_their_shapes_and_ranges():
    good = PostImpactInputs.unknown(3)
    assert not good.given and good.take([0, 2]).size == 2
    with pytest.raises(ParameterError, match="shape"):
        PostImpactInputs(np.zeros((3, 2, 4)), np.zeros((3, 2)), np.zeros((3, 2, 3)),
                         np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ParameterError, match=r"steer_angle\[1, 0\]"):
        steer = np.zeros((3, 2))
        steer[1, 0] = 2.0
        PostImpactInputs(np.zeros((3, 2, 4)), np.zeros((3, 2)), np.zeros((3, 2, 4)), steer,
                         np.zeros((3, 2)))
