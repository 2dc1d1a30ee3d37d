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
from vfs.physics import core
from vfs.physics.braking import (
    BrakeActuatorParams,
    BrakeController,
    PrecrashObservation,
    ScheduledBraking,
    actuator_step,
    friction_limited_deceleration,
)
from vfs.physics.geometry import (
    outline_distance,
)
from vfs.physics.paths import PathArrays
from vfs.physics.precrash_cases import PrecrashCases
from vfs.physics.precrash_contact import (
    GRAZE_SAMPLES,
    active_rows,
    bisect_contact,
    kinematics_at,
    outlines,
    overlapping,
    put_rows,
    record_pair,
    state_at_arclength,
    take_rows,
    take_state,
)
from vfs.physics.precrash_result import KinematicState, PrecrashResult
from vfs.physics.vehicle import VehicleArrays
from vfs.settings import Rule, setting, validate

#: The braking names are re-exported from :mod:`vfs.physics.braking`, the records from
#: :mod:`vfs.physics.precrash_result`, where they live.
__all__ = [
    "CLOSE_RANGE",
    "GRAZE_SAMPLES",
    "UNUSED_VEHICLE_FIELDS",
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

#: Vehicle data the pre-crash phase never reads (:class:`~vfs.physics.vehicle.VehicleArrays`
#: fields): the cars follow their records or brake along them, so the yaw inertia acts first
#: at the impact.  A model that changes only these runs the same pre-crash phase
#: (tests/physics/test_precrash.py checks it bit for bit).
UNUSED_VEHICLE_FIELDS: tuple[str, ...] = ("yaw_inertia",)

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

    dt: float = setting(0.01, "time", "time step of the pre-crash simulation",
                        lo=1e-4, hi=0.1)
    penetration_time: float = setting(0.030, "time", "time the outlines move on after first "
                                      "contact (the impact configuration)", lo=0.0, hi=0.5)
    contact_tolerance: float = setting(0.00005, "time", "first contact is located to within "
                                       "this by bisection; <= dt", lo=0.0, lo_open=True,
                                       hi=0.1)
    extra_time: float = setting(3.0, "time", "simulated beyond the end of the longer record "
                                "(collisions delayed by braking)", lo=0.0, hi=60.0)
    brake: BrakeActuatorParams = BrakeActuatorParams()

    #: Rules between the settings.
    RULES = (Rule(("contact_tolerance", "dt"), lambda p: p.contact_tolerance <= p.dt,
                  "contact_tolerance <= dt"),)

    def __post_init__(self) -> None:
        validate(self)


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
            setattr(self, name, take_rows(getattr(self, name), keep))


# ----------------------------------------------------------------------------
# The simulation
# ----------------------------------------------------------------------------


def simulate_precrash(
    vehicle1: VehicleArrays, vehicle2: VehicleArrays,
    paths: PathArrays, road_friction: npt.ArrayLike,
    controller: BrakeController | None = None, params: PrecrashParams | None = None,
    rng: np.random.Generator | SegmentedRandom | None = None,
    penetration: Callable[[np.ndarray, KinematicState], np.ndarray] | None = None,
    case_of: npt.ArrayLike | None = None, first_step: npt.ArrayLike | None = None,
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
    case_of : array_like of int, optional
        Simulate case instances: row i is case ``case_of[i]`` (:class:`PrecrashRun`);
        the result has one row per instance.
    first_step : array_like of int, optional
        Replay only (no ``controller``): the step of its record each row starts at
        (default 0).  Without a controller a case follows its record exactly until
        first contact, so a row started at any step before its contact reaches the
        same contact and impact, bit for bit; its closest approach before contact is
        then only that after its start.  The model-variant searches
        (:class:`vfs.diagnosis.variants.VariantSimulator`) start variants that change
        only the penetration time a few steps before the contact of the base run.

    Returns
    -------
    PrecrashResult

    Notes
    -----
    A loop over :class:`PrecrashRun`: observe, ask the controller, advance.
    The gym environments (:mod:`vfs.gym.env`) drive the same class step by
    step with the agent in place of the controller.
    """
    if first_step is not None and controller is not None:
        raise ParameterError("first_step replays the records: it takes no controller")
    if controller is None and penetration is None:
        if core.enabled():  # numba is imported with the first compiled run
            instances = check_instances(vehicle1.size, paths, case_of, first_step)
            return core.replay_precrash(vehicle1, vehicle2, paths, params or PrecrashParams(),
                                        CLOSE_RANGE, case_of=instances[0],
                                        first_step=instances[1])
    log_stepped_run(controller, penetration)
    run = PrecrashRun(vehicle1, vehicle2, paths, road_friction, params=params,
                      penetration=penetration, case_of=case_of, first_step=first_step)
    if controller is not None:
        reset_controller(controller, run.n, rng)
    while not run.done:
        demand = controller.demand(run.observation()) if controller is not None else None
        run.advance(demand)
    return run.result()


def check_instances(n_data: int, paths: PathArrays, case_of: npt.ArrayLike | None,
                    first_step: npt.ArrayLike | None
                    ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Checked case instances of a run over ``n_data`` cases: ``case_of`` (int array or
    None) and ``first_step`` (int array (n,) or None), as :func:`simulate_precrash` takes them.

    Raises
    ------
    ParameterError
        Paths not two per case, ``case_of`` outside 0..n_data - 1, ``first_step`` < 0.
    """
    if paths.size != 2 * n_data:
        raise ParameterError(f"paths hold {paths.size} records for {n_data} cases "
                             "(need 2 per case)")
    rows = None if case_of is None else np.asarray(case_of, np.int64).reshape(-1)
    if rows is not None and rows.size and (rows.min() < 0 or rows.max() >= n_data):
        raise ParameterError(f"case_of indices outside 0..{n_data - 1}")
    if first_step is None:
        return rows, None
    n = n_data if rows is None else rows.size
    steps = np.broadcast_to(np.asarray(first_step, np.int64), (n,))
    if steps.size and steps.min() < 0:
        raise ParameterError("first_step must be >= 0")
    return rows, steps


#: Kinds of run already reported on the reference path (one log line per kind and process).
_REPORTED: set[str] = set()


def log_stepped_run(controller: BrakeController | None,
                    penetration: Callable[..., np.ndarray] | None) -> None:
    """Say once per process and kind (logging, INFO) why a run is stepped from Python
    instead of running in the compiled per-case loop (:mod:`vfs.physics.core`): a
    controller or a penetration rule in Python (called between the compiled steps,
    :meth:`PrecrashRun.advance`), or the compiled core switched off.
    """
    import logging

    if not core.enabled():
        why = f"{core.ENV_SWITCH}=0: the numpy reference path"
    elif controller is not None:
        why = (f"the controller {type(controller).__name__} runs in Python between "
               "compiled steps")
    else:
        why = "a Python penetration rule (an effect's hook) runs between compiled steps"
    if why not in _REPORTED:
        _REPORTED.add(why)
        logging.getLogger("vfs.physics.precrash").info("pre-crash: %s", why)


class PrecrashRun(PrecrashCases):
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
    first_step : array_like of int, optional
        The step of its record each row starts at (default 0); replay only, as for
        :func:`simulate_precrash`.

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
                 case_of: npt.ArrayLike | None = None,
                 first_step: npt.ArrayLike | None = None) -> None:
        params = params or PrecrashParams()
        n_data = vehicle1.size
        self.case_of, steps = check_instances(n_data, paths, case_of, first_step)
        n = n_data if self.case_of is None else self.case_of.size
        super().__init__(vehicle1, vehicle2, paths, params.dt, n, self.case_of)
        self.params = params
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

        self.running = np.zeros(n, dtype=bool)

        rows = np.arange(n) if start is None else np.unique(np.asarray(start, np.int64))
        if steps is not None:
            # a row started at step j of its record: its clock reads (k + j) dt
            self.k0 = -steps.copy()
        self.rows = rows
        self._core_inputs: tuple[np.ndarray, ...] | None = None
        self.running[rows] = True
        self.track = _Track(rows.shape[0])
        self.active: tuple[np.ndarray, np.ndarray] | None = None
        self._save_previous()
        self.finished = np.zeros(0, dtype=np.int64)
        self.done = False
        self._settle()

    def _save_previous(self) -> None:
        t = self.track
        self.prev_dv, self.prev_ds = t.dv.copy(), t.ds.copy()
        self.prev_ti, self.prev_si = t.t_index.copy(), t.s_index.copy()

    def _keep(self, keep: np.ndarray) -> None:
        """Drop the running rows where ``keep`` is False."""
        keep = np.flatnonzero(keep)  # one index for the twenty-odd arrays
        self.rows = self.rows[keep]
        self.state = take_state(self.state, keep)
        self.v_rec, self.a_rec = take_rows(self.v_rec, keep), take_rows(self.a_rec, keep)
        self.track.take(keep)
        self.prev_dv, self.prev_ds = take_rows(self.prev_dv, keep), take_rows(self.prev_ds, keep)
        self.prev_ti, self.prev_si = take_rows(self.prev_ti, keep), take_rows(self.prev_si, keep)
        self.active = None

    # ------------------------------------------------------------------ one step

    def _settle(self) -> None:
        """Kinematics at the current step; impacts due, contacts, closest approach, ends."""
        if core.enabled():
            self._settle_compiled()
            return
        params, dt, paths = self.params, self.dt, self.paths
        v1, v2 = self.v1, self.v2
        track = self.track
        rows = self.rows
        ended: list[np.ndarray] = []
        kk = self.k - self.k0[rows]  # steps since each case's start
        tau = kk * dt
        if self.active is None or self.active[0].shape[0] != 2 * rows.shape[0]:
            self.active = active_rows(paths, self._d(rows))
        s_rec, v_rec, a_rec, track.t_index = record_pair(paths, rows, tau, track.t_index,
                                                     active=self.active)
        gap_now = np.minimum(track.dv, v_rec)
        stepped = (kk > 0)[:, None]
        track.ds = np.where(stepped, track.ds + 0.5 * dt * (track.gap + gap_now), track.ds)
        track.gap = gap_now
        self.state, track.s_index = state_at_arclength(paths, rows, s_rec - track.ds,
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
            st_i = kinematics_at(paths, self._d(r), impact_time[r], dv_i, ds_i)
            put_rows(self.impact_state, r, st_i)
            pending[r] = False
            self.speed_reduction[r] = self._taken_off(r, impact_time[r], dv_i)
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
            touching[near] = overlapping(v1, v2, self._d(rows[near]),
                                          take_state(state, near))
        new_contact = touching
        if new_contact.any():
            r = rows[new_contact]
            first = kk[new_contact] == 0  # overlapping from the start of the record
            t_c = np.zeros(r.shape[0])
            later = ~first
            if later.any():
                sel = np.flatnonzero(new_contact)[later]
                t_c[later] = bisect_contact(
                    paths, v1, v2, self._d(rows[sel]), prev_tau[sel], tau[sel],
                    self.prev_dv[sel], track.dv[sel], self.prev_ds[sel], track.ds[sel],
                    params.contact_tolerance, (self.prev_ti[sel], self.prev_si[sel]))
            w = np.where(first, 0.0, np.clip((t_c - prev_tau[new_contact]) / dt, 0.0,
                                             1.0))[:, None]
            dv_c = self.prev_dv[new_contact] + w * (track.dv[new_contact]
                                                    - self.prev_dv[new_contact])
            ds_c = self.prev_ds[new_contact] + w * (track.ds[new_contact]
                                                    - self.prev_ds[new_contact])
            self._contact(r, t_c, kinematics_at(paths, self._d(r), t_c, dv_c, ds_c), dv_c,
                          ds_c)
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
            sub = take_state(state, cand)
            o1, o2 = outlines(v1, v2, self._d(rows[cand]), sub)
            dist = outline_distance(o1, o2)
            r = rows[cand]
            better = dist < self.min_distance[r]
            self.min_distance[r[better]] = dist[better]
            self.time_closest[r[better]] = tau[cand][better]

        self._end_rows(ended, tau)

    def _end_rows(self, ended: list[np.ndarray], tau: np.ndarray) -> None:
        """The end of a step: drop the rows impacted with zero penetration time, close the
        expired ones (own times ``tau`` [s] of the running rows) and, at the run's
        horizon, all; ``ended`` lists the rows ended earlier in the step.
        """
        pending, rows = self.pending, self.rows
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

    def _settle_compiled(self) -> None:
        """:meth:`_settle` by the compiled step (:func:`vfs.physics.core.settle_rows`): the
        same arithmetic row by row; the penetration time and the ends of the rows here.
        """
        params, dt, track, rows = self.params, self.dt, self.track, self.rows
        if self._core_inputs is None:
            paths, v1, v2 = self.paths, self.v1, self.v2
            dims = np.stack([v1.cg_to_front, v1.cg_to_rear, v1.width, v2.cg_to_front,
                             v2.cg_to_rear, v2.width], axis=1)
            self._core_inputs = (np.ascontiguousarray(paths.knots, dtype=float),
                                 np.ascontiguousarray(paths.count, dtype=np.int64),
                                 np.ascontiguousarray(paths.end_curvature, dtype=float),
                                 np.ascontiguousarray(dims, dtype=float))
        knots, count, end_curvature, dims = self._core_inputs
        m = rows.shape[0]
        kk = self.k - self.k0[rows]  # steps since each case's start
        st = np.empty((7, m, 2))
        rec = np.empty((2, m, 2))
        event = np.empty(m, dtype=np.int64)
        ev_state = np.empty((m, 7, 2))
        ev_f = np.empty((m, 5))
        min_distance, time_closest = self.min_distance[rows], self.time_closest[rows]
        core.settle_rows(knots, count, end_curvature, dims, self.reach[rows],
                         np.ascontiguousarray(self._d(rows), dtype=np.int64), kk, dt,
                         params.contact_tolerance, CLOSE_RANGE, track.dv, track.ds, track.gap,
                         track.t_index, track.s_index, self.prev_dv, self.prev_ds,
                         self.prev_ti, self.prev_si, track.best_centre, track.best_time,
                         track.best_x, track.best_y, track.best_yaw, self.pending[rows],
                         self.impact_time[rows], min_distance, time_closest, st, rec, event,
                         ev_state, ev_f)
        self.min_distance[rows], self.time_closest[rows] = min_distance, time_closest
        self.state = KinematicState(*st)
        self.v_rec, self.a_rec = rec[0], rec[1]
        tau = kk * dt
        ended: list[np.ndarray] = []
        if not event.any():  # no contact, no impact (EVENT_NONE is 0): the rows' ends only
            self._end_rows(ended, tau)
            return
        new = event == core.EVENT_CONTACT
        if new.any():
            r = rows[new]
            t_c = ev_f[new, 0]
            st_c = KinematicState(*np.ascontiguousarray(ev_state[new].transpose(1, 0, 2)))
            self._contact(r, t_c, st_c, ev_f[new, 1:3], ev_f[new, 3:5])
        due = event == core.EVENT_IMPACT
        if due.any():
            r = rows[due]
            put_rows(self.impact_state, r,
                     KinematicState(*np.ascontiguousarray(ev_state[due].transpose(1, 0, 2))))
            self.pending[r] = False
            self.speed_reduction[r] = self._taken_off(r, self.impact_time[r], ev_f[due, 1:3])
            ended.append(r)
            self._keep(~due)
            tau = tau[~due]
        self._end_rows(ended, tau)

    def _contact(self, r: np.ndarray, t_c: np.ndarray, st_c: KinematicState,
                 dv_c: np.ndarray, ds_c: np.ndarray) -> None:
        """Record the first contact of rows ``r`` at times ``t_c`` [s] in state ``st_c``
        with the reductions ``dv_c``, ``ds_c`` there; the penetration time sets the impact.
        """
        params = self.params
        self.collided[r] = True
        self.contact_time[r] = t_c
        self.pending[r] = True
        self.min_distance[r] = 0.0
        self.time_closest[r] = t_c
        put_rows(self.contact_state, r, st_c)
        self.contact_dv[r], self.contact_ds[r] = dv_c, ds_c
        t_pen = np.full(r.shape[0], params.penetration_time)
        if self.penetration is not None:
            t_pen = np.asarray(self.penetration(self._d(r), st_c), float)
            if t_pen.shape != r.shape or not np.all((t_pen >= 0.0) & (t_pen <= 0.5)):
                raise ParameterError("penetration times must be (n,) values in [0, 0.5] s")
        self.impact_time[r] = t_c + t_pen
        instant = t_pen == 0.0
        if instant.any():
            ri = r[instant]
            put_rows(self.impact_state, ri, take_state(self.contact_state, ri))
            self.pending[ri] = False
            self.speed_reduction[ri] = self._taken_off(ri, t_c[instant], dv_c[instant])

    def _taken_off(self, r: np.ndarray, t: np.ndarray, dv: np.ndarray) -> np.ndarray:
        """Speed taken off the record [m/s] of rows ``r`` at their times ``t`` [s], where the
        speed reduction integrated so far is ``dv`` (n, 2): min(dv, v_rec(t)) = v_rec - v.

        dv goes on growing while a stopped vehicle stays braked (the vehicle stays at
        v = max(v_rec - dv, 0) = 0); the speed taken off cannot exceed the recorded speed.
        """
        _, v_rec, _, _ = record_pair(self.paths, self._d(r), t, None)
        return np.minimum(dv, v_rec)

    def _close(self, r: np.ndarray, sel: np.ndarray) -> None:
        """End rows ``r`` (= running rows ``sel``) without a collision at the current step."""
        track = self.track
        put_rows(self.end_state, r, take_state(self.state, sel))
        self.speed_reduction[r] = track.gap[sel]  # min(dv, v_rec): the speed taken off
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
            new_decel = actuator_step(track.decel, demand, take_rows(self.limit, rows),
                                      self.params.brake, dt)
        else:
            new_decel = track.decel
        mean_decel = 0.5 * (track.decel + new_decel)
        braking = mean_decel > 0
        track.dv = track.dv + dt * np.where(braking, np.maximum(0.0, self.a_rec + mean_decel),
                                            0.0)
        started = (new_decel > 0) & np.isnan(take_rows(self.brake_start, rows))
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
        self._check_startable(new)  # before the running rows are set aside
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

    def _check_startable(self, new: np.ndarray) -> None:
        """Raise :class:`ParameterError` unless cases ``new`` are distinct and not running."""
        if np.unique(new).size != new.size or self.running[new].any():
            raise ParameterError("cases to start must be distinct and not running")

    def _start(self, new: np.ndarray) -> None:
        """(Re)start cases ``new`` at the current step with fresh results."""
        if new.size == 0:
            return
        self._check_startable(new)
        self.k0[new] = self.k
        self._reset_outcomes(new)
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
