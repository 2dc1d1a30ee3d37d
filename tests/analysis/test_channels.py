"""The run-out and vehicle channels (yaw-inertia factor, contact-phase tyre impulse,
run-out brake factor per vehicle), the coverage of the identification intervals, and
the hidden laws of the diagnosis battery (benchmarks/battery_laws.py).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import slow_scale
from vfs.analysis.calibrate import CalibrationData
from vfs.analysis.identify import consistency_factor, identify
from vfs.effects.learned import CHANNEL_OUTPUTS, CHANNELS, law_effect_class
from vfs.scenarios.generator import NO_NOISE, generate_database
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

#: New channels and a constant value to hide (inside the range, away from the model's).
NEW_CHANNELS = {"yaw_inertia_factor": 0.7, "tyre_impulse": 1.0, "runout_brake1": 0.4,
                "runout_brake2": 0.55}

#: Probability that a one-sigma interval covers the truth.
ONE_SIGMA = math.erf(1.0 / math.sqrt(2.0))


def constant_law(channel: str, value: float):
    cls = law_effect_class({"name": f"const_{channel}", "channel": channel,
                            "feature": "closing_speed", "form": "constant",
                            "coefficients": [value]})
    return cls()


def binomial_band(k: int, p: float, sigmas: float = 3.0) -> tuple[float, float]:
    """Range of a count of k Bernoulli(p) trials within ``sigmas`` standard deviations."""
    sd = math.sqrt(k * p * (1.0 - p))
    return k * p - sigmas * sd, k * p + sigmas * sd


def test_new_channels_are_declared_with_units_ranges_and_outputs():
    for name in NEW_CHANNELS:
        ch = CHANNELS[name]
        assert ch.mode in ("set", "shift") and ch.lo < ch.hi and ch.unit
        assert ch.lo <= NEW_CHANNELS[name] <= ch.hi
        assert set(CHANNEL_OUTPUTS[name]) and type(constant_law(name, 0.5)).stages() == (
            ch.stage,)
    assert set(CHANNEL_OUTPUTS) == set(CHANNELS)


@pytest.mark.parametrize("channel", sorted(NEW_CHANNELS))
def test_neutral_value_leaves_results_bit_identical(channel):
    # the law at the model's own value ("set": yaw-inertia factor 1, brake factor 0.8 of
    # the default run-out) or no offset ("shift") takes the same arithmetic path
    db, _ = generate_database("default", n_cases=12, seed=4, hidden=())
    batch = CaseBatch.from_database(db)
    neutral = {"yaw_inertia_factor": 1.0, "tyre_impulse": 0.0, "runout_brake1": 0.8,
               "runout_brake2": 0.8}[channel]
    base = results_table(batch, simulate_cases(batch))
    law = SimulationParams(effects=(constant_law(channel, neutral),))
    other = results_table(batch, simulate_cases(batch, params=law))
    for col in base.columns:
        a, b = base[col].to_numpy(), other[col].to_numpy()
        if a.dtype.kind == "f":
            np.testing.assert_array_equal(a, b, err_msg=col)
        else:
            assert (a == b).all(), col


@pytest.mark.parametrize("channel", sorted(NEW_CHANNELS))
def test_new_channel_is_identifiable(channel):
    # a database made with a constant value of the channel: the identified values
    # scatter around it and the intervals cover it about as often as they claim
    value = NEW_CHANNELS[channel]
    db, _ = generate_database("default", n_cases=40, seed=3,
                              hidden=(constant_law(channel, value),))
    t = identify(CalibrationData.from_database(db), [channel], grid_points=11)
    ok = t[t["identifiable"]]
    assert len(ok) >= 0.6 * len(t)
    assert abs(np.median(ok["value"]) - value) < 0.1 * (CHANNELS[channel].hi
                                                         - CHANNELS[channel].lo)
    covered = int(((ok["low"] <= value) & (value <= ok["high"])).sum())
    lo, hi = binomial_band(len(ok), ONE_SIGMA)
    assert lo <= covered <= hi, (covered, len(ok))


def test_consistency_factor_recovers_the_scale_of_too_narrow_intervals():
    # values scattered with SD 2 around a constant, intervals claiming SD 1: factor ~2;
    # intervals claiming SD 2: factor 1 (never below)
    rng = np.random.default_rng(5)
    n = 4000
    v = rng.normal(0.0, 2.0, n)
    feats = rng.uniform(size=(n, 2))
    k = consistency_factor(v, v - 1.0, v + 1.0, feats)
    assert abs(k - 2.0) < 0.1
    assert consistency_factor(v, v - 2.5, v + 2.5, feats) == 1.0


@pytest.mark.slow
def test_interval_coverage_is_near_nominal():
    # several channels at constant hidden values: the share of identifiable cases whose
    # interval holds the truth lies within the binomial band of 68.3 %
    n = max(60, int(round(300 * slow_scale())))
    covered = total = 0
    for channel, value in (("restitution", 0.15), ("runout_brake1", 0.4)):
        db, _ = generate_database("default", n_cases=n, seed=11,
                                  hidden=(constant_law(channel, value),))
        t = identify(CalibrationData.from_database(db), [channel], grid_points=13)
        ok = t[t["identifiable"]]
        covered += int(((ok["low"] <= value) & (value <= ok["high"])).sum())
        total += len(ok)
    lo, hi = binomial_band(total, ONE_SIGMA)
    assert lo <= covered <= hi, (covered, total)


def _observed_by_group(db) -> tuple[list[str], np.ndarray, np.ndarray]:
    data = CalibrationData.from_database(db, outputs=None)
    return list(data.group_names), data.column_group, data.observed


@pytest.mark.parametrize("name", ["brake1_logistic", "brake2_bell_angle", "ees_mass_side",
                                  "tyre_friction_speed"])
def test_battery_law_enters_the_generator_on_its_outcomes_only(name):
    from battery_laws import hidden_effect, law_by_name

    law = law_by_name(name)
    plain, _ = generate_database("default", n_cases=30, seed=8, hidden=(), noise=NO_NOISE)
    hid, truth = generate_database("default", n_cases=30, seed=8, hidden=(hidden_effect(law),),
                                   noise=NO_NOISE)
    assert [e["name"] for e in truth.summary()["hidden_effects"]] == [name]
    names, groups, a = _observed_by_group(plain)
    names2, _, b = _observed_by_group(hid)
    assert names == names2
    changed = set()
    for k, g in enumerate(names):
        x, y = a[:, groups == k], b[:, groups == k]
        same = (x == y) | (np.isnan(x) & np.isnan(y)) | np.isclose(x, y, rtol=1e-9, atol=1e-9)
        if not same.all():
            changed.add(g)
    assert changed, "the law changed nothing"
    assert changed <= set(CHANNEL_OUTPUTS[law.channel]), changed
