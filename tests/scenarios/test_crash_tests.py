"""The bundled crash-test database (``--db crash-tests``) and the measurement format.

Oracles: the schema validator; the builder run again (the bundled files are
its output); the papers' own numbers checked against each other (Table 1's
translational kinetic energy against Table 2's E_kAB(0), whose difference is the
wheels' rotation energy, and the energy balance of Table 2, eq. (27) of the
energy-balance paper); the fixed object's 1/m = 0 limit through the whole
simulation.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from vfs.database import open_database
from vfs.database.io import save_database
from vfs.database.validation import validate_database
from vfs.errors import DataError
from vfs.scenarios import crash_tests as ct
from vfs.simulation import CaseBatch, simulate_cases

#: Upper bound of the wheels' (and powertrain's) share of the kinetic energy at contact.
#: Derivation: E_w = sum(I_w omega^2) / 2 = (sum I_w / r^2) v^2 / 2, so the share is
#: (sum I_w / r^2) / m.  Four passenger-car wheels of I_w <= 1.2 kg m^2 and rolling
#: radius r >= 0.29 m give sum I_w / r^2 <= 57 kg; with the free-rolling driveline up
#: to 1.4 times that, 80 kg of 1530-1630 kg: 5 %.
WHEEL_SHARE_MAX = 0.05


@pytest.fixture(scope="module")
def db():
    return open_database("crash-tests")


def test_bundled_database_validates_and_equals_the_builder(db):
    assert validate_database(db) == []
    built = ct.build_crash_test_database()
    for name, table in built.tables().items():
        pd.testing.assert_frame_equal(getattr(db, name), table, check_exact=True,
                                      obj=name)


def test_every_row_is_a_measurement_with_unmeasured_outcomes_nan(db):
    rec = db.reconstruction.set_index("case_id")
    assert (rec["outcome_source"] == "measurement").all()
    assert rec["restitution"].isna().all() and (rec["impact_type"] == "").all()
    assert rec.loc[[1, 2, 3], "energy_loss"].notna().all()
    # the Opel's 13.6 km/h is a CRASH3 computation (collision-uncertainty paper, section
    # 2.3), not a measurement: a paper_* column, its sd the CRASH3 95 % limit of 25 %
    assert np.isnan(rec.loc[4, "ees2"])
    assert rec.loc[4, "paper_ees2_crash3"] == pytest.approx(13.6 / 3.6)
    assert rec.loc[4, "paper_ees2_crash3_sd"] == pytest.approx(0.25 * 13.6 / 3.6 / 1.96,
                                                               rel=1e-3)
    assert rec["rest_x1"].isna().all()  # no rest position is given in the papers' text


def test_nan_outcome_is_rejected_in_a_reconstruction_row(db, tmp_path):
    rec = db.reconstruction.copy()
    rec["outcome_source"] = "reconstruction"
    bad = type(db)(db.cases, db.participants, db.trajectories, rec, meta=db.meta)
    problems = validate_database(bad)
    assert any(p.column == "delta_v1" for p in problems)
    assert any(p.column == "impact_type" for p in problems)
    with pytest.raises(DataError):
        save_database(bad, tmp_path / "bad")


@pytest.mark.parametrize("k", range(3))
def test_kinetic_energy_at_contact_table1_vs_table2(k):
    """Table 1's m V^2 / 2 of both cars is below Table 2's E_kAB(0) by the wheels'
    rotation energy (eq. 20 of the energy-balance paper), 0 < share <= 5 %."""
    v_a = ct.AB_SPEED_A[k]
    v_b = v_a * ct.AB_SPEED_B_FACTOR[k]
    translational = 0.5 * (ct.AB_MASS_A[k] * v_a**2 + ct.AB_MASS_B[k] * v_b**2)
    e0 = 1e3 * ct.AB_ENERGY_KJ["kinetic_energy_contact"][k]
    share = 1.0 - translational / e0
    assert 0.0 < share <= WHEEL_SHARE_MAX


@pytest.mark.parametrize("k", range(3))
def test_table2_energy_balance_closes(k):
    """Eq. (27): E_p = E_kAB(0) - (E_kAB(t_k) + E_D + E_T + E_tAB), to Table 2's rounding."""
    e = {name: values[k] for name, values in ct.AB_ENERGY_KJ.items()}
    rest = e["kinetic_energy_contact"] - (e["kinetic_energy_separation"] + e[
        "deformation_work"] + e["body_friction_work"] + e["tyre_road_work"])
    assert rest == pytest.approx(e["other_loss"], abs=0.1 + 1e-9)


def test_cg_position_reproduces_the_papers_inertia_formula():
    for m, izz in zip(ct.AB_MASS_A + ct.AB_MASS_B, ct.AB_INERTIA_A + ct.AB_INERTIA_B,
                      strict=True):
        lf = ct.cg_to_front_from_inertia(m, izz, ct.ACCORD["wheelbase"])
        assert m * lf * (ct.ACCORD["wheelbase"] - lf) == pytest.approx(izz, rel=1e-12)
        assert 0.0 < lf < 0.5 * ct.ACCORD["wheelbase"]


def test_model_meets_the_test_configuration(db):
    """Replaying the records reaches first contact at the designed time, and the
    barrier (fixed object) neither moves nor deforms: the car rebounds at -eps v."""
    batch = CaseBatch.from_database(db)
    assert batch.fixed_object is not None and batch.fixed_object[:, 1].tolist() == [
        False, False, False, False, True]
    res = simulate_cases(batch)
    np.testing.assert_allclose(res.precrash.contact_time, ct.CONTACT_TIME, atol=0.011)
    barrier = 4
    v = ct.C300_SPEED_KMH / 3.6
    eps = res.restitution[barrier]
    assert res.impact.vx_post[barrier, 0] == pytest.approx(-eps * v, rel=1e-9)
    assert res.impact.vx_post[barrier, 1] == 0.0 and res.impact.ees[barrier, 1] == 0.0
    assert res.runout.rest_x[barrier, 1] == pytest.approx(0.5 * ct.BARRIER["length"])
    loss = 0.5 * ct.C300["mass"] * v**2 * (1.0 - eps**2)
    assert res.impact.energy_loss[barrier] == pytest.approx(loss, rel=1e-9)
    assert math.isfinite(res.runout.rest_x[barrier, 0])


def test_compare_reports_exactly_the_measured_values():
    import numpy as np

    from vfs import open_database
    from vfs.analysis.compare import compare_database

    db = open_database("crash-tests")
    c = compare_database(db)
    m = c.measured
    rec = db.reconstruction.set_index("case_id")
    # one row per finite measured value, nothing for what was not measured
    expected = sum(int(np.isfinite(rec[col]).sum()) for col in m["outcome"].unique())
    assert len(m) == expected and set(m["outcome"]) <= set(rec.columns)
    for r in m.itertuples(index=False):
        assert r.measured == rec.loc[r.case_id, r.outcome]
        assert r.difference == r.model - r.measured
        sd = rec[f"{r.outcome}_sd"].get(r.case_id) if f"{r.outcome}_sd" in rec else np.nan
        assert (np.isnan(r.z) and not sd > 0) or r.z == r.difference / sd
    # the model's value is the simulation's (the results table of the comparison's pairs)
    assert set(m["outcome"]) == {"energy_loss"}
    # a crash test's POI is the assumed set-up: no POI distance, no "type changed"
    assert (c.poi_distances["n"] == 0).all()
    assert set(c.cases["group"]) == {"type unknown"}
