"""Braking in the pre-crash phase: the brake actuator, the controller interface, the friction limit.

A controller (AEB, scheduled braking, a gym agent) sees a
:class:`PrecrashObservation` each step and demands a deceleration [m/s^2]; the
brake actuator (:class:`BrakeActuatorParams`, :func:`actuator_step`) builds it up,
jerk-limited or first-order, and limits it to the road friction
(:func:`friction_limited_deceleration`).  :mod:`vfs.physics.precrash` runs the
step loop that uses them.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError
from vfs.settings import setting, validate
from vfs.units import G

__all__ = [
    "BrakeActuatorParams",
    "BrakeController",
    "BrakeModel",
    "PrecrashObservation",
    "ScheduledBraking",
    "actuator_step",
    "friction_limited_deceleration",
]


class BrakeModel(StrEnum):
    """How the brake actuator builds the deceleration up (:class:`BrakeActuatorParams`)."""

    JERK = "jerk"
    FIRST_ORDER = "first_order"


_JERK = dict(lo=0.0, lo_open=True, hi=1e6)  # [m/s^3]; 1e5 and more: a step


@dataclass(frozen=True)
class BrakeActuatorParams:
    """Brake build-up from demand to delivered deceleration.

    Attributes
    ----------
    model : {'jerk', 'first_order'}
        'jerk': the deceleration ramps towards the demand with at most
        ``jerk`` [m/s^3] (and releases with ``release_jerk``);
        'first_order': dd/dt = (demand - d) / ``time_constant``.
    jerk : float
        Build-up rate [m/s^3].  Default 40 m/s^3: 8 m/s^2 after 0.2 s, inside
        the 0.1-0.3 s brake lag of the Reconstruction chapter ("Lag").
    release_jerk : float
        Release rate [m/s^3], default 40.
    time_constant : float
        First-order time constant [s], default 0.1 (63 % after 0.1 s, 95 %
        after 0.3 s: the Reconstruction chapter's brake lag range).
    max_deceleration : float
        Brake-system limit [m/s^2] before the road limit; default 10.
    """

    model: str = setting("jerk", "text", "jerk: the deceleration ramps towards the demand at "
                         "jerk / release_jerk; first_order: d' = (demand - d) / time_constant",
                         choices=BrakeModel)
    jerk: float = setting(40.0, "jerk", "build-up rate of the deceleration (1e5 = a step)",
                          **_JERK)  # type: ignore[arg-type]
    release_jerk: float = setting(40.0, "jerk", "release rate",
                                  **_JERK)  # type: ignore[arg-type]
    time_constant: float = setting(0.1, "time", "first-order time constant (model "
                                   "first_order)", lo=0.0, lo_open=True, hi=10.0)
    max_deceleration: float = setting(10.0, "acceleration", "brake-system limit before the "
                                      "road limit", lo=0.0, lo_open=True, hi=100.0)

    def __post_init__(self) -> None:
        validate(self)



class PrecrashObservation(NamedTuple):
    """What a controller sees at one step, for the n cases still running.

    Arrays have shape (n,) or (n, 2) (participant 1 and 2 in columns).
    Controllers that model sensors (adas) derive their measurements from it.
    """

    rows: np.ndarray  # case indices into the batch (n,)
    t: float | np.ndarray  # time since the start of the records [s] (scalar or per case (n,))
    x: np.ndarray  # CG positions [m] (n, 2)
    y: np.ndarray
    yaw: np.ndarray  # headings [rad] (n, 2)
    heading: np.ndarray  # direction of motion [rad] (n, 2)
    speed: np.ndarray  # [m/s] (n, 2)
    accel: np.ndarray  # current longitudinal acceleration [m/s^2] (n, 2)
    yaw_rate: np.ndarray  # [rad/s] (n, 2)
    deceleration: np.ndarray  # delivered brake deceleration [m/s^2] (n, 2)
    road_friction: np.ndarray  # (n,)
    vx: np.ndarray | None = None  # CG velocity [m/s], global (n, 2) (speed x heading)
    vy: np.ndarray | None = None


class BrakeController(Protocol):
    """A controller demands a deceleration [m/s^2] (>= 0) per case and participant."""

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Prepare for a batch of ``n_cases`` cases."""

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        """Demanded deceleration [m/s^2], shape (n, 2), for ``obs.rows``."""


class ScheduledBraking:
    """Brake with a fixed demand from a given time on (per case and participant).

    Parameters
    ----------
    start_time : array_like (N, 2)
        Time [s, relative to the record start] at which braking is demanded;
        NaN or inf = never.
    deceleration : array_like (N, 2)
        Demanded deceleration [m/s^2].
    """

    def __init__(self, start_time: npt.ArrayLike, deceleration: npt.ArrayLike) -> None:
        self.start_time = np.atleast_2d(np.asarray(start_time, float))
        self.deceleration = np.broadcast_to(np.asarray(deceleration, float),
                                            self.start_time.shape)

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:  # noqa: D102
        if self.start_time.shape[0] != n_cases:
            raise ParameterError(f"ScheduledBraking has {self.start_time.shape[0]} rows for "
                                 f"{n_cases} cases")

    def demand(self, obs: PrecrashObservation) -> np.ndarray:  # noqa: D102
        start = self.start_time[obs.rows]
        # 1 ns slack: a start time on the step grid is not missed by rounding
        on = obs.t >= np.nan_to_num(start, nan=np.inf) - 1e-9
        return np.where(on, self.deceleration[obs.rows], 0.0)


def actuator_step(current: np.ndarray, demand: np.ndarray, limit: np.ndarray,
                  params: BrakeActuatorParams, dt: float) -> np.ndarray:
    """Delivered deceleration [m/s^2] after one step of the brake build-up."""
    target = np.clip(demand, 0.0, limit)
    if params.model == "jerk":
        step = np.clip(target - current, -params.release_jerk * dt, params.jerk * dt)
        return current + step
    alpha = 1.0 - np.exp(-dt / params.time_constant)
    return current + alpha * (target - current)



def friction_limited_deceleration(road_friction: npt.ArrayLike,
                                  max_deceleration: npt.ArrayLike) -> np.ndarray:
    """Largest braking deceleration [m/s^2]: min(mu g, a_max).

    The tyre-road friction coefficient ``road_friction`` [-] bounds the
    deceleration by mu g; ``max_deceleration`` [m/s^2] is the limit of the
    brake system or of the driver (broadcast against each other).
    """
    return np.minimum(np.asarray(road_friction) * G, max_deceleration)

