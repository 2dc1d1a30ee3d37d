"""Pre-crash contact along recorded paths: the replay's kinematics at any time and the
outline contact tests of :class:`vfs.physics.precrash.PrecrashRun`.

Speed and position are reductions dv, ds (n, 2) [m/s, m] against the record
(:mod:`vfs.physics.precrash`); :func:`kinematics_at` gives both vehicles'
state at any time from them.  The contact tests: :func:`overlapping`
(separating-axis broad phase, then the clipped overlap area), the first
contact between a free and an overlapping step by bisection
(:func:`bisect_contact`) and the largest overlap of a grazing contact
(:func:`largest_overlap`).  Arrays of both vehicles are (n, 2): vehicle 1 in
column 0.
"""

from __future__ import annotations

import numpy as np

from vfs.physics.geometry import AREA_TOLERANCE, outlines_may_overlap, overlap, vehicle_outline
from vfs.physics.paths import (
    PathArrays,
    advance_index,
    find_index,
    pose_at_arclength,
    record_at_time,
)
from vfs.physics.precrash_result import KinematicState
from vfs.physics.vehicle import VehicleArrays


def record_pair(paths: PathArrays, rows: np.ndarray, tau: float | np.ndarray,
            t_index: np.ndarray | None, hint: bool = False,
            active: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, ...]:
    """Recorded s, speed, acceleration (n, 2) at time(s) ``tau`` and the time indices.

    ``paths`` holds participant 1's paths followed by participant 2's (see
    :func:`vfs.physics.paths.concat_paths`); both are looked up in one call.  With
    ``t_index`` (monotone stepping) the indices are advanced, without it
    (bisection, arbitrary times) found by binary search.
    """
    n = rows.shape[0]
    both, last = active if active is not None else active_rows(paths, rows)
    tau2 = np.broadcast_to(np.asarray(tau, float), (n,))
    tau2 = np.concatenate([tau2, tau2])
    if t_index is None:
        ti = find_index(paths, "t", tau2, both)
    else:
        ti = advance_index(paths, "t", t_index.T.reshape(-1), tau2, both)
    rec = record_at_time(paths, both, ti, tau2, last, rows_last=True)
    pair = lambda a: a.reshape(2, n).T  # noqa: E731
    return pair(rec.s), pair(rec.speed), pair(rec.accel), pair(ti)


