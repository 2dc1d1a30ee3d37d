"""Vehicles that stay in contact after the impact, or meet again (``RunoutParams.contact``).

Oracles: a plastic central push between equal cars halves the kinetic energy (momentum
m v = 2 m v'); the pushing car never ends up inside or beyond the pushed one; kinetic
energy never rises with contacts (random pairs); without ``contact`` the vehicles pass
through each other as before.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.errors import ParameterError
from vfs.physics.runout import RunoutParams, RunoutState, run_out_pair
from vfs.physics.vehicle import VehicleParams, stack_vehicles

pytestmark = pytest.mark.usefixtures("both_runout_paths")

LENGTH = 4.5
FREE = (0.0, 0.0, 0.0, 0.0)


def car():
    return stack_vehicles([VehicleParams(length=LENGTH)])


def test_a_car_rolling_into_a_standing_one_pushes_it_instead_of_passing_through():
    v = car()
    s1 = RunoutState.from_arrays(0, 0, 0, 8.0, 0, 0)
    s2 = RunoutState.from_arrays(LENGTH + 1.0, 0, 0, 0.0, 0, 0)  # 1 m ahead, at rest
    params = RunoutParams(contact=True, path_interval=0.005)
    through = run_out_pair(v, v, s1, s2, 0.8, RunoutParams(path_interval=0.005),
                           wheel_brake1=FREE, wheel_brake2=(0.5,) * 4)
    pushed = run_out_pair(v, v, s1, s2, 0.8, params, wheel_brake1=FREE,
                          wheel_brake2=(0.5,) * 4)
    assert through.rest_x[0, 0] > through.rest_x[0, 1] + LENGTH  # the old model: through
    assert pushed.secondary_collision[0] and through.secondary_collision[0]
    assert pushed.rest_x[0, 0] < pushed.rest_x[0, 1]  # behind the car it pushed
    assert pushed.rest_x[0, 1] > LENGTH + 1.5  # which moved
    assert np.abs(pushed.rest_y).max() < 1e-9 and np.abs(pushed.rest_yaw).max() < 1e-9
    energy = pushed.kinetic_energy[0].sum(axis=0)
    assert (np.diff(energy) <= 1e-9 * energy[0]).all()
    # the first push: plastic, central, equal masses -> v' = v / 2, half the energy lost
    ratio = energy[1:] / energy[:-1]
    k = int(np.flatnonzero(ratio < 0.9)[0])  # the first sudden loss: the push
    assert ratio[k] == pytest.approx(0.5, abs=0.01)


def test_hooked_cars_move_together_until_they_separate():
    """Overlapping after the impact, the rear car faster: without contact it drives
    through the front car; with contact they move on together and the rear one stays
    behind."""
    v = car()
    s1 = RunoutState.from_arrays(0, 0, 0, 10.0, 0, 0)
    s2 = RunoutState.from_arrays(LENGTH - 0.3, 0.5, 0.1, 9.0, 0.3, 0.2)
    kw = dict(wheel_brake1=FREE, wheel_brake2=(1.0,) * 4)
    through = run_out_pair(v, v, s1, s2, 0.8, RunoutParams(), **kw)
    hooked = run_out_pair(v, v, s1, s2, 0.8, RunoutParams(contact=True), **kw)
    assert through.rest_x[0, 0] > through.rest_x[0, 1] + LENGTH
    assert hooked.rest_x[0, 0] < hooked.rest_x[0, 1]
    assert hooked.at_rest.all()
    assert not hooked.secondary_collision[0]  # never separated: no *secondary* collision


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_kinetic_energy_never_rises_with_contacts(seed):
    rng = np.random.default_rng(seed)
    n = 12
    v = stack_vehicles([VehicleParams()] * n)
    s1 = RunoutState.from_arrays(0, 0, rng.uniform(-0.3, 0.3, n), rng.uniform(5, 15, n),
                                 rng.uniform(-2, 2, n), rng.uniform(-1, 1, n))
    s2 = RunoutState.from_arrays(rng.uniform(3.5, 5.0, n), rng.uniform(-1.5, 1.5, n),
                                 rng.uniform(-1.0, 1.0, n), rng.uniform(0, 8, n),
                                 rng.uniform(-3, 3, n), rng.uniform(-2, 2, n))
    params = RunoutParams(contact=True, path_interval=0.005, max_time=6.0)
    res = run_out_pair(v, v, s1, s2, 0.8, params,
                       wheel_brake1=rng.choice([0.0, 0.5, 1.0], (n, 4)),
                       wheel_brake2=rng.choice([0.0, 0.5, 1.0], (n, 4)))
    energy = res.kinetic_energy.sum(axis=1)  # (n, K), both cars
    rise = np.diff(energy, axis=1).max(axis=1)
    assert (rise <= 1e-9 * energy[:, 0] + 1e-9).all()


def test_contact_parameters_are_checked():
    with pytest.raises(ParameterError, match="contact_restitution"):
        RunoutParams(contact=True, contact_restitution=1.5)
    with pytest.raises(ParameterError, match="contact"):
        RunoutParams(contact="yes")


def test_the_simulation_runs_contacts_with_and_without_the_flags():
    from vfs.database import open_database
    from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases

    batch = CaseBatch.from_database(open_database("default", where="case_id <= 6"))
    contact = RunoutParams(contact=True)
    flagged = results_table(batch, simulate_cases(
        batch, params=SimulationParams(runout=contact)))
    quiet = results_table(batch, simulate_cases(batch, params=SimulationParams(
        runout=contact, secondary_collisions=False, runout_paths=False)))
    for col in ("rest_x1", "rest_y1", "rest_yaw2", "time_to_rest1"):
        np.testing.assert_array_equal(flagged[col], quiet[col], err_msg=col)
    assert not quiet["secondary_collision"].any()
