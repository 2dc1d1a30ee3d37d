"""Model variants of a calibration (vfs.diagnosis.variants): the shared pre-crash run."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.diagnosis import variants
from vfs.diagnosis.calibrate import CalibrationData
from vfs.diagnosis.variants import VariantSimulator, leaves_precrash
from vfs.effects.library import PenetrationDepth, RestitutionSpeed, WheelLock, YawInertia
from vfs.scenarios.generator import generate_database


@pytest.fixture(scope="module")
def data() -> CalibrationData:
    db, _ = generate_database("default", n_cases=40, seed=5)
    return CalibrationData.from_database(db)


def test_only_vehicle_and_penetration_hooks_change_the_precrash():
    assert leaves_precrash(())
    assert leaves_precrash((RestitutionSpeed(), WheelLock()))
    assert not leaves_precrash((PenetrationDepth(),))  # penetration time
    assert not leaves_precrash((RestitutionSpeed(), YawInertia()))  # vehicle data


def test_shared_precrash_run_gives_the_variants_bit_for_bit(data, monkeypatch):
    """Variants that leave the pre-crash phase as it is reuse the base model's run; their
    residuals equal those of variants that each run their own pre-crash phase (stacked
    the same way), to the last bit. A variant with a penetration law runs its own and
    differs from the default model."""
    models = [(), (RestitutionSpeed(),), (WheelLock(),), (PenetrationDepth(),),
              (YawInertia(factor=1.7),)]
    shared = VariantSimulator(data)
    assert [shared.keeps_precrash(m) for m in models] == [True, True, True, False, True]
    got = shared.residuals(models)
    assert shared._precrash is not None  # noqa: SLF001 - the cache this test is about
    monkeypatch.setattr(variants, "leaves_precrash", lambda _model: False)
    monkeypatch.setattr(VariantSimulator, "keeps_precrash", lambda _self, _model: False)
    monkeypatch.setattr(VariantSimulator, "continues_precrash", lambda _self, _model: False)
    own = VariantSimulator(data).residuals(models)
    for a, b in zip(got, own, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(got[3], got[0], equal_nan=True)
    assert not np.array_equal(got[4], got[0], equal_nan=True)  # the inertia acts at impact


def test_penetration_variants_continue_the_base_run_bit_for_bit(data, monkeypatch):
    """Variants that change only the penetration time run each colliding case again from
    two steps before its contact in the base run; their residuals and pre-crash results
    equal those of the whole run, to the last bit, and the cases without contact keep the
    base results."""
    models = [(PenetrationDepth(),), (PenetrationDepth(depth=1.2),),
              (PenetrationDepth(), RestitutionSpeed())]
    cont = VariantSimulator(data)
    assert all(cont.continues_precrash(m) and not cont.keeps_precrash(m) for m in models)
    assert not cont.continues_precrash((YawInertia(factor=1.7),))
    got = cont.residuals(models)
    stacked = cont.simulate(models)
    monkeypatch.setattr(VariantSimulator, "continues_precrash", lambda _self, _model: False)
    whole = VariantSimulator(data)
    own = whole.residuals(models)
    for a, b in zip(got, own, strict=True):
        np.testing.assert_array_equal(a, b)
    full = whole.simulate(models)
    for name in ("collided", "contact_time", "impact_time", "poi", "cp_angle", "overlap_area",
                 "min_distance", "time_closest", "speed_reduction"):
        np.testing.assert_array_equal(getattr(stacked.precrash, name),
                                      getattr(full.precrash, name), err_msg=name)
    for name in ("impact_state", "contact_state"):
        for a, b in zip(getattr(stacked.precrash, name), getattr(full.precrash, name),
                        strict=True):
            np.testing.assert_array_equal(a, b, err_msg=name)
    # the control: the penetration time moved the impacts
    assert not np.array_equal(got[0], got[1], equal_nan=True)


def test_precrash_take_repeats_cases_in_order(data):
    pre = VariantSimulator(data).base_precrash()
    rows = np.array([2, 0, 2])
    sub = pre.take(rows)
    np.testing.assert_array_equal(sub.contact_time, pre.contact_time[rows])
    np.testing.assert_array_equal(sub.impact_state.x, pre.impact_state.x[rows])
    assert sub.end_time == pre.end_time


def test_variants_skip_the_secondary_collision_check_without_changing_residuals(data):
    """The variant searches run the run-out without the secondary-collision check; the
    residuals (rest poses, run-out distances, ...) are those of the full chain."""
    from vfs.simulation import SimulationParams, simulate_cases

    sim = VariantSimulator(data)
    got = sim.residuals([(WheelLock(),)])[0]
    full = simulate_cases(data.batch, params=SimulationParams(effects=(WheelLock(),)))
    assert full.runout.secondary_collision.any()  # the check has something to find here
    np.testing.assert_array_equal(got, data.residuals(full))


def test_stacked_steer_and_brake_variants_equal_their_own_runs(data):
    """Variants with run-out steer and brake laws stacked in one batch (their
    ``post_impact`` hooks merged row by row, :func:`variants.merge_rows` on the run-out
    inputs) give each variant's residuals as a run of that variant alone, and a steer law
    moves them."""
    from vfs.effects.learned import law_effect_class

    def law(channel, value):
        return law_effect_class({"name": f"v_{channel}", "channel": channel,
                                 "feature": "closing_speed", "form": "constant",
                                 "coefficients": [value]})()

    models = [(), (law("runout_steer1", 0.3),), (law("runout_steer", -0.2), WheelLock()),
              (law("runout_brake2", 0.4),)]
    sim = VariantSimulator(data)
    stacked = sim.residuals(models)
    for model, got in zip(models, stacked, strict=True):
        alone = VariantSimulator(data).residuals([model])[0]
        np.testing.assert_array_equal(got, alone)
    assert not np.array_equal(stacked[1], stacked[0], equal_nan=True)
    assert not np.array_equal(stacked[2], stacked[1], equal_nan=True)
