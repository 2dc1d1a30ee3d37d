"""Every number docs/validation.md, docs/physics.md (Marquard) and docs/compare.md (the
paper's Table 1) quote, recomputed from the inputs.

The numbers are read from the pages themselves, so a change of the model, the data or the page
that moves one fails here. Tolerances are the pages' own rounding (half a unit of the last
printed digit), the papers' rounding where a paper's number enters, and 1e-9 relative where
two computations of the same quantity must agree exactly.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from vfs.units import KMH_PER_MS

ROOT = Path(__file__).resolve().parents[1]
VALIDATION = (ROOT / "docs" / "validation.md").read_text(encoding="utf-8")
PHYSICS = (ROOT / "docs" / "physics.md").read_text(encoding="utf-8")
COMPARE = (ROOT / "docs" / "compare.md").read_text(encoding="utf-8")


def half_unit(text: str) -> float:
    """Half a unit of the last printed digit of a number as printed ("92.9" -> 0.05)."""
    decimals = len(text.split(".")[1]) if "." in text else 0
    return 0.5 * 10.0**-decimals


@pytest.fixture(scope="module")
def crash_tests():
    from vfs.database import open_database
    from vfs.simulation import CaseBatch, simulate_cases

    db = open_database(ROOT / "scenarios" / "databases" / "crash-tests")
    batch = CaseBatch.from_database(db)
    return db, batch, simulate_cases(batch)


# --- validation page: energy losses of AB1-AB3 ------------------------------------------

ROW = re.compile(r"^\| (AB[123]) \| energy loss ([\d.]+) kJ \(sd ([\d.]+)[^|]*\| ([\d.]+) kJ \| "
                 r"([+-][\d.]+) kJ \(([+-][\d.]+) %\) \|$", re.M)


def test_validation_page_quotes_three_energy_rows():
    assert [m.group(1) for m in ROW.finditer(VALIDATION)] == ["AB1", "AB2", "AB3"]


@pytest.mark.parametrize("k", [0, 1, 2])
def test_energy_loss_rows_follow_from_table2_and_the_model(crash_tests, k):
    from vfs.scenarios import crash_tests as ct

    db, batch, res = crash_tests
    m = list(ROW.finditer(VALIDATION))[k]
    measured, sd, model, diff, rel = m.group(2, 3, 4, 5, 6)
    # measured: E_kAB(0) - E_kAB(t_k) of the energy-balance paper's Table 2, printed to 0.1 kJ:
    # the difference of two such numbers is exact to 0.1 kJ
    e0 = ct.AB_ENERGY_KJ["kinetic_energy_contact"][k]
    e1 = ct.AB_ENERGY_KJ["kinetic_energy_separation"][k]
    assert float(measured) == pytest.approx(e0 - e1, abs=0.1 + half_unit(measured))
    rec = db.reconstruction.set_index("case_id")
    assert rec.loc[k + 1, "energy_loss"] / 1e3 == pytest.approx(e0 - e1, rel=1e-12)
    assert float(sd) == pytest.approx(rec.loc[k + 1, "energy_loss_sd"] / 1e3,
                                      abs=half_unit(sd))
    # model: the impulse model's loss; it must equal the closed form of a full impact,
    # (1 - eps^2) u^T A^-1 u / 2 (u: relative POI velocity, A: the compliance matrix), and
    # the page's figure to its rounding
    i = k
    loss = res.impact.energy_loss[i]
    assert res.impact.impact_type[i] == 1  # full (the page: "all full impacts")
    assert loss / 1e3 == pytest.approx(float(model), abs=half_unit(model))
    assert loss == pytest.approx(_full_impact_loss(batch, res, i), rel=1e-9)
    d = loss / 1e3 - rec.loc[k + 1, "energy_loss"] / 1e3
    assert d == pytest.approx(float(diff), abs=half_unit(diff) + half_unit(model))
    assert 100 * d / (e0 - e1) == pytest.approx(float(rel), abs=half_unit(rel) + 0.1)


def _full_impact_loss(batch, res, i):
    """Kinetic-energy loss of a full impact from the impact state [J] (closed form)."""
    st = res.precrash.impact_state
    eps = res.restitution[i]
    poi = res.poi[i]
    m = [batch.vehicle1.mass[i], batch.vehicle2.mass[i]]
    inertia = [batch.vehicle1.yaw_inertia[i], batch.vehicle2.yaw_inertia[i]]
    vel, a = [], np.zeros((2, 2))
    for j in range(2):
        r = poi - np.array([st.x[i, j], st.y[i, j]])
        w = st.yaw_rate[i, j]
        vel.append(np.array([st.vx[i, j], st.vy[i, j]]) + w * np.array([-r[1], r[0]]))
        perp = np.array([-r[1], r[0]])
        a += np.eye(2) / m[j] + np.outer(perp, perp) / inertia[j]
    u = vel[0] - vel[1]
    return 0.5 * (1.0 - eps**2) * u @ np.linalg.solve(a, u)


# --- validation page: Mondeo/Vectra ------------------------------------------------------

def test_mondeo_vectra_ees_is_the_mass_split_internal_loss(crash_tests):
    from vfs.scenarios import crash_tests as ct

    db, batch, res = crash_tests
    i = 3
    row = re.search(r"^\| Mondeo/Vectra \|.*?CRASH3 EES of the Opel, ([\d.]+) km/h \(sd "
                    r"([\d.]+).*?\| EES Opel ([\d.]+) km/h", VALIDATION, re.M)
    assert row, "the validation page's Mondeo/Vectra row"
    crash3, sd, model = row.groups()
    rec = db.reconstruction.set_index("case_id")
    # the paper's CRASH3 value (section 2.3) is a paper_* column, not a measurement
    assert np.isnan(rec.loc[4, "ees2"])
    assert rec.loc[4, "paper_ees2_crash3"] * KMH_PER_MS == pytest.approx(float(crash3),
                                                                        abs=half_unit(crash3))
    # CRASH3's 95 % limit of 25 % (Smith and Noga 1982) as one sd: 0.25 x 13.6 / 1.96
    assert float(sd) == pytest.approx(0.25 * ct.MV_EES2_KMH / 1.959964, abs=half_unit(sd))
    # the model's EES: the whole internal loss split by mass, E2 = dE m1 / (m1 + m2)
    m1, m2 = batch.vehicle1.mass[i], batch.vehicle2.mass[i]
    e2 = res.impact.energy_loss[i] * m1 / (m1 + m2)
    assert res.impact.ees[i, 1] == pytest.approx(np.sqrt(2 * e2 / m2), rel=1e-9)
    assert res.impact.ees[i, 1] * KMH_PER_MS == pytest.approx(float(model), abs=half_unit(model))
    # the page's derived figures: loss, share, deformation-only EES (70-75 % of the loss,
    # energy-balance paper Table 2)
    text = VALIDATION
    assert f"internal loss ({res.impact.energy_loss[i] / 1e3:.1f} kJ" in text
    assert f"gives the Opel {100 * m1 / (m1 + m2):.1f} % ({e2 / 1e3:.1f} kJ" in text
    lo, hi = (res.impact.ees[i, 1] * KMH_PER_MS * np.sqrt(f) for f in (0.70, 0.75))
    assert "EES of 21.3-22.0" in text and f"{lo:.1f}-{hi:.1f}" == "21.3-22.0"
    crash3_j = 0.5 * m2 * (ct.MV_EES2_KMH / KMH_PER_MS) ** 2
    assert f"{crash3_j / 1e3:.1f} kJ" == "8.3 kJ" and "= 8.3 kJ" in text


# --- physics page: Marquard -------------------------------------------------------------

def test_marquard_range_numbers_on_the_physics_page():
    from vfs.physics.marquard import ROTATION_FACTOR_MAX, translation_factor

    m = re.search(r"minimum ([\d.]+) at k\* = ([\d.]+)", PHYSICS)
    assert m
    assert float(m.group(2)) == pytest.approx(ROTATION_FACTOR_MAX, abs=half_unit(m.group(2)))
    assert float(m.group(1)) == pytest.approx(float(translation_factor(ROTATION_FACTOR_MAX)),
                                              abs=half_unit(m.group(1)))
    k3 = re.search(r"k_s\(3\) = ([\d.]+)", PHYSICS).group(1)
    assert float(k3) == pytest.approx(np.polyval([0.17, -0.488, -0.03, 1.0], 3.0),
                                      abs=half_unit(k3))


MARQUARD_ROW = re.compile(r"^\| (< 0\.1|0\.1-0\.5|0\.5-1|1-1\.944) \| (no|yes) \| (\d+) \| "
                          r"([\d.]+) \| ([\d.]+)-([\d.]+) \| (\d+) % \| (\d+) % \|$", re.M)


def test_marquard_table_on_the_bundled_database():
    # docs/physics.md's table: the whole bundled database (600 cases, ~2 s of simulation;
    # a table over all of it cannot be scaled down)
    from vfs.analysis.marquard import marquard_check, summarise
    from vfs.database import open_database
    from vfs.simulation import CaseBatch, simulate_cases

    rows = list(MARQUARD_ROW.finditer(PHYSICS))
    assert len(rows) == 8
    db = open_database("default")
    batch = CaseBatch.from_database(db)
    table = summarise(marquard_check(batch, simulate_cases(batch)))
    assert len(table) == 8
    for m, (_, t) in zip(rows, table.iterrows(), strict=True):
        assert int(m.group(3)) == t["n"]
        assert float(m.group(4)) == pytest.approx(t["median_ratio"], abs=half_unit(m.group(4)))
        assert float(m.group(5)) == pytest.approx(t["p10"], abs=half_unit(m.group(5)))
        assert float(m.group(6)) == pytest.approx(t["p90"], abs=half_unit(m.group(6)))
        assert int(m.group(7)) == pytest.approx(100 * t["within_10pct"], abs=0.5)
        assert int(m.group(8)) == pytest.approx(100 * t["within_20pct"], abs=0.5)
    n = re.search(r"\(([\d,]+) vehicles with a post-impact speed above 1 m/s and k <= k\*",
                  PHYSICS).group(1)
    assert int(n.replace(",", "")) == table["n"].sum()


# --- compare page: study36 side by side --------------------------------------------------

def test_paper_table1_in_the_code_is_the_one_the_page_quotes():
    from vfs.analysis.paper_reference import PAPER_TABLE1, table1_label

    for r in PAPER_TABLE1:
        label = re.escape(table1_label(r.outcome, r.group))
        m = re.search(rf"^\| {label} \| (\d+), ([\d.]+), ([\d.]+), ([\d.]+) ", COMPARE, re.M)
        assert m, label
        assert (int(m.group(1)), float(m.group(2)), float(m.group(3)), float(m.group(4))) == (
            r.n, r.mean_reconstruction, r.mean_vfs, r.p_value)


def test_study36_side_by_side_section_follows_the_comparison():
    """The report's side-by-side section: the paper's numbers beside exactly this run's, and
    the sliding velocity-angle row named as a different population.  (The seed 0-4 figures
    docs/compare.md quotes are bound to benchmarks/results/study36-side-by-side/study36.json
    in tests/test_docs_figures.py.)"""
    from vfs.analysis.compare import compare_database
    from vfs.analysis.paper_reference import (
        PAPER_TABLE1,
        population_notes,
        side_by_side_table1,
        side_by_side_types,
    )
    from vfs.scenarios.generator import generate_database

    db, _ = generate_database("study36", seed=0)
    c = compare_database(db, impact_parameters="default")
    t = c.contingency.table
    side = side_by_side_table1(c)
    assert side["paper_reconstruction"].tolist() == [r.mean_reconstruction for r in PAPER_TABLE1]
    np.testing.assert_array_equal(side["vfs"] - side["reconstruction"],
                                  c.table1["mean_vfs"] - c.table1["mean_reconstruction"])
    notes = population_notes(side)
    assert any(n.startswith("Change of velocity angle, sliding") for n in notes)
    types = side_by_side_types(c).set_index("group")
    assert types.loc["type changed", "cases"] == t.loc["full", "sliding"] + t.loc[
        "sliding", "full"]
    assert types.loc["all", "cases"] == len(db.cases) and types.loc["all", "paper_cases"] == 36
