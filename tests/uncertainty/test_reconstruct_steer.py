"""Reconstructing the post-impact steer angle of each vehicle from the rest positions
(issue 36, item 4): ``vfs reconstruct``'s inputs ``steer1``, ``steer2`` [rad].

Closed loop: clean generated cases whose run-outs were steered by a known law (the
run-out steer channel of :mod:`vfs.effects.learned`, towards the impact side), the other
wheel states known (brake factor 0.8, the generator's), reconstructed from the rest
positions and headings with a flat prior over [-0.6, 0.6] rad per vehicle.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.conftest import slow_scale
from vfs.effects.learned import impact_sides, law_effect_class
from vfs.scenarios.generator import generate_database
from vfs.uncertainty import CaseSet, Distribution
from vfs.uncertainty.config import INPUT_NAMES, INPUTS_BY_NAME, default_config
from vfs.uncertainty.reconstruct import ObservationSettings, ReconstructSettings, reconstruct

FAST = ReconstructSettings(n_prior=3000, n_starts=4, n_local=1500, n_chains=120, n_steps=40,
                           burn_in=20, thin=4)
FLAT = Distribution("uniform", "absolute", low=-0.6, high=0.6)
OBS = ObservationSettings(rest_position_sd=0.2, rest_yaw_sd=math.radians(3))


def _steered_cases(channel: str, value: float, n: int, seed: int):
    truth_law = law_effect_class({"name": f"truth_{channel}", "channel": channel,
                                  "feature": "closing_speed", "form": "constant",
                                  "coefficients": [value]})()
    db, _ = generate_database("clean", n_cases=n, seed=seed, hidden=(truth_law,))
    cases = CaseSet.from_database(db)
    on = {"runout_steer1": [1.0, 0.0], "runout_steer2": [0.0, 1.0],
          "runout_steer": [1.0, 1.0]}[channel]
    # the angle each car had: the law's value towards the side its point of impact lies on
    # (the clean database records the impact configuration the simulation solved)
    return cases, value * impact_sides(cases.config) * np.asarray(on)


def test_steer_inputs_are_declared_and_default_to_the_data():
    for i in (1, 2):
        info = INPUTS_BY_NAME[f"steer{i}"]
        assert info.unit == "rad" and info.bounds[0] < 0.0 < info.bounds[1]
        spec = default_config().inputs[f"steer{i}"]
        # fixed at the case's nominal value: post_steer{i} of the database, else 0
        assert spec.distribution.family == "fixed" and spec.distribution.mode == "offset"


def test_the_steer_angle_of_one_car_is_recovered_and_the_other_is_found_straight():
    # every other input known (fixed at the database's values, the speeds within 1 %): the
    # steer angles alone explain the rest poses; the estimate of the steered car is close
    # to its angle and its band holds it, the unsteered car's band holds 0
    cases, truth = _steered_cases("runout_steer1", 0.3, 6, 6)
    known = Distribution("fixed", "offset")
    cfg = default_config().with_inputs(
        **{n: known for n in INPUT_NAMES if n not in ("steer1", "steer2", "wheel_brake1",
                                                       "wheel_brake2")},
        wheel_brake1=Distribution("fixed", "absolute", value=0.8),
        wheel_brake2=Distribution("fixed", "absolute", value=0.8), steer1=FLAT, steer2=FLAT)
    near = Distribution("uniform", "factor", low=0.99, high=1.01)  # speeds are unknowns
    settings = dataclasses.replace(FAST, speed1=near, speed2=near)
    for j in range(3):
        rec = reconstruct(cases, cases.case_id[j], config=cfg, observation=OBS,
                          settings=settings, seed=j)
        assert rec.stats["n_feasible"] > 0
        band = rec.band.set_index("quantity")
        for i in (1, 2):
            row, t = band.loc[f"steer{i}"], truth[j, i - 1]
            assert row["min"] <= t <= row["max"], (j, i, t, dict(row))
            assert abs(rec.optimum.inputs[f"steer{i}"] - t) < 0.06, (j, i, t, rec.optimum)
        assert abs(truth[j, 0]) == pytest.approx(0.3) and truth[j, 1] == 0.0


@pytest.mark.slow
def test_steer_bands_cover_the_truth_under_the_default_uncertainties():
    # the realistic case: speeds, friction, restitution, POI, contact plane and masses
    # uncertain as configured by default, the brakes known; both cars steered by 0.3 rad
    # towards their impact side: the feasible band of each car's angle holds its truth in
    # most cases and is narrower than the prior's (5-95 %: 1.08 rad)
    n = max(4, int(round(8 * slow_scale())))
    cases, truth = _steered_cases("runout_steer", 0.3, n + 2, 6)
    fixed = Distribution("fixed", "absolute", value=0.8)
    cfg = default_config().with_inputs(steer1=FLAT, steer2=FLAT, wheel_brake1=fixed,
                                       wheel_brake2=fixed)
    inside, widths = [], []
    for j in range(n):
        rec = reconstruct(cases, cases.case_id[j], config=cfg, observation=OBS,
                          settings=FAST, seed=j)
        band = rec.band.set_index("quantity")
        for i in (1, 2):
            row = band.loc[f"steer{i}"]
            inside.append(row["min"] <= truth[j, i - 1] <= row["max"])
            widths.append(row["p95"] - row["p5"])
    assert np.mean(inside) >= 0.75, (inside, truth[:n])
    assert np.median(widths) < 0.75, widths


def test_the_impact_corner_wheel_is_recovered_with_the_other_inputs_known():
    # clean cases whose impact-corner wheels rolled free-ish at 0.2 (the other wheels at
    # 0.8): the corner input (the corner wheel's factor over its car's) is -0.6 for both
    # cars; its band holds it and the optimum is near it.  With the input at 0 (the default)
    # the model is the one without it: the rest poses of a run at the nominal inputs do not
    # change when the input is listed but fixed
    from vfs.uncertainty.model import evaluate
    from vfs.uncertainty.sampling import nominal_inputs

    truth_law = law_effect_class({"name": "truth_corner", "channel": "corner_brake",
                                  "feature": "closing_speed", "form": "constant",
                                  "coefficients": [0.2]})()
    db, _ = generate_database("clean", n_cases=5, seed=6, hidden=(truth_law,))
    cases = CaseSet.from_database(db)
    known = Distribution("fixed", "offset")
    prior = Distribution("uniform", "absolute", low=-0.8, high=0.2)
    cfg = default_config().with_inputs(
        **{n: known for n in INPUT_NAMES if n not in ("corner_brake1", "corner_brake2",
                                                       "wheel_brake1", "wheel_brake2")},
        wheel_brake1=Distribution("fixed", "absolute", value=0.8),
        wheel_brake2=Distribution("fixed", "absolute", value=0.8),
        corner_brake1=prior, corner_brake2=prior)
    near = Distribution("uniform", "factor", low=0.99, high=1.01)
    settings = dataclasses.replace(FAST, speed1=near, speed2=near)
    errors = []
    for j in range(3):
        rec = reconstruct(cases, cases.case_id[j], config=cfg, observation=OBS,
                          settings=settings, seed=j)
        band = rec.band.set_index("quantity")
        for i in (1, 2):
            row = band.loc[f"corner_brake{i}"]
            assert row["min"] <= -0.6 <= row["max"], (j, i, dict(row))
            errors.append(abs(rec.optimum.inputs[f"corner_brake{i}"] + 0.6))
    assert np.median(errors) < 0.1, errors
    # the default (0) leaves the model as it was: a run with a corner value differs
    x = nominal_inputs(cases, default_config()).T
    rows = np.arange(cases.size)
    from vfs.uncertainty.sampling import SampledInputs

    none = np.zeros(len(INPUT_NAMES), dtype=int)
    base = evaluate(cases, SampledInputs(rows, x, none), default_config())
    k = INPUT_NAMES.index("corner_brake1")
    x2 = x.copy()
    x2[:, k] = 0.2
    moved = evaluate(cases, SampledInputs(rows, x2, none), default_config())
    assert np.abs(moved.outcomes["rest_x1"] - base.outcomes["rest_x1"]).max() > 0.01
    np.testing.assert_array_equal(moved.outcomes["rest_x2"], base.outcomes["rest_x2"])
