"""What the agent observes: the sensor and the privileged (full-state) observation.

docs/gym.md, "Observation", documents every entry; :func:`observe` computes them for
many case instances at once (float32, clipped to the Box bounds).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple, Protocol

import numpy as np

from vfs.adas.params import SensorParams
from vfs.adas.sensor import outline_visible
from vfs.adas.threat import Motion, time_to_collision
from vfs.gym.compiled import UNIT_CORNERS, rectangle_distance_compiled, sensor_kernel
from vfs.physics.geometry import rectangle_distance
from vfs.physics.numba_support import enabled as compiled_enabled
from vfs.physics.numba_support import run_kernel
from vfs.physics.precrash import PrecrashObservation

if TYPE_CHECKING:
    from vfs.simulation import CaseBatch

#: Names of the sensor observation's entries, in order (docs/gym.md, "Observation").
OBSERVATION_NAMES: tuple[str, ...] = (
    "ego_speed", "ego_accel", "object_seen", "gap", "rel_x", "rel_y", "rel_vx", "rel_vy",
    "ttc", "road_friction",
)
#: Units of :data:`OBSERVATION_NAMES`.
OBSERVATION_UNITS: tuple[str, ...] = ("m/s", "m/s^2", "-", "m", "m", "m", "m/s", "m/s", "s", "-")
#: Bounds of the sensor observation (values are clipped to them).
OBSERVATION_LOW = np.array([0.0, -20.0, 0.0, 0.0, -200.0, -200.0, -100.0, -100.0, 0.0, 0.0])
OBSERVATION_HIGH = np.array([80.0, 20.0, 1.0, 200.0, 200.0, 200.0, 100.0, 100.0, 10.0, 2.0])

#: Names of the privileged (full-state) observation's entries, in order.
PRIVILEGED_NAMES: tuple[str, ...] = (
    "t", "road_friction", "ego_speed", "ego_accel", "ego_yaw_rate", "ego_deceleration",
    "obj_x", "obj_y", "obj_rel_yaw", "obj_vx", "obj_vy", "obj_yaw_rate", "obj_speed",
    "obj_accel", "ego_length", "ego_width", "ego_cg_to_front", "obj_length", "obj_width",
    "obj_cg_to_front", "gap",
)
PRIVILEGED_LOW = np.array([0.0, 0.0, 0.0, -20.0, -10.0, 0.0, -1000.0, -1000.0, -math.pi,
                           -100.0, -100.0, -10.0, 0.0, -20.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                           0.0])
PRIVILEGED_HIGH = np.array([120.0, 2.0, 80.0, 20.0, 10.0, 20.0, 1000.0, 1000.0, math.pi,
                            100.0, 100.0, 10.0, 80.0, 20.0, 25.0, 5.0, 25.0, 25.0, 5.0, 25.0,
                            2000.0])

class ObservationSettings(Protocol):
    """What :func:`observe` reads of the environment's configuration.

    :class:`vfs.gym.config.EnvConfig` satisfies it; declared here so that this module does
    not import the configuration module, which imports this one (no cycle, not even a
    type-only one).
    """

    @property
    def ego(self) -> int:
        """Vehicle under control, 1 or 2."""

    @property
    def sensor(self) -> SensorParams:
        """The ego vehicle's sensor."""

    @property
    def observe_friction(self) -> bool:
        """Whether the road friction is observed."""

    @property
    def privileged(self) -> bool:
        """Whether the observation holds the full state (not only what the sensor sees)."""

    @property
    def threat_features(self) -> bool:
        """Whether the threat entries :data:`THREAT_NAMES` are appended."""


#: Names of the threat entries appended with ``EnvConfig.threat_features`` (docs/gym.md,
#: "Observation"): both yaw rates, the miss distance and time of closest approach under
#: constant velocity, and the time to collision of the outlines under constant turn rate.
THREAT_NAMES: tuple[str, ...] = ("ego_yaw_rate", "obj_yaw_rate", "miss_cv", "t_closest",
                                 "ttc_ctrv")
#: Units of :data:`THREAT_NAMES`.
THREAT_UNITS: tuple[str, ...] = ("rad/s", "rad/s", "m", "s", "s")
THREAT_LOW = np.array([-5.0, -5.0, -20.0, -10.0, 0.0])
THREAT_HIGH = np.array([5.0, 5.0, 50.0, 10.0, 10.0])

