"""The numpy run-out (:func:`vfs.physics.runout.run_out` with ``VFS_COMPILED=0``, the
reference of the compiled kernel) against closed forms and invariances: a locked car slides
v^2 / (2 mu g) in any direction, a braked rolling car v^2 / (2 (b mu + f_r) g), a car braked
on the front axle only with load transfer at the deceleration of the dynamic front load,
mirrored scenes (left and right wheels exchanged) come to rest mirrored, the kinetic energy
never rises.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics.runout import RunoutParams, RunoutState, kinetic_energy, run_out
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

CAR = VehicleParams(mass=1600.0, length=4.6, width=1.8, wheelbase=2.8, cg_to_front_axle=1.2,
                    front_overhang=0.9, track_width=1.55, cg_height=0.55)
MU = 0.8


@pytest.fixture(autouse=True)
def numpy_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """The numpy run-out, whatever the default of the compiled one."""
    monkeypatch.setenv("VFS_COMPILED", "0")
    monkeypatch.delenv("VFS_COMPILED_RUNOUT", raising=False)


def state(**kw: float) -> RunoutState:
    base = dict(x=0.0, y=0.0, yaw=0.0, vx=0.0, vy=0.0, yaw_rate=0.0)
    return RunoutState.from_arrays(**{**base, **kw})


@pytest.mark.parametrize("heading, along", [(0.0, True), (2.1, True), (-0.7, False)])
def test_a_locked_car_slides_v2_over_2_mu_g_in_any_direction(heading: float,
                                                             along: bool) -> None:
    v0 = 15.0
    direction = heading if along else heading + np.pi / 2  # forwards or sideways
    st = state(x=3.0, y=-4.0, yaw=heading, vx=v0 * np.cos(direction),
               vy=v0 * np.sin(direction))
    res = run_out(stack_vehicles([CAR]), st, MU, wheel_brake=[1.0, 1.0, 1.0, 1.0])
    assert res.at_rest[0]
    d = v0**2 / (2 * MU * G)
    assert res.rest_x[0] - 3.0 == pytest.approx(d * np.cos(direction), abs=0.02)
    assert res.rest_y[0] + 4.0 == pytest.approx(d * np.sin(direction), abs=0.02)
    assert res.distance[0] == pytest.approx(d, abs=0.02)
    assert res.time_to_rest[0] == pytest.approx(v0 / (MU * G), abs=0.02)
    assert res.rest_yaw[0] == pytest.approx(heading, abs=1e-6)


@pytest.mark.parametrize("b, f_r", [(0.5, 0.015), (0.0, 0.2), (0.8, 0.0)])
def test_a_braked_rolling_car_stops_at_the_drag_distance(b: float, f_r: float) -> None:
    v0, heading = 8.0, 0.9
    params = RunoutParams(rolling_resistance=f_r)
    st = state(yaw=heading, vx=v0 * np.cos(heading), vy=v0 * np.sin(heading))
    res = run_out(stack_vehicles([CAR]), st, MU, params=params, wheel_brake=[b] * 4)
    decel = (b * MU + f_r) * G
    assert res.at_rest[0]
    assert res.distance[0] == pytest.approx(v0**2 / (2 * decel), rel=0.005)
    assert np.hypot(res.rest_x[0], res.rest_y[0]) == pytest.approx(res.distance[0], rel=1e-6)


def test_front_brakes_with_load_transfer_decelerate_with_the_dynamic_front_load() -> None:
    """Front wheels locked, rear rolling: m a = mu N_f + f_r N_r with N_f = m (g L2 + a h) / L,
    so a = g (mu L2 + f_r L1) / (L - h (mu - f_r)); static loads: a = g (mu L2 + f_r L1) / L."""
    v0, f_r = 12.0, 0.015
    big_l, l1, h = CAR.wheelbase, CAR.cg_to_front_axle, CAR.cg_height
    l2 = big_l - l1
    for transfer, a in ((True, G * (MU * l2 + f_r * l1) / (big_l - h * (MU - f_r))),
                        (False, G * (MU * l2 + f_r * l1) / big_l)):
        params = RunoutParams(load_transfer=transfer, rolling_resistance=f_r)
        res = run_out(stack_vehicles([CAR]), state(vx=v0), MU, params=params,
                      wheel_brake=[1.0, 1.0, 0.0, 0.0])
        assert res.distance[0] == pytest.approx(v0**2 / (2 * a), rel=0.01), transfer
        assert res.rest_y[0] == pytest.approx(0.0, abs=1e-9)


def test_a_mirrored_scene_comes_to_rest_mirrored() -> None:
    """y -> -y, yaw -> -yaw, vy -> -vy, r -> -r, left and right wheels exchanged."""
    brake = np.array([[1.0, 0.3, 0.6, 0.0], [0.2, 0.9, 0.0, 0.5]])
    st = RunoutState.from_arrays(x=[1.0, -2.0], y=[0.5, 3.0], yaw=[0.3, -2.0],
                                 vx=[12.0, -4.0], vy=[-3.0, 6.0], yaw_rate=[1.2, -0.6])
    mirror = RunoutState(st.x, -st.y, -st.yaw, st.vx, -st.vy, -st.yaw_rate)
    for transfer in (False, True):
        params = RunoutParams(load_transfer=transfer)
        v = stack_vehicles([CAR, CAR])
        a = run_out(v, st, MU, params=params, wheel_brake=brake)
        b = run_out(v, mirror, MU, params=params, wheel_brake=brake[:, [1, 0, 3, 2]])
        np.testing.assert_allclose(b.rest_x, a.rest_x, atol=1e-9)
        np.testing.assert_allclose(b.rest_y, -a.rest_y, atol=1e-9)
        np.testing.assert_allclose(b.rest_yaw, -a.rest_yaw, atol=1e-9)
        np.testing.assert_allclose(b.distance, a.distance, atol=1e-9)
        np.testing.assert_array_equal(b.at_rest, a.at_rest)
        assert a.at_rest.all() and np.abs(a.rest_yaw - st.yaw).min() > 0.05  # it turned


def test_the_kinetic_energy_never_rises_and_starts_at_the_state() -> None:
    st = RunoutState.from_arrays(x=0.0, y=0.0, yaw=[0.0, 1.0, -2.0], vx=[14.0, 3.0, -8.0],
                                 vy=[-5.0, 9.0, 2.0], yaw_rate=[2.0, -3.0, 0.5])
    v = stack_vehicles([CAR] * 3)
    for transfer in (False, True):
        res = run_out(v, st, MU, params=RunoutParams(load_transfer=transfer),
                      wheel_brake=[[1, 1, 1, 1], [0.3, 0.3, 0.0, 0.0], [0.0, 0.5, 1.0, 0.2]])
        e = res.kinetic_energy
        np.testing.assert_allclose(e[:, 0], kinetic_energy(v, st), rtol=1e-12)
        assert (np.diff(e, axis=1) <= 1e-9 * e[:, :1]).all()
        assert res.at_rest.all() and (e[:, -1] == 0.0).all()


def test_a_cg_half_a_metre_before_the_rear_axle_runs() -> None:
    """The CG must lie between the axles (cg_to_rear_axle > 0), at any distance from them:
    locked, the car slides v^2 / (2 mu g) whatever the load split."""
    import dataclasses

    from vfs.errors import ParameterError
    from vfs.physics.vehicle import VehicleArrays

    rear_heavy = dataclasses.replace(CAR, cg_to_front_axle=CAR.wheelbase - 0.5)
    res = run_out(stack_vehicles([rear_heavy]), state(vx=10.0), MU, wheel_brake=[1.0] * 4)
    assert res.distance[0] == pytest.approx(100.0 / (2 * MU * G), abs=0.02)
    v = stack_vehicles([CAR])
    on_axle = VehicleArrays(*(np.asarray(a, float).copy() for a in v))
    on_axle.cg_to_front_axle[:] = on_axle.wheelbase
    with pytest.raises(ParameterError, match="between the axles"):
        run_out(on_axle, state(vx=10.0), MU)
