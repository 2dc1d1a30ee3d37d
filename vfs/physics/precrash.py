"""Pre-crash re-simulation along recorded paths, contact detection and penetration.

Each vehicle keeps its recorded path (:mod:`vfs.physics.paths`); only its speed
profile can change.  Without intervention the replay is the record.  A
controller (AEB, scheduled braking, a gym agent) demands a deceleration; a
brake actuator builds it up (jerk-limited or first-order) and limits it to
the road friction; the brake system delivers the larger of the driver's
recorded deceleration and the demanded one (brake arbitration by maximum).

Speed and position are tracked as reductions against the record:

    v(t) = max(v_rec(t) - dv(t), 0)
    d(dv)/dt = max(0, a_rec(t) + d(t))   while the actuator brakes (d > 0), else 0
    s(t) = s_rec(t) - ds(t),   d(ds)/dt = v_rec(t) - v(t) = min(dv, v_rec)

so without braking dv = ds = 0 and the replay is exact; with braking the
vehicle follows the recorded pedal profile on top of the brake and never
drives backwards.  dv is integrated with the actuator output averaged over
the step (exact for a linear build-up), ds with the trapezoidal rule.

Contact: every step, a broad phase (CG distance against the sum of the
outlines' circumradii) selects candidate pairs; :func:`vfs.physics.geometry.overlap`
decides.  The first contact is refined by bisection to below 1 ms between
the last free step and the first overlapping one; the vehicles then move on
for the penetration time (30 ms by default, the Momentum Based Impact Model paper) and the impact
configuration (poses, velocities, yaw rates, POI and contact plane by the
geometric rules) is taken there.  A case without contact is "avoided" and
reports the minimum outline distance and the time of closest approach.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError
from vfs.physics.braking import (
    BrakeActuatorParams,
    BrakeController,
    PrecrashObservation,
    ScheduledBraking,
    actuator_step,
    friction_limited_deceleration,
)
from vfs.physics.geometry import (
    AREA_TOLERANCE,
    contact_geometry,
    outline_distance,
    outlines_may_overlap,
    overlap,
    vehicle_outline,
)
from vfs.physics.paths import (
    PathArrays,
    advance_index,
    find_index,
    pose_at_arclength,
    record_at_time,
)
from vfs.physics.precrash_result import KinematicState, PrecrashResult
from vfs.physics.vehicle import VehicleArrays

#: The braking names are re-exported from :mod:`vfs.physics.braking`, the records from
#: :mod:`vfs.physics.precrash_result`, where they live.
__all__ = [
    "CLOSE_RANGE",
    "GRAZE_SAMPLES",
    "BrakeActuatorParams",
    "BrakeController",
    "KinematicState",
    "PrecrashObservation",
    "PrecrashParams",
    "PrecrashResult",
    "PrecrashRun",
    "ScheduledBraking",
    "SegmentedRandom",
    "actuator_step",
    "friction_limited_deceleration",
    "simulate_precrash",
]

# ----------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class PrecrashParams:
    """Settings of the pre-crash simulation.

    Attributes
    ----------
    dt : float
        Time step [s], default 0.01 (the PreCrash-Matrix sampling).
    penetration_time : float
        Time the outlines move on after first contact [s], default 0.030
        (the Momentum Based Impact Model paper).
    contact_tolerance : float
        First contact is located to within this [s] by bisection; default
        0.05 ms.  1 ms would do for the contact time itself, but the impact
        configuration 30 ms later inherits the error, and sliding impacts
        amplify it (the Momentum Based Impact Model paper), so the tolerance is kept small; it costs
        only a few extra bisection steps on the colliding cases.
    extra_time : float
        How long [s] to simulate beyond the end of the longer record, so
        that delayed collisions (after braking) are still found; default 3.
    brake : BrakeActuatorParams
        Brake build-up.
    """

    dt: float = 0.01
    penetration_time: float = 0.030
    contact_tolerance: float = 0.00005
    extra_time: float = 3.0
    brake: BrakeActuatorParams = BrakeActuatorParams()

    def __post_init__(self) -> None:
        if not 1e-4 <= self.dt <= 0.1:
            raise ParameterError(f"dt={self.dt} s outside [0.0001, 0.1]")
        if not 0.0 <= self.penetration_time <= 0.5:
            raise ParameterError(f"penetration_time={self.penetration_time} s outside [0, 0.5]")
        if not 0 < self.contact_tolerance <= self.dt:
            raise ParameterError("contact_tolerance must be in (0, dt]")
        if not 0.0 <= self.extra_time <= 60.0:
            raise ParameterError(f"extra_time={self.extra_time} s outside [0, 60]")


class SegmentedRandom(NamedTuple):
    """Random streams of consecutive segments of a batch (several study chunks run as one).

    Case ``i`` of segment ``k`` (the cases ``sum(sizes[:k]) ..`` in batch
    order) draws its random numbers from ``generators[k]``, as it would in a
    run of that segment alone with that generator.  A controller takes them
    through ``reset_segments(sizes, generators)`` (e.g.
    :meth:`vfs.adas.controller.AEBController.reset_segments`); one without that
    method cannot run segmented batches (:func:`simulate_precrash` raises
    :class:`ParameterError`).

    Attributes
    ----------
    sizes : tuple of int
        Cases per segment (sum = batch size).
    generators : tuple of numpy.random.Generator
        One per segment.
    """

    sizes: tuple[int, ...]
    generators: tuple[np.random.Generator, ...]

    @classmethod
    def of(cls, sizes: Sequence[int], generators: Sequence[np.random.Generator]
           ) -> SegmentedRandom:
        """Checked construction (one generator per segment, sizes >= 1)."""
        sizes_t = tuple(int(n) for n in sizes)
        if len(sizes_t) != len(generators) or any(n < 1 for n in sizes_t):
            raise ParameterError("SegmentedRandom: one generator per segment of >= 1 case")
        return cls(sizes_t, tuple(generators))


def reset_controller(controller: BrakeController, n: int,
                     rng: np.random.Generator | SegmentedRandom | None) -> None:
    """``controller.reset(n, rng)``, or ``reset_segments`` for :class:`SegmentedRandom`."""
    if isinstance(rng, SegmentedRandom):
        if sum(rng.sizes) != n:
            raise ParameterError(f"SegmentedRandom covers {sum(rng.sizes)} cases, the "
                                 f"run has {n}")
        reset_segments = getattr(controller, "reset_segments", None)
        if not callable(reset_segments):
            raise ParameterError(f"{type(controller).__name__} cannot run segmented batches "
                                 "(no reset_segments)")
        reset_segments(rng.sizes, rng.generators)
        return
    controller.reset(n, rng if rng is not None else np.random.default_rng(0))


# ----------------------------------------------------------------------------
# Contact tracking
# ----------------------------------------------------------------------------

#: Outline distances are tracked exactly every step while the outlines may be
#: closer than this [m]; farther passes are measured at the moment of minimal
#: CG distance.
CLOSE_RANGE = 5.0


class _Track:
    """Per-vehicle integration state of the cases still running (arrays (n, 2))."""

    def __init__(self, n: int) -> None:
        self.dv = np.zeros((n, 2))  # speed reduction [m/s]
        self.ds = np.zeros((n, 2))  # arc-length reduction [m]
        self.gap = np.zeros((n, 2))  # min(dv, v_rec): rate of ds [m/s]
        self.decel = np.zeros((n, 2))  # delivered deceleration [m/s^2]
        self.t_index = np.zeros((n, 2), dtype=np.int64)
        self.s_index = np.zeros((n, 2), dtype=np.int64)
        # closest approach so far: CG distance [m], its time and the poses
        self.best_centre = np.full(n, np.inf)
        self.best_time = np.full(n, np.nan)
        self.best_x = np.full((n, 2), np.nan)
        self.best_y = np.full((n, 2), np.nan)
        self.best_yaw = np.full((n, 2), np.nan)

    FIELDS = ("dv", "ds", "gap", "decel", "t_index", "s_index", "best_centre",
              "best_time", "best_x", "best_y", "best_yaw")

    def take(self, keep: np.ndarray) -> None:
        for name in self.FIELDS:
            setattr(self, name, getattr(self, name)[keep])


def _record(paths: PathArrays, rows: np.ndarray, tau: float | np.ndarray,
            t_index: np.ndarray | None, hint: bool = False,
            active: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, ...]:
    """Recorded s, speed, acceleration (n, 2) at time(s) ``tau`` and the time indices.

    ``paths`` holds participant 1's paths followed by participant 2's (see
    :func:`vfs.physics.paths.concat_paths`); both are looked up in one call.  With
    ``t_index`` (monotone stepping) the indices are advanced, without it
    (bisection, arbitrary times) found by binary search.
    """
    n = rows.shape[0]
    both, last = active if active is not None else _active(paths, rows)
    tau2 = np.broadcast_to(np.asarray(tau, float), (n,))
    tau2 = np.concatenate([tau2, tau2])
    if t_index is None:
        ti = find_index(paths, "t", tau2, both)
    else:
        ti = advance_index(paths, "t", t_index.T.reshape(-1), tau2, both)
    rec = record_at_time(paths, both, ti, tau2, last, rows_last=True)
    pair = lambda a: a.reshape(2, n).T  # noqa: E731
    return pair(rec.s), pair(rec.speed), pair(rec.accel), pair(ti)


def _active(paths: PathArrays, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Path rows of both participants of cases ``rows`` and their last knots."""
    both = np.concatenate([rows, rows + paths.size // 2])
    return both, paths.knots[paths.count[both] - 1, both]


def _state(paths: PathArrays, rows: np.ndarray, s: np.ndarray,
           speed: np.ndarray, s_index: np.ndarray | None,
           active: tuple[np.ndarray, np.ndarray] | None = None,
           ) -> tuple[KinematicState, np.ndarray]:
    """Kinematic state of both vehicles at arc lengths ``s`` moving at ``speed`` (n, 2)."""
    n = rows.shape[0]
    both, last = active if active is not None else _active(paths, rows)
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


def _kinematics(paths: PathArrays, rows: np.ndarray, tau: float | np.ndarray,
                dv: np.ndarray, ds: np.ndarray,
                hint: tuple[np.ndarray, np.ndarray] | None = None) -> KinematicState:
    """State at arbitrary time(s) ``tau`` given the reductions dv, ds (n, 2).

    ``hint`` = (time index, arc-length index) (n, 2) at an earlier time lets
    the look-up advance from there instead of searching.
    """
    t_hint, s_hint = hint if hint is not None else (None, None)
    s_rec, v_rec, _, _ = _record(paths, rows, tau, t_hint)
    return _state(paths, rows, s_rec - ds, np.maximum(v_rec - dv, 0.0), s_hint)[0]


def _outlines(v1: VehicleArrays, v2: VehicleArrays, rows: np.ndarray,
              st: KinematicState) -> tuple[np.ndarray, np.ndarray]:
    o1 = vehicle_outline(v1.take(rows), st.x[:, 0], st.y[:, 0], st.yaw[:, 0])
    o2 = vehicle_outline(v2.take(rows), st.x[:, 1], st.y[:, 1], st.yaw[:, 1])
    return o1, o2


def _overlap_area(v1: VehicleArrays, v2: VehicleArrays, rows: np.ndarray,
                  st: KinematicState) -> np.ndarray:
    """Overlap area of the outlines [m^2]."""
    o1, o2 = _outlines(v1, v2, rows, st)
    return overlap(o1, o2).area


#: Outlines farther apart than twice this [m] (by a separating axis) skip the clipping in
#: the contact test: their overlap is empty, so the decision is the same.
SEPARATION_MARGIN = 1e-6


def _overlapping(v1: VehicleArrays, v2: VehicleArrays, rows: np.ndarray,
                 st: KinematicState) -> np.ndarray:
    """True where the outlines overlap with positive area (> :data:`AREA_TOLERANCE`).

    The separating-axis test (:func:`outlines_may_overlap`) settles the pairs
    that are certainly apart; only the others are clipped (:func:`overlap`).
    """
    o1, o2 = _outlines(v1, v2, rows, st)
    out = np.zeros(rows.shape[0], dtype=bool)
    maybe = outlines_may_overlap(o1, o2, SEPARATION_MARGIN)
    if maybe.all():
        return overlap(o1, o2).area > AREA_TOLERANCE
    if maybe.any():
        out[maybe] = overlap(o1[maybe], o2[maybe]).area > AREA_TOLERANCE
    return out


#: Samples of the penetration window searched for the largest overlap of a graze.
GRAZE_SAMPLES = 16


def _largest_overlap(paths: PathArrays, v1: VehicleArrays, v2: VehicleArrays,
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
        a = _overlap_area(v1, v2, rows, _kinematics(paths, rows, tt, dv, ds))
        better = a > best_area
        best_t = np.where(better, tt, best_t)
        best_area = np.where(better, a, best_area)
    return best_t, _kinematics(paths, rows, best_t, dv, ds)


def _nan_state(n: int) -> KinematicState:
    return KinematicState(*(np.full((n, 2), np.nan) for _ in KinematicState._fields))


def _put(dst: KinematicState, rows: np.ndarray, src: KinematicState) -> None:
    for a, b in zip(dst, src, strict=True):
        a[rows] = b


# ----------------------------------------------------------------------------
# The simulation
# ----------------------------------------------------------------------------


def simulate_precrash(
    vehicle1: VehicleArrays, vehicle2: VehicleArrays,
    paths: PathArrays, road_friction: npt.ArrayLike,
    controller: BrakeController | None = None, params: PrecrashParams | None = None,
    rng: np.random.Generator | SegmentedRandom | None = None,
    penetration: Callable[[np.ndarray, KinematicState], np.ndarray] | None = None,
) -> PrecrashResult:
    """Re-simulate N cases from the start of their records to impact or the horizon.

    Parameters
    ----------
    vehicle1, vehicle2 : VehicleArrays
        Vehicles of the N cases.
    paths : PathArrays
        Recorded paths of the 2N participants: participant 1 of every case,
        then participant 2 (:func:`vfs.physics.paths.concat_paths`); times relative
        to each record's start, and both records of a case must start at the
        same absolute time.
    road_friction : array_like (N,)
        Tyre-road friction coefficient; the brake deceleration is limited
        to road_friction * g.
    controller : BrakeController, optional
        Brake demand; None replays the record.
    params : PrecrashParams, optional
    rng : numpy.random.Generator or SegmentedRandom, optional
        Passed to ``controller.reset`` (sensor noise, reaction times);
        a :class:`SegmentedRandom` to ``controller.reset_segments``.
    penetration : callable, optional
        ``penetration(rows, contact_state) -> seconds``: penetration time per
        case [s], in [0, 0.5], called once at first contact with the case
        indices and their :class:`KinematicState` there (e.g. a penetration
        depth effect, :mod:`vfs.effects`); default ``params.penetration_time``.

    Returns
    -------
    PrecrashResult

    Notes
    -----
    A loop over :class:`PrecrashRun`: observe, ask the controller, advance.
    The gym environments (:mod:`vfs.gym.env`) drive the same class step by
    step with the agent in place of the controller.
    """
    run = PrecrashRun(vehicle1, vehicle2, paths, road_friction, params=params,
                      penetration=penetration)
    if controller is not None:
        reset_controller(controller, run.n, rng)
    while not run.done:
        demand = controller.demand(run.observation()) if controller is not None else None
        run.advance(demand)
    return run.result()


class PrecrashRun:
    """The pre-crash simulation of N cases, advanced one time step at a time.

    :func:`simulate_precrash` runs it to the end with a controller; a gym
    environment steps it with an agent's demand.  Every case ("row") runs on
    its own clock: the time since the start of its record is (k - k0) dt,
    with k the run's step counter and k0 the step at which the case
    started; :func:`simulate_precrash` starts every case at k = 0.  With
    ``open_ended=True`` the run never ends by itself and finished cases can
    be started again (:meth:`advance` with ``start=``), which is how a
    vector environment resets its sub-environments.

    Parameters
    ----------
    vehicle1, vehicle2, paths, road_friction, params, penetration
        As for :func:`simulate_precrash`.
    start : array_like of int, optional
        Cases running from step 0 (default: all).
    open_ended : bool
        Keep the run going when no case is left (default False).
    case_of : array_like of int, optional
        Run case instances: row i simulates case ``case_of[i]`` of the
        vehicles and paths (several rows may share a case; results are per
        row); default one row per case.  The ``penetration`` callback gets
        these case indices.

    Attributes
    ----------
    rows : ndarray of int
        Cases still running, in the order of the observation's arrays.
    finished : ndarray of int
        Cases that ended (impact reached or horizon expired) at the last
        step; their results are final after :meth:`finalize`.
    """

    state: KinematicState
    v_rec: np.ndarray
    a_rec: np.ndarray

    def __init__(self, vehicle1: VehicleArrays, vehicle2: VehicleArrays, paths: PathArrays,
                 road_friction: npt.ArrayLike, params: PrecrashParams | None = None,
                 penetration: Callable[[np.ndarray, KinematicState], np.ndarray] | None = None,
                 start: npt.ArrayLike | None = None, open_ended: bool = False,
                 case_of: npt.ArrayLike | None = None) -> None:
        params = params or PrecrashParams()
        n_data = vehicle1.size
        if paths.size != 2 * n_data:
            raise ParameterError(f"paths hold {paths.size} records for {n_data} cases "
                                 "(need 2 per case)")
        self.case_of = None if case_of is None else np.asarray(case_of, np.int64).reshape(-1)
        if self.case_of is not None and self.case_of.size and (
                self.case_of.min() < 0 or self.case_of.max() >= n_data):
            raise ParameterError(f"case_of indices outside 0..{n_data - 1}")
        n = n_data if self.case_of is None else self.case_of.size
        self.n = n
        self.params = params
        self.dt = params.dt
        self.v1, self.v2, self.paths = vehicle1, vehicle2, paths
        self.penetration = penetration
        self.open_ended = bool(open_ended)
        mu = np.broadcast_to(np.asarray(road_friction, float), (n_data,))
        self.mu = mu[self._d(np.arange(n))].copy()
        self.limit = friction_limited_deceleration(self.mu, params.brake.max_deceleration)[:, None]
        self.reach = (vehicle1.corner_radius + vehicle2.corner_radius)[self._d(np.arange(n))]
        # per case: its longer record + extra_time (so a case's result never depends
        # on the other cases of the batch)
        duration = paths.duration
        self.case_horizon = (np.maximum(duration[:n_data], duration[n_data:])
                             + params.extra_time)[self._d(np.arange(n))]
        self.horizon = float(np.max(self.case_horizon)) if n else 0.0
        self.k = 0
        self.k0 = np.zeros(n, dtype=np.int64)

        self.collided = np.zeros(n, dtype=bool)
        self.contact_time = np.full(n, np.nan)
        self.min_distance = np.full(n, np.inf)
        self.time_closest = np.full(n, np.nan)
        self.brake_start = np.full((n, 2), np.nan)
        self.speed_reduction = np.zeros((n, 2))
        self.impact_state = _nan_state(n)
        self.contact_state = _nan_state(n)
        self.end_state = _nan_state(n)
        self.contact_dv = np.zeros((n, 2))  # reductions at first contact
        self.contact_ds = np.zeros((n, 2))
        # per case, the integration state at impact time is interpolated between
        # the two steps around it; remember the reductions at both
        self.pending = np.zeros(n, dtype=bool)  # in contact, waiting for impact time
        self.impact_time = np.full(n, np.nan)
        self.best_time = np.full(n, np.nan)  # time of the smallest CG distance
        self.best_pose = np.full((3, n, 2), np.nan)  # x, y, yaw of both at that moment
        self.poi = np.full((n, 2), np.nan)
        self.cp_angle = np.full(n, np.nan)
        self.cp_rule = np.zeros(n, dtype=np.int64)
        self.area = np.zeros(n)
        self.final = np.zeros(n, dtype=bool)  # post-processed by finalize
        self.running = np.zeros(n, dtype=bool)

        rows = np.arange(n) if start is None else np.unique(np.asarray(start, np.int64))
        self.rows = rows
        self.running[rows] = True
        self.track = _Track(rows.shape[0])
        self.active: tuple[np.ndarray, np.ndarray] | None = None
        self._save_previous()
        self.finished = np.zeros(0, dtype=np.int64)
        self.done = False
        self._settle()

    # ------------------------------------------------------------------ clocks

    def _d(self, rows: np.ndarray) -> np.ndarray:
        """Data rows (vehicles, paths) of case instances ``rows``."""
        return rows if self.case_of is None else self.case_of[rows]

    @property
    def time(self) -> float:
        """Time of the run's current step k dt [s] (a case's own time when all started at 0)."""
        return self.k * self.dt

    def local_time(self, rows: np.ndarray | None = None) -> np.ndarray:
        """Time since the start of their records [s] of cases ``rows`` (default: running)."""
        rows = self.rows if rows is None else rows
        return (self.k - self.k0[rows]) * self.dt

    @property
    def common_clock(self) -> bool:
        """All running cases started at the same step (their times are equal)."""
        k0 = self.k0[self.rows]
        return bool(k0.size == 0 or (k0 == k0[0]).all())

    def _observed_time(self, rows: np.ndarray) -> float | np.ndarray:
        k0 = self.k0[rows]
        if k0.size == 0 or (k0 == k0[0]).all():
            return (self.k - int(k0[0])) * self.dt if k0.size else self.time
        return (self.k - k0) * self.dt

    def _save_previous(self) -> None:
        t = self.track
        self.prev_dv, self.prev_ds = t.dv.copy(), t.ds.copy()
        self.prev_ti, self.prev_si = t.t_index.copy(), t.s_index.copy()

    def _keep(self, keep: np.ndarray) -> None:
        """Drop the running rows where ``keep`` is False."""
        self.rows = self.rows[keep]
        self.state = _take_state(self.state, keep)
        self.v_rec, self.a_rec = self.v_rec[keep], self.a_rec[keep]
        self.track.take(keep)
        self.prev_dv, self.prev_ds = self.prev_dv[keep], self.prev_ds[keep]
        self.prev_ti, self.prev_si = self.prev_ti[keep], self.prev_si[keep]
        self.active = None

    # ------------------------------------------------------------------ one step

    def _settle(self) -> None:
        """Kinematics at the current step; impacts due, contacts, closest approach, ends."""
        params, dt, paths = self.params, self.dt, self.paths
        v1, v2 = self.v1, self.v2
        track = self.track
        rows = self.rows
        ended: list[np.ndarray] = []
        kk = self.k - self.k0[rows]  # steps since each case's start
        tau = kk * dt
        if self.active is None or self.active[0].shape[0] != 2 * rows.shape[0]:
            self.active = _active(paths, self._d(rows))
        s_rec, v_rec, a_rec, track.t_index = _record(paths, rows, tau, track.t_index,
                                                     active=self.active)
        gap_now = np.minimum(track.dv, v_rec)
        stepped = (kk > 0)[:, None]
        track.ds = np.where(stepped, track.ds + 0.5 * dt * (track.gap + gap_now), track.ds)
        track.gap = gap_now
        self.state, track.s_index = _state(paths, rows, s_rec - track.ds,
                                           np.maximum(v_rec - track.dv, 0.0), track.s_index,
                                           active=self.active)
        self.v_rec, self.a_rec = v_rec, a_rec
        prev_tau = (kk - 1) * dt

        # ---- impact time reached for cases in penetration
        pending, impact_time = self.pending, self.impact_time
        due = pending[rows] & (impact_time[rows] <= tau + 1e-12)
        if due.any():
            r = rows[due]
            w = np.clip((impact_time[r] - prev_tau[due]) / dt, 0.0, 1.0)[:, None]
            dv_i = self.prev_dv[due] + w * (track.dv[due] - self.prev_dv[due])
            ds_i = self.prev_ds[due] + w * (track.ds[due] - self.prev_ds[due])
            st_i = _kinematics(paths, self._d(r), impact_time[r], dv_i, ds_i)
            _put(self.impact_state, r, st_i)
            pending[r] = False
            self.speed_reduction[r] = dv_i
            ended.append(r)
            keep = ~due
            self._keep(keep)
            rows, tau, prev_tau, kk = self.rows, tau[keep], prev_tau[keep], kk[keep]

        # ---- contact detection for cases not yet in contact
        state = self.state
        free = ~pending[rows]
        centre = np.hypot(state.x[:, 0] - state.x[:, 1], state.y[:, 0] - state.y[:, 1])
        lower = centre - self.reach[rows]
        near = free & (lower <= 0.0)
        touching = np.zeros(rows.shape[0], dtype=bool)
        if near.any():
            touching[near] = _overlapping(v1, v2, self._d(rows[near]),
                                          _take_state(state, near))
        new_contact = touching
        if new_contact.any():
            r = rows[new_contact]
            first = kk[new_contact] == 0  # overlapping from the start of the record
            t_c = np.zeros(r.shape[0])
            later = ~first
            if later.any():
                sel = np.flatnonzero(new_contact)[later]
                t_c[later] = _bisect_contact(
                    paths, v1, v2, self._d(rows[sel]), prev_tau[sel], tau[sel],
                    self.prev_dv[sel], track.dv[sel], self.prev_ds[sel], track.ds[sel],
                    params.contact_tolerance, (self.prev_ti[sel], self.prev_si[sel]))
            self.collided[r] = True
            self.contact_time[r] = t_c
            pending[r] = True
            self.min_distance[r] = 0.0
            self.time_closest[r] = t_c
            w = np.where(first, 0.0, np.clip((t_c - prev_tau[new_contact]) / dt, 0.0,
                                             1.0))[:, None]
            dv_c = self.prev_dv[new_contact] + w * (track.dv[new_contact]
                                                    - self.prev_dv[new_contact])
            ds_c = self.prev_ds[new_contact] + w * (track.ds[new_contact]
                                                    - self.prev_ds[new_contact])
            st_c = _kinematics(paths, self._d(r), t_c, dv_c, ds_c)
            _put(self.contact_state, r, st_c)
            self.contact_dv[r], self.contact_ds[r] = dv_c, ds_c
            t_pen = np.full(r.shape[0], params.penetration_time)
            if self.penetration is not None:
                t_pen = np.asarray(self.penetration(self._d(r), st_c), float)
                if t_pen.shape != r.shape or not np.all((t_pen >= 0.0) & (t_pen <= 0.5)):
                    raise ParameterError("penetration times must be (n,) values in [0, 0.5] s")
            impact_time[r] = t_c + t_pen
            instant = t_pen == 0.0
            if instant.any():
                ri = r[instant]
                _put(self.impact_state, ri, _take_state(self.contact_state, ri))
                pending[ri] = False
                self.speed_reduction[ri] = dv_c[instant]
        # closest approach: exact outline distance while the outlines are
        # within CLOSE_RANGE; beyond it, the pose of minimal CG distance is
        # kept and measured at the end
        closer = free & (centre < track.best_centre)
        track.best_centre = np.where(closer, centre, track.best_centre)
        track.best_time = np.where(closer, tau, track.best_time)
        c2 = closer[:, None]
        track.best_x = np.where(c2, state.x, track.best_x)
        track.best_y = np.where(c2, state.y, track.best_y)
        track.best_yaw = np.where(c2, state.yaw, track.best_yaw)
        cand = closer & ~touching & (lower < np.minimum(self.min_distance[rows], CLOSE_RANGE))
        if cand.any():
            sub = _take_state(state, cand)
            o1, o2 = _outlines(v1, v2, self._d(rows[cand]), sub)
            dist = outline_distance(o1, o2)
            r = rows[cand]
            better = dist < self.min_distance[r]
            self.min_distance[r[better]] = dist[better]
            self.time_closest[r[better]] = tau[cand][better]

        # drop cases that are finished: impacted with zero penetration time
        done = ~pending[rows] & self.collided[rows]
        if done.any():
            ended.append(rows[done])
            keep = ~done
            self._keep(keep)
            rows, tau = self.rows, tau[keep]
        expired = ~pending[rows] & (tau >= self.case_horizon[rows] - 1e-9)
        if expired.any():
            r = rows[expired]
            self._close(r, expired)
            ended.append(r)
            self._keep(~expired)
            rows = self.rows
        if not self.open_ended and (rows.size == 0 or self.time >= self.horizon):
            self._close(rows, np.ones(rows.shape[0], dtype=bool))
            ended.append(rows)
            self.done = True
        self.finished = np.concatenate(ended) if ended else np.zeros(0, dtype=np.int64)
        self.running[self.finished] = False

    def _close(self, r: np.ndarray, sel: np.ndarray) -> None:
        """End rows ``r`` (= running rows ``sel``) without a collision at the current step."""
        track = self.track
        _put(self.end_state, r, _take_state(self.state, sel))
        self.speed_reduction[r] = track.dv[sel]
        self.best_time[r] = track.best_time[sel]
        self.best_pose[0, r], self.best_pose[1, r] = track.best_x[sel], track.best_y[sel]
        self.best_pose[2, r] = track.best_yaw[sel]

    def observation(self) -> PrecrashObservation:
        """What a controller sees now, for the running cases :attr:`rows`.

        ``t`` is the time since the start of the records [s]: a float while
        every running case started at the same step (as in
        :func:`simulate_precrash`, or one case at a time), else an array (n,)
        of each case's own time.
        """
        state, track = self.state, self.track
        rows = self.rows
        return PrecrashObservation(
            rows=rows, t=self._observed_time(rows),
            x=state.x, y=state.y, yaw=state.yaw,
            heading=np.arctan2(state.vy, state.vx), speed=state.speed,
            accel=np.where(track.decel > 0, -np.maximum(track.decel, -self.a_rec), self.a_rec),
            yaw_rate=state.yaw_rate, deceleration=track.decel, road_friction=self.mu[rows],
            vx=state.vx, vy=state.vy,
        )

    def advance(self, demand: npt.ArrayLike | None = None,
                start: npt.ArrayLike | None = None) -> None:
        """Apply ``demand`` over one step, then settle the next step.

        Parameters
        ----------
        demand : array_like (n, 2), optional
            Demanded deceleration [m/s^2] of the running cases (:attr:`rows`
            order) over the coming step; None keeps the actuator's output.
        start : array_like of int, optional
            Cases (not running) that start from the beginning of their
            records at the new step; their earlier results are discarded.
        """
        if self.done:
            raise ParameterError("the pre-crash run has ended")
        dt, track, rows = self.dt, self.track, self.rows
        self._save_previous()
        if demand is not None:
            demand = np.asarray(demand, float)
            new_decel = actuator_step(track.decel, demand, self.limit[rows], self.params.brake,
                                      dt)
        else:
            new_decel = track.decel
        mean_decel = 0.5 * (track.decel + new_decel)
        braking = mean_decel > 0
        track.dv = track.dv + dt * np.where(braking, np.maximum(0.0, self.a_rec + mean_decel),
                                            0.0)
        started = (new_decel > 0) & np.isnan(self.brake_start[rows])
        if started.any():
            ri, ci = np.nonzero(started)
            self.brake_start[rows[ri], ci] = self.local_time(rows)[ri]
        track.decel = new_decel
        self.k += 1
        if start is not None:
            self._start(np.asarray(start, np.int64).reshape(-1))
        self._settle()

    def start(self, new: npt.ArrayLike) -> None:
        """Start cases ``new`` (not running) at the current step, without advancing the
        running ones: they begin at their own time 0 now (an environment's same-step
        reset), with the same numbers as a start through :meth:`advance`.
        """
        new = np.asarray(new, np.int64).reshape(-1)
        if new.size == 0:
            return
        if self.done or not self.open_ended:
            raise ParameterError("start() needs an open-ended run that has not ended")
        finished = self.finished
        # set the running rows aside, settle the new ones alone, then put both together
        # (running rows first, as advance(start=...) orders them)
        rows, state, v_rec, a_rec = self.rows, self.state, self.v_rec, self.a_rec
        saved = {name: getattr(self.track, name) for name in _Track.FIELDS}
        prev = (self.prev_dv, self.prev_ds, self.prev_ti, self.prev_si)
        self._keep(np.zeros(rows.shape[0], dtype=bool))
        self._start(new)
        self._settle()
        for name in _Track.FIELDS:
            setattr(self.track, name, np.concatenate([saved[name], getattr(self.track, name)]))
        self.prev_dv, self.prev_ds, self.prev_ti, self.prev_si = (
            np.concatenate([old, cur]) for old, cur in zip(
                prev, (self.prev_dv, self.prev_ds, self.prev_ti, self.prev_si), strict=True))
        self.rows = np.concatenate([rows, self.rows])
        self.v_rec = np.concatenate([v_rec, self.v_rec])
        self.a_rec = np.concatenate([a_rec, self.a_rec])
        self.state = KinematicState(*(np.concatenate([a, b]) for a, b in
                                      zip(state, self.state, strict=True)))
        self.active = None
        self.finished = np.concatenate([finished, self.finished])

    def _start(self, new: np.ndarray) -> None:
        """(Re)start cases ``new`` at the current step with fresh results."""
        if new.size == 0:
            return
        if np.unique(new).size != new.size or self.running[new].any():
            raise ParameterError("cases to start must be distinct and not running")
        self.k0[new] = self.k
        for arr, value in ((self.collided, False), (self.contact_time, np.nan),
                           (self.min_distance, np.inf), (self.time_closest, np.nan),
                           (self.brake_start, np.nan), (self.speed_reduction, 0.0),
                           (self.contact_dv, 0.0), (self.contact_ds, 0.0),
                           (self.pending, False), (self.impact_time, np.nan),
                           (self.best_time, np.nan), (self.poi, np.nan),
                           (self.cp_angle, np.nan), (self.cp_rule, 0), (self.area, 0.0),
                           (self.final, False)):
            arr[new] = value
        self.best_pose[:, new] = np.nan
        for st in (self.impact_state, self.contact_state, self.end_state):
            _put(st, new, _nan_state(new.size))
        m = new.size
        fresh = _Track(m)
        track = self.track
        for name in _Track.FIELDS:
            setattr(track, name, np.concatenate([getattr(track, name), getattr(fresh, name)]))
        for name in ("prev_dv", "prev_ds", "prev_ti", "prev_si"):
            old = getattr(self, name)
            setattr(self, name, np.concatenate([old, np.zeros((m, 2), old.dtype)]))
        self.rows = np.concatenate([self.rows, new])
        # placeholders; _settle computes them for every running row
        self.v_rec = np.concatenate([self.v_rec, np.zeros((m, 2))])
        self.a_rec = np.concatenate([self.a_rec, np.zeros((m, 2))])
        self.state = KinematicState(*(np.concatenate([a, np.zeros((m, 2))])
                                      for a in self.state))
        self.running[new] = True
        self.active = None

    def stop(self, rows: npt.ArrayLike, keep_state: bool = False) -> None:
        """Stop running cases ``rows`` now.

        With ``keep_state`` they end as if their horizon had expired (no
        collision; end state, closest approach and :meth:`finalize` as
        usual), e.g. when an environment ends an episode at standstill;
        without, their results are left incomplete (an abandoned episode).
        """
        rows = np.asarray(rows, np.int64).reshape(-1)
        if rows.size == 0:
            return
        sel = np.isin(self.rows, rows)
        if int(sel.sum()) != np.unique(rows).size:
            raise ParameterError("stop: some cases are not running")
        if keep_state:
            self._close(self.rows[sel], sel)
        self._keep(~sel)
        self.running[rows] = False
        if keep_state:
            self.finalize(rows)

    # ------------------------------------------------------------------ results

    def finalize(self, rows: npt.ArrayLike | None = None) -> None:
        """Post-process ended cases ``rows`` (default: all ended, not yet finalized).

        Outline distance of far passes, grazing contacts (impact moved to the
        largest overlap) and the contact geometry (POI, contact plane) at
        impact.
        """
        if rows is None:
            sel = np.flatnonzero(~self.final & ~self.running)
        else:
            sel = np.asarray(rows, np.int64).reshape(-1)
            sel = sel[~self.final[sel]]
        if sel.size == 0:
            return
        v1, v2, paths = self.v1, self.v2, self.paths
        # never within CLOSE_RANGE: outline distance at the moment of minimal CG distance
        far = np.isinf(self.min_distance[sel]) & ~np.isnan(self.best_time[sel])
        if far.any():
            r = sel[far]
            bp = self.best_pose[:, r]
            o1 = vehicle_outline(v1.take(self._d(r)), bp[0, :, 0], bp[1, :, 0], bp[2, :, 0])
            o2 = vehicle_outline(v2.take(self._d(r)), bp[0, :, 1], bp[1, :, 1], bp[2, :, 1])
            self.min_distance[r] = outline_distance(o1, o2)
            self.time_closest[r] = self.best_time[r]
        hit = self.collided[sel] & ~np.isnan(self.impact_state.x[sel, 0])
        self.collided[sel] = hit
        if hit.any():
            r = sel[hit]
            graze = _overlap_area(v1, v2, self._d(r), _take_state(self.impact_state, r)) \
                <= AREA_TOLERANCE
            if graze.any():
                # grazing contact: the outlines separated again within the
                # penetration time; take the impact at the largest overlap
                g_rows = r[graze]
                t_best, st_best = _largest_overlap(paths, v1, v2, self._d(g_rows),
                                                   self.contact_time[g_rows],
                                                   self.impact_time[g_rows],
                                                   self.contact_dv[g_rows],
                                                   self.contact_ds[g_rows])
                self.impact_time[g_rows] = t_best
                _put(self.impact_state, g_rows, st_best)
            st = _take_state(self.impact_state, r)
            o1, o2 = _outlines(v1, v2, self._d(r), st)
            cg1 = np.stack([st.x[:, 0], st.y[:, 0]], axis=1)
            cg2 = np.stack([st.x[:, 1], st.y[:, 1]], axis=1)
            g = contact_geometry(o1, o2, cg1, cg2)
            self.poi[r], self.cp_angle[r], self.cp_rule[r], self.area[r] = \
                g.poi, g.cp_angle, g.rule, g.area
        self.final[sel] = True

    def result(self, rows: npt.ArrayLike | None = None) -> PrecrashResult:
        """The :class:`PrecrashResult` of all cases (default) or of the ended ``rows``.

        Finalizes what is not yet; a case still running has NaN results.
        """
        self.finalize(None if rows is None else rows)
        idx = slice(None) if rows is None else np.asarray(rows, np.int64).reshape(-1)
        hit = self.collided[idx]
        min_distance = self.min_distance[idx]
        take = lambda st: KinematicState(*(a[idx] for a in st))  # noqa: E731
        return PrecrashResult(
            collided=hit, contact_time=np.where(hit, self.contact_time[idx], np.nan),
            impact_time=np.where(hit, self.impact_time[idx], np.nan),
            impact_state=take(self.impact_state), contact_state=take(self.contact_state),
            poi=self.poi[idx], cp_angle=self.cp_angle[idx], cp_rule=self.cp_rule[idx],
            overlap_area=self.area[idx],
            min_distance=np.where(np.isinf(min_distance), np.nan, min_distance),
            time_closest=self.time_closest[idx], brake_start=self.brake_start[idx],
            speed_reduction=self.speed_reduction[idx], end_state=take(self.end_state),
            end_time=self.time,
        )


def _take_state(state: KinematicState, mask: np.ndarray) -> KinematicState:
    """Rows of a state (by mask or index)."""
    return KinematicState(*(a[mask] for a in state))


def _bisect_contact(paths: PathArrays, v1: VehicleArrays, v2: VehicleArrays,
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
        st = _kinematics(paths, rows, mid, dv0 + w * (dv1 - dv0), ds0 + w * (ds1 - ds0), hint)
        inside = _overlapping(v1, v2, rows, st)
        hi = np.where(inside, mid, hi)
        lo = np.where(inside, lo, mid)
        span *= 0.5
    return hi
