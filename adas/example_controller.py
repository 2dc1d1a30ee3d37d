"""A user-written AEB controller in Python, registered as a plugin (vfs never imports it).

Most systems are TOML files (``adas/*.toml``, fields in ``adas/README.md``).  Logic that
those fields cannot express is written as a controller: an object with ``reset(n_cases,
rng)`` and ``demand(obs) -> (n, 2) decelerations [m/s^2]`` (the protocol
``vfs.physics.precrash.BrakeController``), wrapped in a system with ``name``,
``description``, ``controller(batch, equipped)`` and ``precrash_params(base)``.

This one brakes on the *gap time*: the distance between the two vehicles' centres of
gravity less ``gap_m`` (about a car length), divided by their closing speed along the line
between them.  When it falls to ``gap_time_s`` the equipped vehicle demands
``deceleration_mps2`` until it stands still.  No sensor model, no prediction of turning:
a deliberately simple example, not a recommendation.

Run it::

    vfs study --db default --plugin adas/example_controller.py --systems gap-time,three-stage
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vfs.adas import register_system
from vfs.adas.contract import ControllerDefaults
from vfs.adas.systems import python_system
from vfs.physics.precrash import BrakeActuatorParams, PrecrashObservation, PrecrashParams


class GapTimeController(ControllerDefaults):
    """Full braking once the gap time falls to a threshold; held to standstill.

    :class:`vfs.adas.contract.ControllerDefaults` gives it ``events()`` (none) and
    ``reset_segments`` (it draws nothing), so it keeps the whole contract
    (``vfs.adas.check_system(SYSTEM)`` passes).

    Parameters
    ----------
    equipped : numpy.ndarray of bool, shape (N, 2)
        Which participant of each case carries the system.
    gap_time : float
        Threshold [s].
    gap : float
        Distance [m] subtracted from the centre distance.
    deceleration : float
        Demand [m/s^2].
    """

    def __init__(self, equipped: np.ndarray, gap_time: float, gap: float,
                 deceleration: float) -> None:
        self.equipped = equipped
        self.gap_time = gap_time
        self.gap = gap
        self.deceleration = deceleration
        self.active = np.zeros_like(equipped)

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Forget earlier runs (no random draws)."""
        self.active = np.zeros((n_cases, 2), dtype=bool)

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        """Demanded deceleration [m/s^2], shape (n, 2)."""
        dx = obs.x[:, 1] - obs.x[:, 0]
        dy = obs.y[:, 1] - obs.y[:, 0]
        distance = np.hypot(dx, dy)
        vx = obs.speed * np.cos(obs.heading)
        vy = obs.speed * np.sin(obs.heading)
        # closing speed [m/s]: the rate at which the centre distance shrinks
        closing = -((vx[:, 1] - vx[:, 0]) * dx + (vy[:, 1] - vy[:, 0]) * dy) \
            / np.maximum(distance, 1e-9)
        with np.errstate(divide="ignore", invalid="ignore"):
            gap_time = np.where(closing > 0.0, (distance - self.gap) / closing, np.inf)
        trigger = (gap_time <= self.gap_time)[:, None] & self.equipped[obs.rows]
        active = self.active[obs.rows] | trigger
        active &= obs.speed > 0.0  # released at standstill
        self.active[obs.rows] = active
        return np.where(active, self.deceleration, 0.0)


@dataclasses.dataclass(frozen=True)
class GapTimeSystem:
    """The system a study runs: its parameters and a fresh controller per batch."""

    name: str = "gap-time"
    description: str = "example plugin: full braking (9 m/s^2) at a gap time of 1.2 s"
    gap_time_s: float = 1.2
    gap_m: float = 4.5
    deceleration_mps2: float = 9.0
    brake: BrakeActuatorParams = BrakeActuatorParams(jerk=40.0, release_jerk=40.0)

    def controller(self, batch, equipped) -> GapTimeController:  # noqa: ANN001
        """A controller for the cases of ``batch``; ``equipped`` broadcasts to (N, 2)."""
        mask = np.broadcast_to(np.asarray(equipped, dtype=bool), (batch.size, 2)).copy()
        return GapTimeController(mask, self.gap_time_s, self.gap_m, self.deceleration_mps2)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``base`` with this system's brake actuator."""
        return dataclasses.replace(base, brake=self.brake)

    def __reduce__(self):  # noqa: ANN204
        # worker processes of a study import this file by its path
        return (python_system, (__file__, "SYSTEM"))


SYSTEM = register_system(GapTimeSystem())
