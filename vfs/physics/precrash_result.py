"""Records of the pre-crash phase: the kinematic state of both vehicles and the phase's result.

Arrays per case (N,) or per case and participant (N, 2); SI units (m, s, rad, m/s).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["KinematicState", "PrecrashResult"]


class KinematicState(NamedTuple):
    """Pose and velocity of both vehicles of n cases (arrays (n, 2))."""

    x: np.ndarray  # CG [m]
    y: np.ndarray
    yaw: np.ndarray  # heading [rad]
    vx: np.ndarray  # CG velocity [m/s], global
    vy: np.ndarray
    yaw_rate: np.ndarray  # [rad/s]
    speed: np.ndarray  # [m/s]


class PrecrashResult(NamedTuple):
    """Outcome of the pre-crash phase for N cases.

    Attributes
    ----------
    collided : ndarray of bool (N,)
        The outlines touched.
    contact_time : ndarray (N,)
        First contact [s, relative to the record start], NaN if none.
    impact_time : ndarray (N,)
        contact_time + penetration time [s].
    impact_state : KinematicState
        Poses and velocities at impact_time ((N, 2) arrays, NaN if none).
    contact_state : KinematicState
        Poses and velocities at first contact.
    poi : ndarray (N, 2)
        Point of impact [m] at impact_time (centroid of the overlap).
    cp_angle : ndarray (N,)
        Contact-plane tangent [rad] at impact_time.
    cp_rule : ndarray of int (N,)
        Contact-plane rule applied (vfs.physics.geometry.CP_RULES).
    overlap_area : ndarray (N,)
        Overlap area at impact_time [m^2].
    min_distance : ndarray (N,)
        Smallest outline distance before contact [m] (0 if they touched).
    time_closest : ndarray (N,)
        Time of the smallest distance [s] (step resolution; the first of equal distances).
    brake_start : ndarray (N, 2)
        First time the actuator delivered deceleration [s], NaN if never.
    speed_reduction : ndarray (N, 2)
        Speed taken off the record by braking [m/s] at the impact (colliding cases) or
        at the end: v_rec - v, at most the recorded speed (a stopped vehicle: all of it).
    end_state : KinematicState
        Poses and velocities at the end of the simulated horizon for cases
        without a collision (NaN for colliding cases): where a braked
        vehicle came to a stop.
    end_time : float
        Time of the end of the simulated horizon [s] (the longest case's;
        each case ends at its own horizon: its longer record plus
        ``extra_time``).
    """

    collided: np.ndarray
    contact_time: np.ndarray
    impact_time: np.ndarray
    impact_state: KinematicState
    contact_state: KinematicState
    poi: np.ndarray
    cp_angle: np.ndarray
    cp_rule: np.ndarray
    overlap_area: np.ndarray
    min_distance: np.ndarray
    time_closest: np.ndarray
    brake_start: np.ndarray
    speed_reduction: np.ndarray
    end_state: KinematicState
    end_time: float

    def take(self, rows: np.ndarray) -> PrecrashResult:
        """The result of the cases ``rows`` (indices, repeats allowed), in that order.

        ``end_time`` stays that of the whole batch [s].
        """
        rows = np.asarray(rows)
        out: list[object] = []
        for name, value in zip(self._fields, self, strict=True):
            if isinstance(value, KinematicState):
                out.append(KinematicState(*(a[rows] for a in value)))
            elif name == "end_time":
                out.append(value)
            else:
                out.append(np.asarray(value)[rows])
        return PrecrashResult(*out)  # type: ignore[arg-type]

    def put(self, rows: np.ndarray, other: PrecrashResult) -> PrecrashResult:
        """A copy with the cases ``rows`` (distinct indices) replaced by the cases of
        ``other``, in order; ``end_time`` stays this result's [s].
        """
        rows = np.asarray(rows)
        out: list[object] = []
        for name, mine, theirs in zip(self._fields, self, other, strict=True):
            if isinstance(mine, KinematicState):
                parts = []
                for a, b in zip(mine, theirs, strict=True):
                    a = a.copy()
                    a[rows] = b
                    parts.append(a)
                out.append(KinematicState(*parts))
            elif name == "end_time":
                out.append(mine)
            else:
                a = np.array(mine, copy=True)
                a[rows] = theirs
                out.append(a)
        return PrecrashResult(*out)  # type: ignore[arg-type]
