"""Longitudinal speed profiles of scene participants: travel speed, late braking (closed form)."""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from vfs.physics.precrash import friction_limited_deceleration

if TYPE_CHECKING:
    from vfs.scenarios.catalogue import ScenarioSpec

#: Brake start [s after t*] used for participants that do not brake (never reached).
NO_BRAKE = 1.0e3
#: Default jerk [m/s^3] and deceleration [m/s^2] stored for participants that do not brake.
IDLE_JERK, IDLE_DECEL = 50.0, 6.0


def brake_ramp(s: np.ndarray, jerk: np.ndarray, decel: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Speed [m/s] and distance [m] taken off by braking for s [s] >= 0 after its start.

    The deceleration rises with ``jerk`` [m/s^3] to ``decel`` [m/s^2] (after s_r =
    decel / jerk) and stays there.
    """
    s_r = decel / jerk
    ramp = s <= s_r
    dv = np.where(ramp, 0.5 * jerk * s**2, decel * (s - 0.5 * s_r))
    dx = np.where(ramp, jerk * s**3 / 6.0,
                  0.5 * decel * s**2 - 0.5 * decel * s_r * s + decel * s_r**2 / 6.0)
    return dv, dx


def brake_time_for_drop(drop: np.ndarray, jerk: np.ndarray, decel: np.ndarray) -> np.ndarray:
    """Braking time [s] that takes ``drop`` [m/s] off the speed (inverse of the ramp)."""
    s_r = decel / jerk
    return np.where(drop <= 0.5 * decel * s_r, np.sqrt(2.0 * np.maximum(drop, 0.0) / jerk),
                    drop / decel + 0.5 * s_r)


def longitudinal_motion(tau: np.ndarray, v_travel: np.ndarray, brake_time: np.ndarray,
                        jerk: np.ndarray, decel: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed-form longitudinal motion at times tau [s, relative to t*].

    Parameters
    ----------
    tau : ndarray
        Times relative to the designed impact [s] (broadcast with the others).
    v_travel : ndarray
        Travel speed before braking [m/s].
    brake_time : ndarray
        Brake start relative to t* [s] (:data:`NO_BRAKE` = never).
    jerk, decel : ndarray
        Brake build-up [m/s^3] and deceleration level [m/s^2].

    Returns
    -------
    position : ndarray
        Distance travelled [m] relative to the brake start (any fixed reference).
    speed : ndarray
        Speed [m/s] (>= 0; a braked vehicle stays at rest).
    accel : ndarray
        Longitudinal acceleration [m/s^2] (negative while braking).
    """
    s_stop = brake_time_for_drop(v_travel, jerk, decel)
    s = tau - brake_time
    sc = np.clip(s, 0.0, s_stop)
    dv, dx = brake_ramp(sc, jerk, decel)
    position = v_travel * np.minimum(s, s_stop) - dx
    speed = np.maximum(v_travel - dv, 0.0)
    accel = np.where((s > 0.0) & (s < s_stop), -np.minimum(jerk * s, decel), 0.0)
    return position, speed, accel


class SpeedProfile(NamedTuple):
    """Speed-profile parameters of n participants (arrays (n,))."""

    v_travel: np.ndarray  # [m/s]
    brake_time: np.ndarray  # brake start relative to t* [s], NO_BRAKE if none
    jerk: np.ndarray  # [m/s^3]
    decel: np.ndarray  # [m/s^2]

    @property
    def braking(self) -> np.ndarray:
        """True where the profile brakes before the crash."""
        return self.brake_time < 0.5 * NO_BRAKE

    def at(self, tau: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position [m], speed [m/s] and acceleration [m/s^2] at tau [s, relative to t*]."""
        return longitudinal_motion(np.asarray(tau, float), self.v_travel, self.brake_time,
                                   self.jerk, self.decel)

    def speed_at(self, tau: np.ndarray | float) -> np.ndarray:
        """Speed [m/s] at tau [s, relative to t*]."""
        return self.at(tau)[1]

    def distance_before(self, lead: np.ndarray | float) -> np.ndarray:
        """Distance [m] covered in the ``lead`` [s] before t*."""
        return self.at(0.0)[0] - self.at(-np.asarray(lead, float))[0]


def draw_speed_profile(rng: np.random.Generator, n: int, speed: tuple[float, float],
                       brake_prob: float, spec: ScenarioSpec, mu: np.ndarray,
                       min_share: float) -> SpeedProfile:
    """Travel speeds and late braking of n participants."""
    v = rng.uniform(speed[0], speed[1], n)
    brake = rng.random(n) < brake_prob
    lead = rng.uniform(*spec.brake_lead_time, n)
    jerk = rng.uniform(*spec.brake_jerk, n)
    decel = friction_limited_deceleration(mu, rng.uniform(*spec.brake_deceleration, n))
    # a late brake leaves at least min_share of the travel speed at t*
    lead = np.minimum(lead, brake_time_for_drop(v * (1.0 - min_share), jerk, decel))
    brake &= (v > 0.0) & (lead > 1e-3)
    return SpeedProfile(v, np.where(brake, -lead, NO_BRAKE), np.where(brake, jerk, IDLE_JERK),
                   np.where(brake, decel, IDLE_DECEL))