def active_rows(paths: PathArrays, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Path rows of both participants of cases ``rows`` and their last knots."""
    both = np.concatenate([rows, rows + paths.size // 2])
    return both, paths.knots[paths.count[both] - 1, both]


def state_at_arclength(paths: PathArrays, rows: np.ndarray, s: np.ndarray,
           speed: np.ndarray, s_index: np.ndarray | None,
           active: tuple[np.ndarray, np.ndarray] | None = None,
           ) -> tuple[KinematicState, np.ndarray]:
    """Kinematic state of both vehicles at arc lengths ``s`` moving at ``speed`` (n, 2)."""
    n = rows.shape[0]
    both, last = active if active is not None else active_rows(paths, rows)
    s2 = s.T.reshape(-1)
    if s_index is None:
        si = find_index(paths, "s", s2, both)
    else:
        si = advance_index(paths, "s", s_index.T.reshape(-1), s2, both)
    pose = pose_at_arclength(paths, both, si, s2, last, rows_last=True)
    pair = lambda a: a.reshape(2, n).T  # noqa: E731
    state = KinematicState(
        x=pair(pose.x), y=pair(pose.y), yaw=pair(pose.yaw),
        vx=speed * pair(pose.tx), vy=speed * pair(pose.ty),
        yaw_rate=speed * pair(pose.curvature), speed=speed,
    )
    return state, pair(si)


def kinematics_at(paths: PathArrays, rows: np.ndarray, tau: float | np.ndarray,
                dv: np.ndarray, ds: np.ndarray,
                hint: tuple[np.ndarray, np.ndarray] | None = None) -> KinematicState:
    """State at arbitrary time(s) ``tau`` given the reductions dv, ds (n, 2).

    ``hint`` = (time index, arc-length index) (n, 2) at an earlier time lets
    the look-up advance from there instead of searching.
    """
    t_hint, s_hint = hint if hint is not None else (None, None)
    s_rec, v_rec, _, _ = record_pair(paths, rows, tau, t_hint)
    return state_at_arclength(paths, rows, s_rec - ds, np.maximum(v_rec - dv, 0.0), s_hint)[0]


def outlines(v1: VehicleArrays, v2: VehicleArrays, rows: np.ndarray,
              st: KinematicState) -> tuple[np.ndarray, np.ndarray]:
    """Outline corners (n, 4, 2) [m] of both vehicles of cases ``rows`` in state ``st``."""
    o1 = vehicle_outline(v1.take(rows), st.x[:, 0], st.y[:, 0], st.yaw[:, 0])
    o2 = vehicle_outline(v2.take(rows), st.x[:, 1], st.y[:, 1], st.yaw[:, 1])
    return o1, o2


def overlap_area(v1: VehicleArrays, v2: VehicleArrays, rows: np.ndarray,
                  st: KinematicState) -> np.ndarray:
    """Overlap area of the outlines [m^2]."""
    o1, o2 = outlines(v1, v2, rows, st)
    return overlap(o1, o2).area


#: Outlines farther apart than twice this [m] (by a separating axis) skip the clipping in
#: the contact test: their overlap is empty, so the decision is the same.
SEPARATION_MARGIN = 1e-6


def overlapping(v1: VehicleArrays, v2: VehicleArrays, rows: np.ndarray,
                 st: KinematicState) -> np.ndarray:
    """True where the outlines overlap with positive area (> :data:`AREA_TOLERANCE`).

    The separating-axis test (:func:`outlines_may_overlap`) settles the pairs
    that are certainly apart; only the others are clipped (:func:`overlap`).
    """
    o1, o2 = outlines(v1, v2, rows, st)
    out = np.zeros(rows.shape[0], dtype=bool)
    maybe = outlines_may_overlap(o1, o2, SEPARATION_MARGIN)
    if maybe.all():
        return overlap(o1, o2).area > AREA_TOLERANCE
    if maybe.any():
        out[maybe] = overlap(o1[maybe], o2[maybe]).area > AREA_TOLERANCE
    return out


#: Samples of the penetration window searched for the largest overlap of a graze.
GRAZE_SAMPLES = 16


def largest_overlap(paths: PathArrays, v1: VehicleArrays, v2: VehicleArrays,
                     rows: np.ndarray, t_contact: np.ndarray, t_impact: np.ndarray,
                     dv: np.ndarray, ds: np.ndarray) -> tuple[np.ndarray, KinematicState]:
    """Time of the largest overlap within [t_contact, t_impact] and the state then.

    Used for grazing contacts, where the outlines separate again before the
    penetration time is over.  The reductions dv, ds are held at their
    values at first contact over this short window (tens of ms).
    """
    best_t = t_contact.copy()
    best_area = np.full(rows.shape[0], -1.0)
    for frac in np.linspace(0.0, 1.0, GRAZE_SAMPLES + 1):
        tt = t_contact + frac * (t_impact - t_contact)
        a = overlap_area(v1, v2, rows, kinematics_at(paths, rows, tt, dv, ds))
        better = a > best_area
        best_t = np.where(better, tt, best_t)
        best_area = np.where(better, a, best_area)
    return best_t, kinematics_at(paths, rows, best_t, dv, ds)


def nan_state(n: int) -> KinematicState:
    """A state of n cases, all NaN (not reached)."""
    return KinematicState(*(np.full((n, 2), np.nan) for _ in KinematicState._fields))


def put_rows(dst: KinematicState, rows: np.ndarray, src: KinematicState) -> None:
    """Write ``src`` into rows ``rows`` of ``dst`` (in place)."""
    for a, b in zip(dst, src, strict=True):
        a[rows] = b


def take_rows(a: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``a[index]`` for a 1-d boolean mask or integer index of the rows (first axis) of
    ``a``: the same rows, by :func:`numpy.compress` or :func:`numpy.take` (several times
    faster than fancy indexing on arrays of more than one dimension, paid per step).
    """
    index = np.asarray(index)
    if index.ndim != 1 or a.ndim == 0:
        return a[index]
    if index.dtype == np.bool_:
        if index.shape[0] != a.shape[0]:
            return a[index]  # the IndexError of a wrong mask
        return np.compress(index, a, axis=0)
    return np.take(a, index, axis=0)


def take_state(state: KinematicState, mask: np.ndarray) -> KinematicState:
    """Rows of a state (by mask or index)."""
    return KinematicState(*(take_rows(a, mask) for a in state))


def bisect_contact(paths: PathArrays, v1: VehicleArrays, v2: VehicleArrays,
                    rows: np.ndarray, t_free: float | np.ndarray, t_hit: float | np.ndarray,
                    dv0: np.ndarray, dv1: np.ndarray, ds0: np.ndarray, ds1: np.ndarray,
                    tolerance: float,
                    hint: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """First-contact time between a free and an overlapping step, to ``tolerance`` [s].

    Within the step the reductions dv, ds are interpolated linearly (their
    error is second order in dt).  Returns the earliest time found to overlap.
    """
    lo = np.full(rows.shape[0], t_free)
    hi = np.full(rows.shape[0], t_hit)
    span = float(np.max(hi - lo))  # one step [s] (each case on its own clock)
    while span > tolerance:
        mid = 0.5 * (lo + hi)
        w = ((mid - t_free) / (t_hit - t_free))[:, None]
        st = kinematics_at(paths, rows, mid, dv0 + w * (dv1 - dv0), ds0 + w * (ds1 - ds0), hint)
        inside = overlapping(v1, v2, rows, st)
        hi = np.where(inside, mid, hi)
        lo = np.where(inside, lo, mid)
        span *= 0.5
    return hi


__all__ = ["GRAZE_SAMPLES", "SEPARATION_MARGIN", "active_rows", "bisect_contact",
           "kinematics_at", "largest_overlap", "nan_state", "outlines", "overlap_area",
           "overlapping", "put_rows", "record_pair", "state_at_arclength",
           "take_rows", "take_state"]