_OBS_BOUNDS = (OBSERVATION_LOW.astype(np.float32), OBSERVATION_HIGH.astype(np.float32))
_PRIV_BOUNDS = (PRIVILEGED_LOW.astype(np.float32), PRIVILEGED_HIGH.astype(np.float32))
_THREAT_BOUNDS = (THREAT_LOW.astype(np.float32), THREAT_HIGH.astype(np.float32))

#: TTC reported when no contact is approaching [s] (the top of its range); also the
#: horizon of the constant-turn-rate TTC of the threat entries.
TTC_NONE = 10.0




class Dimensions(NamedTuple):
    """Outline dimensions [m] of ego and object per case instance (float32 arrays (N,))."""

    ego_front: np.ndarray
    ego_rear: np.ndarray
    ego_width: np.ndarray
    obj_front: np.ndarray
    obj_rear: np.ndarray
    obj_width: np.ndarray

    @classmethod
    def of(cls, batch: CaseBatch, ego: int) -> Dimensions:
        """Dimensions of the cases of ``batch`` with participant ``ego`` (1/2) as ego."""
        v = (batch.vehicle1, batch.vehicle2)
        e, o = v[ego - 1], v[2 - ego]
        f = np.float32
        return cls(e.cg_to_front.astype(f), e.cg_to_rear.astype(f), e.width.astype(f),
                   o.cg_to_front.astype(f), o.cg_to_rear.astype(f), o.width.astype(f))

    def take(self, rows: np.ndarray) -> Dimensions:
        """Rows ``rows``."""
        return Dimensions(*(a[rows] for a in self))


def _visible(sx: np.ndarray, sy: np.ndarray, bx: np.ndarray, by: np.ndarray,
             sensor: SensorParams, cx: np.ndarray, cy: np.ndarray, co: np.ndarray,
             so: np.ndarray, hl: np.ndarray, hw: np.ndarray) -> np.ndarray:
    """:func:`vfs.adas.sensor.outline_visible` with quick decisions first: the object's centre
    inside the sector (seen) or beyond range + circumradius (not seen); the exact test
    runs on the rest only.  (bx, by): boresight unit vector; (co, so): object axis.
    """
    dx, dy = cx - sx, cy - sy
    dist = np.sqrt(dx * dx + dy * dy)
    half = 0.5 * sensor.field_of_view
    ahead = (dx * bx + dy * by) >= math.cos(half) * dist if half < math.pi else True
    seen = (dist <= sensor.range) & ahead
    unsure = ~seen & (dist - np.sqrt(hl * hl + hw * hw) <= sensor.range)
    if unsure.any():
        u = np.flatnonzero(unsure)
        seen[u] = outline_visible(sx[u], sy[u], np.arctan2(by[u], bx[u]), sensor.field_of_view,
                                  sensor.range, cx[u], cy[u], np.arctan2(so[u], co[u]),
                                  hl[u], hw[u])
    return seen


