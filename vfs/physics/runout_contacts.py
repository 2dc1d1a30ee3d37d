"""Contacts of the two vehicles of a pair in the run-out: separation, secondary collisions and,
on request, the impulses that keep the cars from passing through each other.

:class:`SecondaryCollisions` flags a renewed overlap after separation; :class:`Contacts`
(``RunoutParams(contact=True)``) also solves it with impulses of the impact model.  Both are
step callbacks of the run-out integrator (:func:`vfs.physics.runout.run_out_pair`);
docs/physics.md, section 5.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

import numpy as np

from vfs.physics.geometry import AREA_TOLERANCE, contact_geometry, overlap, vehicle_outline
from vfs.physics.impact import ImpactConfig, ImpactParams, contact_frame, solve_impact
from vfs.physics.vehicle import VehicleArrays


class PairState(Protocol):
    """What the callbacks read of the run-out state of the 2N vehicles (a
    :class:`vfs.physics.runout.RunoutState`): arrays (2N,), SI units, global frame.
    """

    @property
    def x(self) -> np.ndarray:
        """CG x [m]."""

    @property
    def y(self) -> np.ndarray:
        """CG y [m]."""

    @property
    def yaw(self) -> np.ndarray:
        """Heading [rad]."""

    @property
    def vx(self) -> np.ndarray:
        """CG velocity x [m/s]."""

    @property
    def vy(self) -> np.ndarray:
        """CG velocity y [m/s]."""

    @property
    def yaw_rate(self) -> np.ndarray:
        """Yaw rate [rad/s]."""


class Kick(NamedTuple):
    """New velocities of some vehicles after a step, from a step callback (contacts)."""

    rows: np.ndarray  # (k,) positions in the batch
    vx: np.ndarray  # [m/s] global
    vy: np.ndarray  # [m/s]
    yaw_rate: np.ndarray  # [rad/s]


#: A corner of one outline this deep [m] inside the other proves an overlap area
#: above AREA_TOLERANCE: the overlap then contains a quarter disc of this
#: radius around the corner, pi (1e-4)^2 / 4 = 7.9e-9 m^2 > 1e-9 m^2.
CORNER_DEPTH = 1e-4


class SecondaryCollisions:
    """Tracks separation and renewed overlap of the pairs (k, k + N) of a 2N batch.

    A pair is tested in three phases: the distance of the CGs against the sum
    of the corner radii (:func:`vfs.physics.vehicle.corner_radius`); for the near pairs the
    separating-axis test of the two rectangles (disjoint or touching -> no
    overlap) and the depth of the deepest corner inside the other outline
    (deeper than :data:`CORNER_DEPTH` -> overlap); only the remaining pairs go
    to :func:`vfs.physics.geometry.overlap`, whose area decides against AREA_TOLERANCE.
    """

    def __init__(self, vehicles: VehicleArrays, x: np.ndarray, y: np.ndarray,
                 yaw: np.ndarray) -> None:
        n = x.shape[0] // 2
        radius = vehicles.corner_radius
        self.vehicles = vehicles
        self.n = n
        self.radius_sum = radius[:n] + radius[n:]
        self.half_length = 0.5 * vehicles.length
        self.half_width = 0.5 * vehicles.width
        self.centre_offset = vehicles.cg_to_front - self.half_length  # CG -> outline centre
        self.separated = ~self._overlapping(np.arange(n), x, y, yaw)[0]
        self.secondary = np.zeros(n, bool)
        self.time = np.full(n, np.nan)
        self.next_check = np.zeros(n)  # earliest time a pair can touch [s]
        self.gyration2 = vehicles.yaw_inertia / vehicles.mass  # I / m [m^2]
        # outline point speed bound per unit CG speed bound: 1 + R / sqrt(I / m)
        self.reach = 1.0 + radius / np.sqrt(self.gyration2)

    def _overlapping(self, pairs: np.ndarray, x: np.ndarray, y: np.ndarray,
                     yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Overlap area > AREA_TOLERANCE for the given pair indices.

        Also returns the depth [m] of the deepest corner where it proved the
        overlap (0 elsewhere).
        """
        result = np.zeros(pairs.shape[0], bool)
        proof = np.zeros(pairs.shape[0])
        i, j = pairs, pairs + self.n
        dx = x[j] - x[i]
        dy = y[j] - y[i]
        near = np.flatnonzero(dx * dx + dy * dy < self.radius_sum[pairs] ** 2)
        if near.size == 0:
            return result, proof
        i, j = i[near], j[near]
        c1, s1, c2, s2 = np.cos(yaw[i]), np.sin(yaw[i]), np.cos(yaw[j]), np.sin(yaw[j])
        l1, w1 = self.half_length[i], self.half_width[i]
        l2, w2 = self.half_length[j], self.half_width[j]
        off1, off2 = self.centre_offset[i], self.centre_offset[j]
        # outline centre of 2 relative to that of 1, in frame 1 and in frame 2
        gx = dx[near] + off2 * c2 - off1 * c1
        gy = dy[near] + off2 * s2 - off1 * s1
        x12, y12 = c1 * gx + s1 * gy, c1 * gy - s1 * gx
        x21, y21 = -(c2 * gx + s2 * gy), -(c2 * gy - s2 * gx)
        cos_rel = c1 * c2 + s1 * s2  # heading of 2 relative to 1
        sin_rel = c1 * s2 - s1 * c2
        ac, as_ = np.abs(cos_rel), np.abs(sin_rel)
        # separating axes: the edge normals of both rectangles
        sat = (np.abs(x12) < l1 + l2 * ac + w2 * as_) & (np.abs(y12) < w1 + l2 * as_ + w2 * ac)
        sat &= (np.abs(x21) < l2 + l1 * ac + w1 * as_) & (np.abs(y21) < w2 + l1 * as_ + w1 * ac)
        depth = np.full(near.size, -np.inf)
        for sl in (1.0, -1.0):
            for sw in (1.0, -1.0):
                # corner of 2 in frame 1 (rotate by +rel) and corner of 1 in frame 2 (by -rel)
                px = x12 + sl * l2 * cos_rel - sw * w2 * sin_rel
                py = y12 + sl * l2 * sin_rel + sw * w2 * cos_rel
                depth = np.maximum(depth, np.minimum(l1 - np.abs(px), w1 - np.abs(py)))
                px = x21 + sl * l1 * cos_rel + sw * w1 * sin_rel
                py = y21 - sl * l1 * sin_rel + sw * w1 * cos_rel
                depth = np.maximum(depth, np.minimum(l2 - np.abs(px), w2 - np.abs(py)))
        deep = sat & (depth > CORNER_DEPTH)
        result[near[deep]] = True
        proof[near[deep]] = depth[deep]
        unsure = np.flatnonzero(sat & ~deep)
        if unsure.size:
            a, b = i[unsure], j[unsure]
            v = self.vehicles
            o1 = vehicle_outline(v.take(a), x[a], y[a], yaw[a])
            o2 = vehicle_outline(v.take(b), x[b], y[b], yaw[b])
            result[near[unsure]] = overlap(o1, o2).area > AREA_TOLERANCE
        return result, proof

    def __call__(self, t: float, state: PairState, moved: np.ndarray) -> None:
        """Check the pairs after the step ending at t [s] (a step callback)."""
        n = self.n
        check = np.flatnonzero(~self.secondary & (moved[:n] | moved[n:]) & (self.next_check <= t))
        if check.size == 0:
            return
        x, y, yaw = state.x, state.y, state.yaw
        over, depth = self._overlapping(check, x, y, yaw)
        # Skip pairs whose state cannot change for a while.  Kinetic energy E never
        # grows, so |v| <= sqrt(2 E / m) = vmax and |r| <= vmax / sqrt(I / m) for good:
        # corner circles a gap apart cannot touch before gap / (vmax1 + vmax2), and a
        # corner at depth d inside the other outline cannot get out (to the proof depth)
        # before (d - CORNER_DEPTH) / (vmax1 (1 + R1/g1) + vmax2 (1 + R2/g2)).
        i, j = check, check + n
        gap = np.hypot(x[j] - x[i], y[j] - y[i]) - self.radius_sum[check]
        both = np.concatenate([i, j])
        vx, vy, r = state.vx[both], state.vy[both], state.yaw_rate[both]
        vmax = np.sqrt(vx * vx + vy * vy + self.gyration2[both] * r * r)
        closing = vmax[: i.size] + vmax[i.size:]
        point = vmax * self.reach[both]
        escape = point[: i.size] + point[i.size:]
        was_separated = self.separated[check]
        with np.errstate(divide="ignore", invalid="ignore"):
            wait = np.where(gap > 0.0, gap / closing, 0.0)
            wait = np.where(~was_separated & (depth > CORNER_DEPTH),
                            (depth - CORNER_DEPTH) / escape, wait)
        self.next_check[check] = t + wait
        hit = check[was_separated & over]
        self.secondary[hit] = True
        self.time[hit] = t
        self.separated[check[~was_separated & ~over]] = True


