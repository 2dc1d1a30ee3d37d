"""The compiled impact kernel (vfs.physics.core_impact) against its reference, the numpy
block solver of vfs.physics.impact (``VFS_COMPILED=0``): every field bit for bit.

Both repeat the same IEEE operations in the same order, and the kernel leaves the
arctangents to numpy, so equality is exact (NaN equal to NaN), in both restitution
conventions, with and without stiffness ratios, for fixed objects, separating
configurations, the normal-only fallback (Kane's paradox) and beyond one numpy block.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.bench.kernels import compiled_switch
from vfs.physics import impact
from vfs.physics.impact import CHUNK, ImpactConfig, solve_impact
from vfs.scenarios.random import random_impact_configs


def solve_both(monkeypatch: pytest.MonkeyPatch, config: ImpactConfig,
               **kwargs: object) -> tuple[impact.ImpactResult, impact.ImpactResult]:
    """(numpy reference, compiled kernel) results of the same call."""
    monkeypatch.setenv("VFS_COMPILED", "0")
    ref = solve_impact(config, **kwargs)  # type: ignore[arg-type]
    monkeypatch.setenv("VFS_COMPILED", "1")
    got = solve_impact(config, **kwargs)  # type: ignore[arg-type]
    return ref, got


def assert_identical(ref: impact.ImpactResult, got: impact.ImpactResult) -> None:
    """Every field: same shape, dtype and bits (NaN where the reference has NaN)."""
    for name, a, b in zip(ref._fields, ref, got, strict=True):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.dtype == b.dtype, name
        np.testing.assert_array_equal(b, a, err_msg=name, strict=True)


def with_fields(config: ImpactConfig, **fields: np.ndarray) -> ImpactConfig:
    """``config`` with some fields replaced."""
    return config._replace(**fields)


@pytest.mark.parametrize("mode", ["impulse", "normal"])
def test_random_configurations_bit_identical(monkeypatch: pytest.MonkeyPatch,
                                             mode: str) -> None:
    config = random_impact_configs(np.random.default_rng(3), 20_000)
    ref, got = solve_both(monkeypatch, config, restitution_mode=mode)
    # the sample must contain every outcome the kernel branches on
    assert set(np.unique(ref.impact_type)) == {impact.IMPACT_NONE, impact.IMPACT_FULL,
                                               impact.IMPACT_SLIDING}
    assert_identical(ref, got)


@pytest.mark.parametrize("mode", ["impulse", "normal"])
def test_stiffness_ratio_bit_identical(monkeypatch: pytest.MonkeyPatch, mode: str) -> None:
    rng = np.random.default_rng(4)
    config = random_impact_configs(rng, 5_000)
    ratio = rng.uniform(0.2, 5.0, 5_000)
    ratio[::7] = np.nan  # NaN selects the mass rule per impact
    ref, got = solve_both(monkeypatch, config, stiffness_ratio=ratio, restitution_mode=mode)
    assert_identical(ref, got)
    ref, got = solve_both(monkeypatch, config, stiffness_ratio=2.0, restitution_mode=mode)
    assert_identical(ref, got)


def test_fixed_objects_and_slow_vehicles(monkeypatch: pytest.MonkeyPatch) -> None:
    """A rigid fixed object (m = izz = inf) takes none of the energy; a vehicle slower
    than 1 mm/s has no velocity angle (NaN)."""
    rng = np.random.default_rng(5)
    n = 3_000
    config = random_impact_configs(rng, n)
    m, izz, vx, vy = (config.m.copy(), config.izz.copy(), config.vx.copy(),
                      config.vy.copy())
    m[::3, 1] = np.inf
    izz[::3, 1] = np.inf
    vx[1::3, 1] = 0.0
    vy[1::3, 1] = 0.0
    config = with_fields(config, m=m, izz=izz, vx=vx, vy=vy)
    ref, got = solve_both(monkeypatch, config)
    assert (got.ees[::3, 1] == 0.0).all()
    assert np.isnan(got.velocity_angle_change[1::3, 1]).all()
    assert_identical(ref, got)


def test_normal_mode_energy_fallback_bit_identical(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where the normal-only restitution would create energy (Kane's paradox), both
    paths fall back to the impulse restitution for that impact alone."""
    rng = np.random.default_rng(6)
    config = random_impact_configs(rng, 40_000)
    config = with_fields(config, restitution=rng.uniform(0.6, 1.0, 40_000),
                         contact_friction=rng.uniform(0.05, 0.3, 40_000))
    monkeypatch.setenv("VFS_COMPILED", "0")
    normal = solve_impact(config, restitution_mode="normal")
    impulse = solve_impact(config)
    # with eps > 0 the two conventions give different impulses, except where the
    # normal-only one fell back to the impulse restitution
    fell_back = ((normal.impulse_x == impulse.impulse_x)
                 & (normal.impulse_y == impulse.impulse_y)
                 & (normal.impact_type != impact.IMPACT_NONE))
    assert 0 < fell_back.sum() < fell_back.size  # the sample reaches the fallback
    ref, got = solve_both(monkeypatch, config, restitution_mode="normal")
    assert_identical(ref, got)


def test_more_than_one_block(monkeypatch: pytest.MonkeyPatch) -> None:
    """The reference solves blocks of CHUNK impacts; the kernel the whole batch."""
    config = random_impact_configs(np.random.default_rng(7), CHUNK + 1_000)
    ref, got = solve_both(monkeypatch, config, stiffness_ratio=np.linspace(0.5, 2.0,
                                                                         CHUNK + 1_000))
    assert_identical(ref, got)


def test_strided_and_integer_inputs(monkeypatch: pytest.MonkeyPatch) -> None:
    """Views, Fortran order and integer arrays give the same result as contiguous floats."""
    config = random_impact_configs(np.random.default_rng(8), 2_000)
    strided = ImpactConfig(*(np.asfortranarray(a)[::2] for a in config))
    contiguous = ImpactConfig(*(np.ascontiguousarray(a) for a in strided))
    ref, got = solve_both(monkeypatch, contiguous)
    _, got_strided = solve_both(monkeypatch, strided)
    assert_identical(ref, got_strided)
    rounded = ImpactConfig(*(np.rint(a).astype(np.int64) for a in config))
    rounded = with_fields(rounded, m=config.m, izz=config.izz,
                          restitution=config.restitution,
                          contact_friction=config.contact_friction)
    ref, got = solve_both(monkeypatch, rounded)
    assert_identical(ref, got)


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(1e-3, 1e3),
       angle=st.floats(-1e3, 1e3, allow_nan=False))
def test_property_bit_identical_under_scaling(seed: int, scale: float, angle: float) -> None:
    """Arbitrary magnitudes (speeds and lever arms scaled) and contact-plane angles far
    outside (0, pi): the kernel equals the reference bit for bit."""
    rng = np.random.default_rng(seed)
    config = random_impact_configs(rng, 64)
    config = with_fields(config, vx=np.clip(config.vx * scale, -150, 150),
                         vy=np.clip(config.vy * scale, -150, 150),
                         poi_x=config.poi_x * scale, poi_y=config.poi_y * scale,
                         cp_angle=config.cp_angle + angle)
    mode = "normal" if seed % 2 else "impulse"
    with compiled_switch("0"):
        ref = solve_impact(config, restitution_mode=mode)
    with compiled_switch("1"):
        got = solve_impact(config, restitution_mode=mode)
    assert_identical(ref, got)
