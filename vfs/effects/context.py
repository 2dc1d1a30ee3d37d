"""What an effect hook sees: the colliding cases at first contact and at impact.

Contexts hold arrays over the n colliding cases of a batch (``rows`` index
the batch) and compute derived geometry lazily, once per simulation, so
that several effects can share it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from vfs.physics.geometry import (
    Overlap,
    contact_faces,
    overlap,
    swept_overlap,
    to_vehicle_frame,
    vehicle_outline,
)
from vfs.physics.precrash import KinematicState
from vfs.physics.vehicle import VehicleArrays


@dataclass(frozen=True, eq=False)
class _PairContext:
    rows: np.ndarray
    vehicle1: VehicleArrays
    vehicle2: VehicleArrays
    state: KinematicState
    road_friction: np.ndarray

    @property
    def size(self) -> int:
        """Number of cases n."""
        return int(self.rows.shape[0])

    @cached_property
    def outline1(self) -> np.ndarray:
        """Outline corners of vehicle 1 (n, 4, 2) [m]."""
        s = self.state
        return vehicle_outline(self.vehicle1, s.x[:, 0], s.y[:, 0], s.yaw[:, 0])

    @cached_property
    def outline2(self) -> np.ndarray:
        """Outline corners of vehicle 2 (n, 4, 2) [m]."""
        s = self.state
        return vehicle_outline(self.vehicle2, s.x[:, 1], s.y[:, 1], s.yaw[:, 1])

    @cached_property
    def relative_velocity(self) -> np.ndarray:
        """CG velocity of vehicle 1 relative to vehicle 2 (n, 2) [m/s]."""
        s = self.state
        return np.stack([s.vx[:, 0] - s.vx[:, 1], s.vy[:, 0] - s.vy[:, 1]], axis=1)

    @cached_property
    def relative_speed(self) -> np.ndarray:
        """|v1 - v2| of the CGs (n,) [m/s]."""
        return np.hypot(self.relative_velocity[:, 0], self.relative_velocity[:, 1])

    @cached_property
    def swept_overlap(self) -> np.ndarray:
        """Overlap ratio along the relative velocity (n,) [-]
        (:func:`vfs.physics.geometry.swept_overlap`).
        """
        return swept_overlap(self.outline1, self.outline2, self.relative_velocity)


@dataclass(frozen=True, eq=False)
class ContactContext(_PairContext):
    """The colliding cases at first contact (stage ``penetration``).

    Attributes
    ----------
    rows : ndarray of int (n,)
        Case indices in the batch.
    vehicle1, vehicle2 : VehicleArrays
        Vehicles of these cases.
    state : KinematicState
        Poses and velocities at first contact ((n, 2) arrays).
    road_friction : ndarray (n,)
        Tyre-road friction [-].
    """


@dataclass(frozen=True, eq=False)
class ImpactContext(_PairContext):
    """The colliding cases at the impact configuration (impact stages).

    Attributes
    ----------
    rows, vehicle1, vehicle2, road_friction
        As in :class:`ContactContext`.
    state : KinematicState
        Poses and velocities at impact ((n, 2) arrays).
    contact_time, impact_time : ndarray (n,)
        First contact and impact [s, record time axis].
    """

    contact_time: np.ndarray = None  # type: ignore[assignment]
    impact_time: np.ndarray = None  # type: ignore[assignment]

    @cached_property
    def overlap(self) -> Overlap:
        """Overlap polygon, area [m^2] and centroid [m] of the outlines at impact."""
        return overlap(self.outline1, self.outline2)

    @cached_property
    def faces(self) -> np.ndarray:
        """Face of each outline nearest the overlap centroid (n, 2), codes of
        :func:`vfs.physics.geometry.contact_faces` (front, rear, left, right).
        """
        s = self.state
        c = self.overlap.centroid
        f1 = contact_faces(c, self.vehicle1, s.x[:, 0], s.y[:, 0], s.yaw[:, 0])
        f2 = contact_faces(c, self.vehicle2, s.x[:, 1], s.y[:, 1], s.yaw[:, 1])
        return np.stack([f1, f2], axis=1)

    @cached_property
    def overlap_local(self) -> tuple[np.ndarray, np.ndarray]:
        """Overlap polygon vertices in the frames of vehicle 1 and vehicle 2,
        (n, W, 2) each [m] (x forward, y left, origin at the CG).
        """
        poly = self.overlap.polygon.vertices
        n, w = poly.shape[0], poly.shape[1]
        s = self.state
        return tuple(  # type: ignore[return-value]
            to_vehicle_frame(poly.reshape(-1, 2), np.repeat(s.x[:, j], w),
                             np.repeat(s.y[:, j], w), np.repeat(s.yaw[:, j], w)).reshape(n, w, 2)
            for j in (0, 1))