#: Closing speed [m/s] of the contact points below which touching vehicles are left alone
#: (a resting contact: far below the stop speed v_stop).
CONTACT_CLOSING_SPEED = 1e-3


class Contacts:
    """Resolves the contact of the pairs (k, k + N) of a 2N batch (``RunoutParams.contact``).

    After every step the pairs whose outlines overlap (the tests of
    :class:`SecondaryCollisions`) get their POI and contact plane from the overlap
    (:func:`vfs.physics.geometry.contact_geometry`, as the impact); where the contact
    points approach each other faster than :data:`CONTACT_CLOSING_SPEED` (u_n < 0 in the
    contact frame of :func:`vfs.physics.impact.contact_frame`), the impact model's
    impulse (:func:`vfs.physics.impact.solve_impact`, restitution
    ``RunoutParams.contact_restitution``) changes both velocities.  Momentum is kept and
    the Kudlich-Slibar impulse never adds energy, so the run-out stays dissipative.
    Secondary collisions are flagged as without contacts (:class:`SecondaryCollisions`).
    """

    def __init__(self, vehicles: VehicleArrays, x: np.ndarray, y: np.ndarray,
                 yaw: np.ndarray, restitution: float) -> None:
        self.flags = SecondaryCollisions(vehicles, x, y, yaw)
        self.vehicles = vehicles
        self.n = x.shape[0] // 2
        self.restitution = float(restitution)
        self.friction = ImpactParams().contact_friction
        self.impulses = np.zeros(self.n, dtype=int)  # contact impulses per pair

    def __call__(self, t: float, state: PairState, moved: np.ndarray) -> Kick | None:
        """Flags, then impulses for the approaching overlapping pairs (a step callback)."""
        self.flags(t, state, moved)
        n = self.n
        check = np.flatnonzero(moved[:n] | moved[n:])
        if check.size == 0:
            return None
        over, _ = self.flags._overlapping(check, state.x, state.y, state.yaw)
        pairs = check[over]
        if pairs.size == 0:
            return None
        i, j = pairs, pairs + n
        v = self.vehicles
        o1 = vehicle_outline(v.take(i), state.x[i], state.y[i], state.yaw[i])
        o2 = vehicle_outline(v.take(j), state.x[j], state.y[j], state.yaw[j])
        geo = contact_geometry(o1, o2, np.stack([state.x[i], state.y[i]], axis=1),
                               np.stack([state.x[j], state.y[j]], axis=1))
        ok = np.isfinite(geo.poi[:, 0]) & np.isfinite(geo.cp_angle)
        if not ok.any():
            return None
        pairs, i, j = pairs[ok], i[ok], j[ok]

        def both(a: np.ndarray) -> np.ndarray:
            return np.stack([a[i], a[j]], axis=1)

        config = ImpactConfig.from_arrays(
            m=both(v.mass), izz=both(v.yaw_inertia), x=both(state.x), y=both(state.y),
            yaw=both(state.yaw), vx=both(state.vx), vy=both(state.vy),
            yaw_rate=both(state.yaw_rate), poi_x=geo.poi[ok, 0], poi_y=geo.poi[ok, 1],
            cp_angle=geo.cp_angle[ok], restitution=self.restitution,
            contact_friction=self.friction)
        closing = contact_frame(config).u_n < -CONTACT_CLOSING_SPEED
        if not closing.any():
            return None
        config = ImpactConfig(*(a[closing] for a in config))
        pairs, i, j = pairs[closing], i[closing], j[closing]
        res = solve_impact(config)
        self.impulses[pairs] += 1
        return Kick(np.concatenate([i, j]),
                    np.concatenate([res.vx_post[:, 0], res.vx_post[:, 1]]),
                    np.concatenate([res.vy_post[:, 0], res.vy_post[:, 1]]),
                    np.concatenate([res.yaw_rate_post[:, 0], res.yaw_rate_post[:, 1]]))
