"""The outcome vocabulary (vfs.outcomes) and the SI reconstruction (degrees only in files)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.database import load_csv_folder, load_database, save_csv_folder, save_database
from vfs.database.schema import RECONSTRUCTION, table_from_file_units, table_to_file_units
from vfs.errors import ParameterError
from vfs.outcomes import (
    OUTCOMES,
    OUTPUT_GROUPS,
    QUANTITIES,
    difference,
    from_reconstruction,
    from_results,
    get_outcome,
    result_columns,
    unit_factors,
)
from vfs.scenarios.example_database import make_example_database
from vfs.scenarios.generator import NO_NOISE, generate_database, reconstruction_rows
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases
from vfs.units import KMH_PER_MS

ANGLES = ("pdof1", "pdof2", "velocity_angle_change1", "velocity_angle_change2")
finite = st.floats(-1e6, 1e6, allow_nan=False)


@pytest.fixture(scope="module")
def clean():
    """A clean database (no hidden effect, no noise) and its simulation."""
    db, _ = generate_database("clean", n_cases=20, seed=3, noise=NO_NOISE)
    ids = db.reconstruction["case_id"].to_numpy()
    batch = CaseBatch.from_database(db, ids)
    return db, batch, simulate_cases(batch, params=SimulationParams())


# ------------------------------------------------------------------ vocabulary


def test_units_come_from_the_quantity_kinds():
    assert QUANTITIES["speed"].display_unit == "km/h"
    assert QUANTITIES["speed"].display_factor == KMH_PER_MS
    assert QUANTITIES["angle"].si_unit == "rad" and QUANTITIES["angle"].display_unit == "deg"
    assert QUANTITIES["angle"].to_display(math.pi) == pytest.approx(180.0, rel=1e-15)
    for o in OUTCOMES:
        q = QUANTITIES[o.quantity]
        assert (o.unit, o.display_unit, o.display_factor) == (
            q.si_unit, q.display_unit, q.display_factor)
        assert o.wrap == (o.quantity == "angle" and o.name != "velocity_angle_change")
    names = [o.name for o in OUTCOMES]
    assert len(names) == len(set(names)) and "runout_distance" in names
    assert not {"runout_displacement", "rest_distance"} & set(names)
    with pytest.raises(ParameterError, match="runout_distance"):
        get_outcome("rest_distance")


def test_user_units_convert_to_si():
    f = unit_factors()
    assert f["km/h"] == ("speed", 1.0 / KMH_PER_MS) and f["kmh"] == f["km/h"]
    assert f["deg"][0] == "angle" and f["deg"][1] == pytest.approx(math.pi / 180.0, rel=1e-15)
    assert f["kj"] == ("energy", 1e3) and f["m"] == ("length", 1.0)
    assert "-" not in f and "%" not in f  # ambiguous: several quantities


@given(st.sampled_from(sorted(QUANTITIES)), finite)
def test_display_conversion_round_trips(name, value):
    q = QUANTITIES[name]
    back = float(q.from_display(q.to_display(value)))
    assert back == pytest.approx(value, rel=4e-16, abs=1e-300)


def test_columns_exist_in_results_and_reconstruction(clean):
    _, batch, res = clean
    table = results_table(batch, res)
    cols = result_columns(res)
    schema = set(RECONSTRUCTION.column_names)
    for o in OUTCOMES:
        for i in o.vehicles:
            for c in o.columns_of(i):
                assert c in table.columns and c in cols, (o.name, c)
                assert c in schema or o.name == "closing_speed", (o.name, c)
            for c in o.sd_columns_of(i):
                assert c.removesuffix("_sd") in schema, (o.name, c)
    for g in OUTPUT_GROUPS.values():
        assert len({m.quantity for m in g.members}) == 1


# ------------------------------------------------------------------ derivation


def test_results_without_a_table_equal_the_results_table(clean):
    _, batch, res = clean
    direct = from_results(res)
    via_table = from_results(results_table(batch, res))
    assert direct.keys() == via_table.keys() == {o.name for o in OUTCOMES}
    for name, values in direct.items():
        np.testing.assert_array_equal(values, via_table[name], err_msg=name)


def test_results_and_their_reconstruction_give_the_same_outcomes(clean, tmp_path):
    """Reconstruction rows written from a simulation (the generator), in memory and
    through the files (degrees), give exactly the values derived from the results."""
    db, batch, res = clean
    rows = np.arange(batch.size)
    rec = reconstruction_rows(batch, res, rows, res.restitution, res.contact_friction)
    model = from_results(res)
    stored = {c: RECONSTRUCTION.column(c).as_stored(res.impact.columns()[c])
              for c in ANGLES}
    model_stored = from_results({**result_columns(res), **stored})
    save_database(db, tmp_path / "db")
    loaded = load_database(tmp_path / "db").reconstruction
    for source, recorded in (("memory", from_reconstruction(rec)),
                             ("database", from_reconstruction(db.reconstruction)),
                             ("files", from_reconstruction(loaded))):
        assert set(recorded) == set(model) - {"closing_speed"}, source
        for name, values in recorded.items():
            expect = (model if source == "memory" else model_stored)[name]
            np.testing.assert_array_equal(values, expect, err_msg=f"{source} {name}")


@given(st.lists(st.tuples(finite, finite, finite, finite, st.sampled_from(["full", "sliding",
                                                                           "none"])),
                min_size=1, max_size=20))
def test_one_derivation_for_both_sources(rows):
    """Any values under the shared column names give the same outcomes from both sides."""
    a = np.array([r[:4] for r in rows], float)
    cols = {"vx1_post": a[:, 0], "vy1_post": a[:, 1], "rest_x1": a[:, 2], "rest_y1": a[:, 3],
            "x1": a[:, 1], "y1": a[:, 0], "impact_type": np.array([r[4] for r in rows])}
    for c in ("vx2_post", "vy2_post", "rest_x2", "rest_y2", "x2", "y2"):
        cols[c] = a[:, 3]
    names = ("post_speed", "post_direction", "runout_distance", "sliding")
    model = from_results(cols, names)
    recorded = from_reconstruction(pd.DataFrame(cols), names)
    for name in names:
        np.testing.assert_array_equal(model[name], recorded[name])
    np.testing.assert_array_equal(model["post_speed"][:, 0], np.hypot(a[:, 0], a[:, 1]))
    np.testing.assert_array_equal(model["runout_distance"][:, 0],
                                  np.hypot(a[:, 2] - a[:, 1], a[:, 3] - a[:, 0]))
    kind = cols["impact_type"]
    assert np.array_equal(model["sliding"][:, 0] == 1.0, kind == "sliding")
    assert np.array_equal(np.isnan(model["sliding"][:, 0]), kind == "none")


@given(st.floats(-math.pi, math.pi), st.floats(-3 * math.pi, 3 * math.pi))
def test_angle_differences_wrap(reference, delta):
    pdof, dv = get_outcome("pdof"), get_outcome("delta_v")
    d = float(difference(pdof, reference + delta, reference))
    assert -math.pi - 1e-12 <= d <= math.pi + 1e-12
    assert math.isclose(math.cos(d), math.cos(delta), abs_tol=1e-9)
    assert math.isclose(math.sin(d), math.sin(delta), abs_tol=1e-9)
    assert float(difference(dv, reference + delta, reference)) == (reference + delta) - reference


# ------------------------------------------------------------------ SI inside, degrees in files


@settings(max_examples=300)
@given(st.lists(st.floats(-math.pi, math.pi), min_size=1, max_size=50))
def test_file_units_round_trip_exactly(values):
    spec = RECONSTRUCTION.column("pdof1")
    assert (spec.unit, spec.stored_unit) == ("rad", "deg")
    stored = spec.as_stored(values)
    np.testing.assert_array_equal(spec.from_file(spec.to_file(stored)), stored)
    np.testing.assert_allclose(spec.to_file(values), np.degrees(values), rtol=1e-15, atol=1e-13)
    df = pd.DataFrame({"case_id": np.arange(len(values)), "pdof1": stored,
                       "pdof1_sd": np.abs(stored), "rest_yaw1": stored})
    back = table_from_file_units(table_to_file_units(df, "reconstruction"), "reconstruction")
    pd.testing.assert_frame_equal(back, df, check_exact=True)


def test_files_keep_degrees_and_loading_gives_rad(tmp_path):
    db = make_example_database(n_cases=6, seed=2)
    assert db.reconstruction["pdof2"].abs().max() == pytest.approx(math.pi)
    for save, load, name in ((save_database, load_database, "reconstruction.parquet"),
                             (save_csv_folder, load_csv_folder, "reconstruction.csv")):
        folder = save(db, tmp_path / name)
        raw = (pq.read_table(folder / name).to_pandas() if name.endswith("parquet")
               else pd.read_csv(folder / name))
        np.testing.assert_array_equal(raw["pdof2"], np.degrees(db.reconstruction["pdof2"]))
        np.testing.assert_array_equal(raw["rest_yaw1"], db.reconstruction["rest_yaw1"])  # rad
        again = load(folder)
        pd.testing.assert_frame_equal(again.reconstruction, db.reconstruction, check_exact=True)


def test_validation_checks_the_file_range(tmp_path):
    from dataclasses import replace

    from vfs.database import validate_database

    db = make_example_database(n_cases=2, seed=0)
    bad = db.reconstruction.copy()
    bad.loc[0, "pdof1"] = math.radians(200.0)
    problems = validate_database(replace(db, reconstruction=bad))
    text = " ".join(p.message for p in problems)
    assert "pdof1=200 outside the allowed range (-180, 180]" in text
