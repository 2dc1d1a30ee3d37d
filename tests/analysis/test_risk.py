"""Tests of vfs.analysis.risk: contract over every registered curve, hand-computed spot values."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.analysis.risk import (
    DEFAULT_CURVES,
    MS_PER_MPH,
    RISK_CURVES,
    BeltedLogisticRiskCurve,
    LogisticRiskCurve,
    PowerRiskCurve,
    RiskCurve,
    default_risk_curve,
    get_risk_curve,
    register_risk_curve,
)
from vfs.errors import ParameterError

pytestmark = pytest.mark.filterwarnings("error")

ALL_NAMES = sorted(RISK_CURVES)
DV_GRID_MS = np.linspace(0.0, 120.0, 2401)  # 0 to 432 km/h [m/s]

# Coefficients copied from docs/references.md (independent of the module's table):
# P = 1 / (1 + exp(-(a + b dv))), dv in mph
NHTSA = {
    "nhtsa2022_all_mais2": (-5.1331, 0.1479),
    "nhtsa2022_all_mais3": (-6.9540, 0.1637),
    "nhtsa2022_all_fatal": (-8.9819, 0.1603),
    "nhtsa2022_frontal_mais2": (-4.9429, 0.1425),
    "nhtsa2022_frontal_mais3": (-6.9774, 0.1620),
    "nhtsa2022_frontal_fatal": (-9.0422, 0.1571),
    "nhtsa2022_rear_mais3": (-8.0329, 0.1793),
}


@pytest.fixture
def restore_registry() -> Iterator[None]:
    saved = dict(RISK_CURVES)
    yield
    for name in RISK_CURVES.names():
        if name not in saved:
            RISK_CURVES.remove(name)
    for name, curve in saved.items():
        RISK_CURVES.add(name, curve, replace=True)


def test_expected_curves_are_registered() -> None:
    assert set(NHTSA) | {"kusano_gabler_mais2", "joksch1993_fatal"} <= set(RISK_CURVES)
    for name, curve in RISK_CURVES.items():
        assert curve.name == name
        assert curve.description and curve.source and curve.injury_level


# ----------------------------------------------------------------------------
# Contract: every registered curve
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", ALL_NAMES)
def test_curve_is_bounded_and_monotone(name: str) -> None:
    p = get_risk_curve(name).probability(DV_GRID_MS)
    assert p.shape == DV_GRID_MS.shape
    assert np.all((p >= 0.0) & (p <= 1.0))
    assert np.all(np.diff(p) >= 0.0)
    assert p[-1] > p[0]  # not constant


@pytest.mark.parametrize("name", ALL_NAMES)
def test_curve_propagates_nan_and_keeps_shape(name: str) -> None:
    curve = get_risk_curve(name)
    dv = np.array([[5.0, np.nan], [np.nan, 20.0]])
    p = curve.probability(dv)
    assert p.shape == (2, 2)
    assert np.isnan(p[0, 1]) and np.isnan(p[1, 0])
    assert np.isfinite(p[0, 0]) and np.isfinite(p[1, 1])
    assert np.isnan(curve.probability(np.nan))
    assert curve.probability(10.0).shape == ()
    assert curve.probability([]).shape == (0,)


@pytest.mark.parametrize("name", ALL_NAMES)
@pytest.mark.parametrize("bad", [-0.1, -math.inf, [1.0, -2.0]])
def test_negative_delta_v_rejected(name: str, bad: object) -> None:
    with pytest.raises(ParameterError, match=">= 0"):
        get_risk_curve(name).probability(bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ALL_NAMES)
def test_non_numeric_delta_v_rejected(name: str) -> None:
    with pytest.raises(ParameterError):
        get_risk_curve(name).probability(["fast"])


@settings(max_examples=50, deadline=None)
@given(
    st.floats(min_value=0.0, max_value=200.0),
    st.floats(min_value=0.0, max_value=200.0),
    st.sampled_from(ALL_NAMES),
)
def test_monotone_for_any_pair(dv1: float, dv2: float, name: str) -> None:
    lo, hi = sorted((dv1, dv2))
    p_lo, p_hi = get_risk_curve(name).probability([lo, hi])
    assert 0.0 <= p_lo <= p_hi <= 1.0


def test_curves_are_frozen() -> None:
    curve = get_risk_curve("nhtsa2022_all_mais3")
    with pytest.raises(dataclasses.FrozenInstanceError):
        curve.slope = 1.0  # type: ignore[attr-defined]


# ----------------------------------------------------------------------------
# Spot values computed by hand, through m/s
# ----------------------------------------------------------------------------


def test_nhtsa_all_mais3_at_30_mph() -> None:
    dv_ms = 30 * 0.44704  # 30 mph in m/s
    expected = 1 / (1 + math.exp(-(-6.9540 + 0.1637 * 30)))  # ~ 0.1148
    assert float(get_risk_curve("nhtsa2022_all_mais3").probability(dv_ms)) == pytest.approx(
        expected, rel=1e-12)
    assert expected == pytest.approx(0.11476, abs=1e-5)


@pytest.mark.parametrize("name", sorted(NHTSA))
@pytest.mark.parametrize("dv_mph", [0.0, 12.5, 25.0, 40.0, 70.0])
def test_nhtsa_spot_values(name: str, dv_mph: float) -> None:
    a, b = NHTSA[name]
    expected = 1 / (1 + math.exp(-(a + b * dv_mph)))
    got = float(get_risk_curve(name).probability(dv_mph * 0.44704))
    assert got == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("name", sorted(NHTSA))
def test_nhtsa_fifty_percent_point(name: str) -> None:
    a, b = NHTSA[name]
    dv50_ms = (-a / b) * 0.44704  # a + b dv = 0 -> P = 1/2
    assert float(get_risk_curve(name).probability(dv50_ms)) == pytest.approx(0.5, rel=1e-12)


def test_kusano_gabler_spot_values_and_belt() -> None:
    curve = get_risk_curve("kusano_gabler_mais2")
    dv_ms = 50 / 3.6  # 50 km/h
    belted = 1 / (1 + math.exp(-(-6.068 + 0.100 * 50 - 0.6234 * (+1))))
    unbelted = 1 / (1 + math.exp(-(-6.068 + 0.100 * 50 - 0.6234 * (-1))))
    assert float(curve.probability(dv_ms)) == pytest.approx(belted, rel=1e-12)  # default
    assert isinstance(curve, BeltedLogisticRiskCurve)
    assert float(curve.probability(dv_ms, belted=True)) == pytest.approx(belted, rel=1e-12)
    assert float(curve.probability(dv_ms, belted=False)) == pytest.approx(unbelted, rel=1e-12)
    assert unbelted > belted
    both = curve.probability([dv_ms, dv_ms], belted=[True, False])
    assert both == pytest.approx([belted, unbelted], rel=1e-12)
    with pytest.raises(ParameterError, match="boolean"):
        curve.probability(dv_ms, belted=1)  # type: ignore[arg-type]


def test_joksch_spot_values() -> None:
    curve = get_risk_curve("joksch1993_fatal")
    dv_ms = np.array([0.0, 35.5, 71.0, 100.0]) * 0.44704  # mph -> m/s
    # (35.5 / 71)^4 = 0.5^4 = 0.0625; at and above 71 mph P is capped at 1
    assert curve.probability(dv_ms) == pytest.approx([0.0, 0.0625, 1.0, 1.0], rel=1e-12)


def test_unit_conversion() -> None:
    assert MS_PER_MPH == 0.44704
    mph_curve = get_risk_curve("nhtsa2022_all_mais3")
    kmh_curve = get_risk_curve("kusano_gabler_mais2")
    assert mph_curve.input_unit == "mph" and kmh_curve.input_unit == "km/h"
    assert float(mph_curve.to_input_unit(10.0)) == pytest.approx(10.0 / 0.44704, rel=1e-15)
    assert float(kmh_curve.to_input_unit(10.0)) == pytest.approx(36.0, rel=1e-15)
    # a curve in m/s with the same numbers as a mph curve differs by the unit factor
    in_ms = LogisticRiskCurve(name="test_ms", description="d", source="s",
                              injury_level="MAIS3+", input_unit="m/s",
                              intercept=-6.9540, slope=0.1637)
    assert float(in_ms.probability(30.0)) == pytest.approx(
        float(mph_curve.probability(30.0 * 0.44704)), rel=1e-12)


# ----------------------------------------------------------------------------
# Registry and defaults
# ----------------------------------------------------------------------------


def test_unknown_name_lists_known_names() -> None:
    with pytest.raises(ParameterError, match="nhtsa2022_all_mais3") as info:
        get_risk_curve("nhtsa_2099")
    assert "nhtsa_2099" in str(info.value)


def test_defaults() -> None:
    assert DEFAULT_CURVES == {
        "MAIS2+": "nhtsa2022_all_mais2",
        "MAIS3+": "nhtsa2022_all_mais3",
        "fatal": "nhtsa2022_all_fatal",
    }
    for level, name in DEFAULT_CURVES.items():
        curve = default_risk_curve(level)
        assert curve is get_risk_curve(name)
        assert curve.injury_level == level
    with pytest.raises(ParameterError, match="MAIS3\\+"):
        default_risk_curve("AIS6")


@pytest.mark.usefixtures("restore_registry")
def test_register_custom_curve() -> None:
    curve = PowerRiskCurve(name="test_power", description="d", source="s",
                           injury_level="fatal", input_unit="km/h",
                           reference_speed=100.0, exponent=2.0)
    assert register_risk_curve(curve) is curve
    assert get_risk_curve("test_power") is curve
    assert float(curve.probability(50 / 3.6)) == pytest.approx(0.25)  # (50/100)^2
    with pytest.raises(ParameterError, match="already registered"):
        register_risk_curve(curve)
    other = dataclasses.replace(curve, exponent=3.0)
    register_risk_curve(other, replace=True)
    assert get_risk_curve("test_power") is other
    with pytest.raises(ParameterError):
        register_risk_curve("not a curve")  # type: ignore[type-var]


@pytest.mark.parametrize(
    "kwargs",
    [
        {"input_unit": "furlong/fortnight", "intercept": -5.0, "slope": 0.1},
        {"input_unit": "mph", "intercept": -5.0, "slope": 0.0},
        {"input_unit": "mph", "intercept": -5.0, "slope": -0.1},
        {"input_unit": "mph", "intercept": math.nan, "slope": 0.1},
    ],
)
def test_invalid_curve_parameters(kwargs: dict) -> None:
    with pytest.raises(ParameterError):
        LogisticRiskCurve(name="bad", description="d", source="s", injury_level="MAIS2+",
                          **kwargs)


def test_invalid_power_curve_and_name() -> None:
    with pytest.raises(ParameterError):
        PowerRiskCurve(name="bad", description="d", source="s", injury_level="fatal",
                       input_unit="mph", reference_speed=0.0, exponent=4.0)
    with pytest.raises(ParameterError):
        PowerRiskCurve(name="", description="d", source="s", injury_level="fatal",
                       input_unit="mph", reference_speed=71.0, exponent=4.0)


def test_base_class_is_abstract() -> None:
    with pytest.raises(TypeError):
        RiskCurve(name="base", description="d", source="s", injury_level="fatal",  # type: ignore[abstract]
                  input_unit="m/s")