def miss_distance_cv(rx: np.ndarray, ry: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                     yaw_a: np.ndarray, hl_a: np.ndarray, hw_a: np.ndarray,
                     yaw_b: np.ndarray, hl_b: np.ndarray, hw_b: np.ndarray,
                     gap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed miss distance [m] and time of closest approach [s] under constant velocity.

    Rectangle B (centre (rx, ry) [m] from A's centre) moves relative to A with the
    constant velocity (vx, vy) [m/s]; both keep their orientations.  Its path meets A
    where the Minkowski sum of the two rectangles (a convex set symmetric about B's
    centre, whose half-width across the motion is the sum of the two support
    functions h(n) = hl |n . u| + hw |n . w| along the unit normal n of the motion)
    crosses the line of motion, so the distance between the outlines at their closest
    approach is exactly ``|n . r| - h_A(n) - h_B(n)`` when positive; a negative value is
    how far B's path reaches into A (the lateral displacement that would just make it
    graze).  The time of closest approach of the centres is ``-(r . v) / |v|^2``;
    where it is not in the future (receding, or no relative motion) the miss
    distance is the present ``gap`` [m].

    Returns
    -------
    miss, t_closest : ndarray
        Signed miss distance [m] and time of closest approach [s] (0 without relative
        motion).
    """
    v2 = vx * vx + vy * vy
    moving = v2 > 1e-12
    speed = np.sqrt(np.where(moving, v2, 1.0))
    nx, ny = -vy / speed, vx / speed
    ca, sa, cb, sb = np.cos(yaw_a), np.sin(yaw_a), np.cos(yaw_b), np.sin(yaw_b)
    reach = (hl_a * np.abs(nx * ca + ny * sa) + hw_a * np.abs(ny * ca - nx * sa)
             + hl_b * np.abs(nx * cb + ny * sb) + hw_b * np.abs(ny * cb - nx * sb))
    t_closest = np.where(moving, -(rx * vx + ry * vy) / np.where(moving, v2, 1.0), 0.0)
    miss = np.where(t_closest > 0.0, np.abs(nx * rx + ny * ry) - reach, gap)
    return miss, t_closest


def threat_entries(p: PrecrashObservation, dims: Dimensions, ego: int, gap: np.ndarray,
                   horizon: float = TTC_NONE) -> np.ndarray:
    """The threat entries (:data:`THREAT_NAMES`) of the cases ``p.rows``, (n, 5) float64.

    Ego and object yaw rates [rad/s]; :func:`miss_distance_cv` of the outlines [m] and
    the time of closest approach [s]; the time to collision of the outlines under the
    constant turn rate and velocity prediction of the AEB systems
    (:func:`vfs.adas.threat.time_to_collision`, model "ctrv") within ``horizon`` [s]
    (``horizon`` where there is no contact).  ``gap`` is the present distance of the
    outlines [m].
    """
    e, o = ego - 1, 2 - ego
    ef, er, ew, of, orr, ow = (np.asarray(a, float) for a in dims.take(p.rows))
    heading = np.where(p.speed > 0.0, p.heading, p.yaw)  # the yaw at standstill
    vx = p.vx if p.vx is not None else p.speed * np.cos(p.heading)
    vy = p.vy if p.vy is not None else p.speed * np.sin(p.heading)
    motions = []
    for k, (front, rear, width) in ((e, (ef, er, ew)), (o, (of, orr, ow))):
        motions.append(Motion(p.x[:, k], p.y[:, k], p.yaw[:, k], heading[:, k], p.speed[:, k],
                              p.accel[:, k], p.yaw_rate[:, k], 0.5 * (front + rear),
                              0.5 * width, 0.5 * (front - rear)))
    a, b = motions
    ca, sa, cb, sb = np.cos(a.yaw), np.sin(a.yaw), np.cos(b.yaw), np.sin(b.yaw)
    rx = b.x + b.centre_offset * cb - a.x - a.centre_offset * ca
    ry = b.y + b.centre_offset * sb - a.y - a.centre_offset * sa
    miss, t_closest = miss_distance_cv(rx, ry, vx[:, o] - vx[:, e], vy[:, o] - vy[:, e],
                                       a.yaw, a.half_length, a.half_width, b.yaw,
                                       b.half_length, b.half_width, np.asarray(gap, float))
    ttc = np.minimum(time_to_collision(a, b, horizon, "ctrv"), horizon)
    return np.stack([p.yaw_rate[:, e], p.yaw_rate[:, o], miss, t_closest, ttc], axis=1)


def observe(p: PrecrashObservation, dims: Dimensions, cfg: ObservationSettings) -> np.ndarray:
    """Observations (n, d) float32 of the cases ``p.rows`` (docs/gym.md, "Observation").

    :func:`observe_reference`; the sensor observation without threat entries (the
    default) by the compiled kernel (:func:`vfs.gym.compiled.sensor_kernel`) where
    :func:`vfs.physics.numba_support.enabled`: the same numbers bit for bit
    (``tests/gym/test_fast_observation.py``), without some hundred numpy calls per step.
    """
    if (compiled_enabled() and not cfg.privileged and not cfg.threat_features
            and p.vx is not None and p.vy is not None):
        return _observe_sensor_compiled(p, p.vx, p.vy, dims, cfg)
    return observe_reference(p, dims, cfg)


#: Non-empty once the sensor kernel ran in this process (:func:`_observe_sensor_compiled`).
_KERNEL_LOADED: list[bool] = []


def _observe_sensor_compiled(p: PrecrashObservation, vx: np.ndarray, vy: np.ndarray,
                             dims: Dimensions, cfg: ObservationSettings) -> np.ndarray:
    """:func:`observe_reference` of the sensor observation by the compiled kernel
    (``vx``, ``vy``: ``p.vx``, ``p.vy``, not None).
    """
    rows = p.rows
    n = rows.shape[0]
    e, o = cfg.ego - 1, 2 - cfg.ego
    f32 = np.float32
    yaw32 = p.yaw.astype(f32)
    yc, ys = np.cos(yaw32), np.sin(yaw32)
    sn = cfg.sensor
    boresight = bool(sn.mount_yaw)
    if boresight:
        b = yaw32[:, e] + f32(sn.mount_yaw)
        bx, by = np.cos(b), np.sin(b)
    else:
        bx = by = yc[:0, e]
    half = 0.5 * sn.field_of_view
    out = np.empty((n, 10), f32)
    unsure = np.empty(n, np.int8)
    aux = np.empty((n, 6), f32)
    seen_in = np.empty(0, np.int8)
    low, high = _OBS_BOUNDS
    args = (p.x, p.y, p.yaw, yc, ys, p.speed, p.accel, vx, vy, p.road_friction, rows,
            *dims, e, o, boresight, bx, by, f32(sn.mount_x), f32(sn.mount_y),
            half < math.pi, half, f32(math.cos(half)), f32(sn.range), bool(cfg.observe_friction),
            low, high, *UNIT_CORNERS)
    kernel = sensor_kernel()
    if _KERNEL_LOADED:
        kernel(*args, seen_in, False, out, unsure, aux)
    else:  # the first call says when numba compiled the kernel instead of loading its cache
        run_kernel(kernel, "sensor observation of the gym", *args, seen_in, False, out,
                   unsure, aux)
        _KERNEL_LOADED.append(True)
    if n and unsure.any():  # the exact visibility test of the reference (numpy)
        u = np.flatnonzero(unsure)
        a = aux[u]
        bu = np.arctan2(by[u], bx[u]) if boresight else np.arctan2(ys[u, e], yc[u, e])
        seen_in = np.full(n, -1, np.int8)
        seen_in[u] = outline_visible(a[:, 0], a[:, 1], bu, sn.field_of_view, sn.range,
                                     a[:, 2], a[:, 3], np.arctan2(ys[u, o], yc[u, o]),
                                     a[:, 4], a[:, 5])
        kernel(*args, seen_in, True, out, unsure, aux)
    return out


def observe_reference(p: PrecrashObservation, dims: Dimensions,
                      cfg: ObservationSettings) -> np.ndarray:
    """Observations (n, d) float32 of the cases ``p.rows`` (docs/gym.md, "Observation").

    Sensor observation (:data:`OBSERVATION_NAMES`): ego speed [m/s] and
    longitudinal acceleration [m/s^2]; whether the object's outline is in
    the sensor's field of view (1/0); when it is: the gap between the
    outlines [m], the position of the object's geometric centre relative to
    the ego's front-bumper centre in the ego frame (x forward, y left) [m],
    the object's velocity relative to the ego in the ego frame [m/s], and
    the time to collision gap / closing speed [s] (closing speed = rate at
    which the centres approach; :data:`TTC_NONE` when not approaching);
    zeros (TTC :data:`TTC_NONE`) when unseen; the road friction coefficient
    (0 unless ``observe_friction``).  The privileged observation
    (:data:`PRIVILEGED_NAMES`) is the full state in the ego frame.  With
    ``cfg.threat_features`` the entries :data:`THREAT_NAMES`
    (:func:`threat_entries`) follow; in the sensor view those of the object are
    0 (its TTC :data:`TTC_NONE`) when it is unseen.  Values are clipped to the
    Box bounds.
    """
    rows = p.rows
    e, o = cfg.ego - 1, 2 - cfg.ego
    f32 = np.float32
    # positions relative to the ego CG in float64, then everything in float32 (the
    # observation's type; float32 sin/cos are SIMD, float64 ones are not)
    ex, ey = p.x[:, e], p.y[:, e]
    ox, oy = (p.x[:, o] - ex).astype(f32), (p.y[:, o] - ey).astype(f32)
    eyaw, oyaw = p.yaw[:, e].astype(f32), p.yaw[:, o].astype(f32)
    ce, se = np.cos(eyaw), np.sin(eyaw)
    co, so = np.cos(oyaw), np.sin(oyaw)
    ev = p.speed[:, e].astype(f32)
    if p.vx is not None and p.vy is not None:
        vx, vy = p.vx.astype(f32), p.vy.astype(f32)
    else:
        h = p.heading.astype(f32)
        vx, vy = p.speed.astype(f32) * np.cos(h), p.speed.astype(f32) * np.sin(h)
    dims_rows = dims.take(rows)
    ef, er, ew, of, orr, ow = dims_rows
    e_c, o_c = 0.5 * (ef - er), 0.5 * (of - orr)  # geometric centre ahead of the CG
    ecx, ecy = e_c * ce, e_c * se  # geometric centres, relative to the ego CG
    ocx, ocy = ox + o_c * co, oy + o_c * so
    ehl, ohl = 0.5 * (ef + er), 0.5 * (of + orr)
    distance = rectangle_distance_compiled if compiled_enabled() else rectangle_distance
    gap = distance(ecx, ecy, eyaw, ehl, 0.5 * ew, ocx, ocy, oyaw, ohl, 0.5 * ow)
    # object centre relative to the ego's front-bumper centre, ego frame
    dx, dy = ocx - ef * ce, ocy - ef * se
    dvx, dvy = vx[:, o] - vx[:, e], vy[:, o] - vy[:, e]
    rel_x, rel_y = ce * dx + se * dy, -se * dx + ce * dy
    rel_vx, rel_vy = ce * dvx + se * dvy, -se * dvx + ce * dvy
    closing = -(dx * dvx + dy * dvy) / np.maximum(np.sqrt(dx * dx + dy * dy), f32(1e-9))
    ttc = np.where(closing > 0.0, gap / np.maximum(closing, f32(1e-12)), f32(TTC_NONE))
    friction = p.road_friction.astype(f32) if cfg.observe_friction else \
        np.zeros(rows.shape[0], f32)
    accel = p.accel[:, e].astype(f32)
    if cfg.privileged:
        orel = np.arctan2(ce * so - se * co, ce * co + se * so)
        cols = [np.broadcast_to(np.asarray(p.t, f32), rows.shape), friction, ev, accel,
                p.yaw_rate[:, e], p.deceleration[:, e],
                ce * ox + se * oy, -se * ox + ce * oy, orel,
                rel_vx, rel_vy, p.yaw_rate[:, o], p.speed[:, o], p.accel[:, o],
                ef + er, ew, ef, of + orr, ow, of, gap]
        low, high = _PRIV_BOUNDS
    else:
        sn = cfg.sensor
        mx, my = ef + f32(sn.mount_x), f32(sn.mount_y)
        if sn.mount_yaw:
            bx, by = np.cos(eyaw + f32(sn.mount_yaw)), np.sin(eyaw + f32(sn.mount_yaw))
        else:
            bx, by = ce, se
        seen = _visible(ce * mx - se * my, se * mx + ce * my, bx, by, sn, ocx, ocy, co, so,
                        ohl, 0.5 * ow)
        cols = [ev, accel, seen, gap * seen, rel_x * seen, rel_y * seen, rel_vx * seen,
                rel_vy * seen, np.where(seen, ttc, f32(TTC_NONE)), friction]
        low, high = _OBS_BOUNDS
    if cfg.threat_features:
        threat = threat_entries(p, dims, cfg.ego, gap).astype(np.float32)
        if not cfg.privileged:  # what the sensor does not see: 0, TTC_NONE
            hidden = ~seen.astype(bool)
            threat[hidden, 1:4] = 0.0
            threat[hidden, 4] = TTC_NONE
        cols += list(threat.T)
        low, high = np.concatenate([low, _THREAT_BOUNDS[0]]), \
            np.concatenate([high, _THREAT_BOUNDS[1]])
    out = np.stack(cols, axis=1, dtype=np.float32)
    np.clip(out, low, high, out=out)
    if not np.isfinite(out).all():
        out = np.nan_to_num(out, nan=0.0)
    return out


__all__ = [
    "OBSERVATION_HIGH", "OBSERVATION_LOW", "OBSERVATION_NAMES", "OBSERVATION_UNITS",
    "PRIVILEGED_HIGH", "PRIVILEGED_LOW", "PRIVILEGED_NAMES", "THREAT_HIGH", "THREAT_LOW",
    "THREAT_NAMES", "THREAT_UNITS", "TTC_NONE", "Dimensions", "miss_distance_cv", "observe",
    "observe_reference", "threat_entries",
]
