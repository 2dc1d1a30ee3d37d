"""The AEB controller: sensor, threat assessment, staged braking and the driver.

:class:`AEBController` implements :class:`vfs.physics.precrash.BrakeController`.  Per
case and equipped participant ("ego"; the other participant is its object):

1. Once per sensor cycle (measurement time t_m) the sensor checks whether the
   object's outline intersects the field-of-view sector (:mod:`vfs.adas.sensor`)
   and draws the detection; for detected objects that can be reached within
   the horizon the TTC of the predicted outlines is computed
   (:mod:`vfs.adas.threat`).
2. The stage logic (trigger, hold, release; :class:`vfs.adas.params.AEBParams`)
   runs on that measurement.  A visible object that was not detected leaves
   the decision unchanged (the track coasts); an invisible one counts as no
   threat (infinite TTC).
3. The decision is queued and acts from t_m + latency until the next one
   acts: the controller acts on measurements ``latency`` old.  Queuing the
   decision instead of the measurement is equivalent (the decision depends
   only on the measurement and the state before it) and keeps one TTC
   computation per measurement.
4. Every simulation step the demand is the largest deceleration of the
   acting stages (full braking limited to road friction x g) and of the
   driver, who brakes after the first alert + reaction time + brake lag.

All state is held in arrays over the N cases of the batch and both
participants; the steps work on the cases still running (``obs.rows``).
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.adas import compiled
from vfs.adas.params import STANDSTILL_SPEED, AEBParams, DriverParams
from vfs.adas.sensor import outline_visible
from vfs.adas.threat import Motion, braked_contact, earliest_contact, time_to_collision
from vfs.errors import ParameterError
from vfs.physics.numba_support import enabled as core_enabled
from vfs.physics.precrash import (
    BrakeActuatorParams,
    PrecrashObservation,
    friction_limited_deceleration,
)
from vfs.physics.precrash_contact import take_rows

if TYPE_CHECKING:
    from vfs.simulation import CaseBatch

#: Stage names, in the order of the last axis of the stage arrays.
STAGES = ("warning", "partial", "full")

#: Keys of :meth:`AEBController.events`.
EVENT_KEYS = ("warning_time", "partial_time", "full_time", "ttc_at_trigger",
              "driver_reaction_time", "driver_brake_time", "driver_deceleration")

#: Slack [s] when comparing the step time with a scheduled time.
_TIME_SLACK = 1e-9

#: Step [s] assumed before the controller has seen two steps (PrecrashParams default).
_DEFAULT_DT = 0.01


class _Decision(NamedTuple):
    """A decision waiting for its latency to pass."""

    t_act: float | np.ndarray  # time from which it acts [s] (scalar or per case)
    stage: np.ndarray  # (N, 2, 3) bool, stages active
    ttc: np.ndarray  # (N, 2) TTC measured [s]


def actuator_delay(brake: BrakeActuatorParams, deceleration: np.ndarray,
                   dt: float) -> np.ndarray:
    """Delay [s] of the step of ``deceleration`` equivalent to the actuator's build-up.

    A ramp of jerk J to a loses the speed a t_r / 2 (t_r = a / J), like a step
    t_r / 2 later; the simulation averages the actuator output over a step,
    so a ramp shorter than one step acts like one of one step:
    max(a / J, dt) / 2.  A first-order lag (discrete, factor
    alpha = 1 - exp(-dt / tau) per step, averaged over the step) loses the
    speed a (dt / alpha - dt / 2).  docs/aeb.md, eq. 3.7.
    """
    if brake.model == "jerk":
        return 0.5 * np.maximum(deceleration / brake.jerk, dt)
    alpha = 1.0 - np.exp(-dt / brake.time_constant)
    return np.full_like(np.asarray(deceleration, float), dt / alpha - 0.5 * dt)


class AEBController:
    """A generic AEB (and the equipped vehicles' drivers) for a batch of cases.

    Parameters
    ----------
    batch : CaseBatch
        The cases; their vehicles give the outline dimensions.
    equipped : array_like of bool, broadcastable to (N, 2)
        Which participant of each case carries the system (e.g. ``[True,
        False]``: participant 1 of every case).
    aeb : AEBParams
    driver : DriverParams, optional
        The driver's reaction to the first alert; None = no reaction.
    brake : BrakeActuatorParams, optional
        The actuator the simulation uses with this system (the last-moment
        rule anticipates its build-up); default ``BrakeActuatorParams()``.

    Notes
    -----
    Run it through :func:`vfs.simulation.simulate_cases` (or
    :func:`vfs.physics.precrash.simulate_precrash`) with
    ``AEBSystem.precrash_params(...)`` so that the simulation's actuator is
    the system's.  :meth:`events` returns what happened after the run.
    """

    def __init__(self, batch: CaseBatch, equipped: npt.ArrayLike, aeb: AEBParams,
                 driver: DriverParams | None = None,
                 brake: BrakeActuatorParams | None = None) -> None:
        n = batch.size
        try:
            eq = np.broadcast_to(np.asarray(equipped, dtype=bool), (n, 2)).copy()
        except ValueError as exc:
            raise ParameterError(f"equipped must broadcast to ({n}, 2) (cases x participants), "
                                 f"got shape {np.shape(equipped)}") from exc
        self.aeb = aeb
        self.driver = driver
        self.brake = brake if brake is not None else BrakeActuatorParams()
        self.equipped = eq
        self._n = n
        v1, v2 = batch.vehicle1, batch.vehicle2
        self._front = np.stack([v1.cg_to_front, v2.cg_to_front], axis=1)  # [m]
        self._rear = np.stack([v1.cg_to_rear, v2.cg_to_rear], axis=1)  # [m]
        self._width = np.stack([v1.width, v2.width], axis=1)  # [m]
        # the outline rows of a packed Motion (vfs.adas.compiled.gather_pairs) of every (case,
        # participant), flat index 2 case + participant: half length and half width
        # enlarged by the box margins, centre offset [m] (the numbers _pairs gives)
        ml, mw = 0.5 * aeb.box_margin_longitudinal, 0.5 * aeb.box_margin_lateral
        self._outline = np.stack([0.5 * (self._front + self._rear) + ml,
                                  0.5 * self._width + mw,
                                  0.5 * (self._front - self._rear)]).reshape(3, 2 * n)
        thresholds = np.array([np.nan if x is None else x for x in aeb.thresholds], float)
        self._thresholds = thresholds  # (3,) [s]
        self._release_thresholds = np.where(np.isnan(thresholds), np.inf,
                                            aeb.release_factor * thresholds)
        self._initialise(n, None)

    # ------------------------------------------------------------------ state

    def _initialise(self, n: int, rng: np.random.Generator | None,
                    segments: tuple[tuple[int, ...], tuple[np.random.Generator, ...]] | None
                    = None) -> None:
        """Fresh state for a run; the drivers are drawn from ``rng`` (None: not yet), or
        segment by segment from ``segments`` = (sizes, generators).
        """
        self._rng = rng if rng is not None else np.random.default_rng(0)
        # first case of each segment and its generator (one segment: the whole batch)
        if segments is None:
            self._segment_starts = np.zeros(1, dtype=np.int64)
            self._segment_rngs: tuple[np.random.Generator, ...] = (self._rng,)
        else:
            self._segment_starts = np.concatenate([[0], np.cumsum(segments[0])[:-1]])
            self._segment_rngs = tuple(segments[1])
        self._stage = np.zeros((n, 2, 3), dtype=bool)  # decided at the last measurement
        self._acting = np.zeros((n, 2, 3), dtype=bool)  # decision acting now
        self._ttc = np.full((n, 2), np.inf)  # last measured TTC [s]
        self._queue: deque[_Decision] = deque()
        self._next_measurement = 0.0  # [s]
        self._t_prev: float | None = None
        self._dt = _DEFAULT_DT
        self._stage_time = np.full((n, 2, 3), np.nan)
        self._alert_time = np.full((n, 2), np.nan)
        self._ttc_at_trigger = np.full((n, 2), np.nan)
        self._driver_start = np.full((n, 2), np.inf)  # planned start of driver braking [s]
        self._driver_time = np.full((n, 2), np.nan)  # actual start [s]
        d = self.driver
        if d is None or rng is None:
            self._reaction = np.full((n, 2), np.nan)
            self._driver_brakes = np.zeros((n, 2), dtype=bool)
            self._driver_decel = np.zeros((n, 2))
            return
        sizes = np.diff(np.append(self._segment_starts, n))
        reaction, brakes, decel = [], [], []
        for size, g in zip(sizes, self._segment_rngs, strict=True):
            m = int(size)  # each segment draws as a run of its cases alone would
            reaction.append(g.gamma(d.reaction_shape, 1.0 / d.reaction_rate, (m, 2))
                            if d.reaction_time is None else np.full((m, 2), d.reaction_time))
            brakes.append(g.random((m, 2)) < d.brake_share)
            decel.append(d.deceleration_mean + d.deceleration_sd * g.standard_normal((m, 2)))
        self._reaction = np.concatenate(reaction)
        self._driver_brakes = np.concatenate(brakes) & self.equipped
        self._driver_decel = np.clip(np.concatenate(decel), d.deceleration_min,
                                     d.deceleration_max)

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Prepare a run over the batch's ``n_cases`` cases; draw the drivers from ``rng``."""
        if n_cases != self._n:
            raise ParameterError(f"AEBController was built for {self._n} cases, the simulation "
                                 f"runs {n_cases}")
        self._initialise(n_cases, rng)

    def reset_segments(self, sizes: tuple[int, ...],
                       generators: tuple[np.random.Generator, ...]) -> None:
        """Prepare a run whose consecutive segments of ``sizes`` cases draw from their own
        ``generators`` (:class:`vfs.physics.precrash.SegmentedRandom`): every draw of a
        case is the one of a run of its segment alone with its generator.
        """
        if sum(sizes) != self._n or len(sizes) != len(generators):
            raise ParameterError(f"AEBController was built for {self._n} cases, the segments "
                                 f"cover {sum(sizes)}")
        self._initialise(self._n, generators[0], (tuple(sizes), tuple(generators)))

    def _draw(self, case: np.ndarray) -> np.ndarray:
        """One uniform draw [0, 1) per entry of ``case`` (ascending case indices), each from
        its segment's generator, segment by segment.
        """
        if len(self._segment_rngs) == 1:
            return self._segment_rngs[0].random(case.size)
        seg = np.searchsorted(self._segment_starts, case, side="right") - 1
        counts = np.bincount(seg, minlength=len(self._segment_rngs))
        return np.concatenate([g.random(int(c)) for g, c in
                               zip(self._segment_rngs, counts, strict=True)])

    # ------------------------------------------------------------------ steps

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        """Demanded deceleration [m/s^2] (n, 2) for the cases ``obs.rows``; 0 where unequipped."""
        t = float(obs.t)
        if self._t_prev is not None and t > self._t_prev:
            self._dt = t - self._t_prev
        self._t_prev = t
        if t >= self._next_measurement - _TIME_SLACK:
            self._measure(obs)
            cycle = self.aeb.sensor.cycle_time
            self._next_measurement = ((np.floor(t / cycle + 1e-6) + 1.0) * cycle
                                      if cycle > 0.0 else -np.inf)
        self._act(t)
        rows = obs.rows
        acting = take_rows(self._acting, rows)
        full = friction_limited_deceleration(obs.road_friction, self.aeb.full_deceleration)[:, None]
        out = np.where(acting[..., 2], full, 0.0)
        out = np.maximum(out, np.where(acting[..., 1], self.aeb.partial_deceleration, 0.0))
        if self.driver is not None:
            on = t >= take_rows(self._driver_start, rows) - _TIME_SLACK
            first = on & np.isnan(take_rows(self._driver_time, rows))
            if first.any():
                ri, ci = np.nonzero(first)
                self._driver_time[rows[ri], ci] = t
            out = np.maximum(out, np.where(on, take_rows(self._driver_decel, rows), 0.0))
        return np.where(take_rows(self.equipped, rows), out, 0.0)

    def _act(self, t: float) -> None:
        """Let the queued decisions whose latency has passed act; record first times."""
        while self._queue and self._queue[0].t_act <= t + _TIME_SLACK:
            decision = self._queue.popleft()
            first = decision.stage & np.isnan(self._stage_time)
            if first.any():
                self._stage_time[first] = t
                alert = decision.stage.any(axis=2) & np.isnan(self._alert_time)
                if alert.any():
                    self._alert_time[alert] = t
                    self._ttc_at_trigger[alert] = decision.ttc[alert]
                    react = alert & self._driver_brakes
                    self._driver_start[react] = (t + self._reaction[react]
                                                 + (self.driver.brake_lag
                                                    if self.driver is not None else 0.0))
            self._acting = decision.stage

    def _measure(self, obs: PrecrashObservation) -> None:
        """One sensor cycle: reach, visibility, detection, TTC and the stage logic.

        The compiled kernels of :mod:`vfs.adas.compiled` by default; the numpy path
        below with ``VFS_COMPILED=0`` (:func:`vfs.physics.numba_support.enabled`), the reference.
        """
        aeb, sensor = self.aeb, self.aeb.sensor
        rows = obs.rows
        ri, ji = np.nonzero(take_rows(self.equipped, rows))
        if ri.size and core_enabled():
            case = rows[ri]
            a, b = compiled.gather_pairs(obs.x, obs.y, obs.yaw, obs.heading, obs.speed,
                                         obs.accel, obs.yaw_rate, self._outline, obs.rows,
                                         ri, ji)
            compiled.assess(a, b, case, ji, self._front.reshape(-1)[2 * case + ji],
                            obs.road_friction[ri], self._stage, self._ttc, aeb, self.brake,
                            self._dt, self._draw)
        elif ri.size:
            case = rows[ri]
            front = self._front[case, ji]
            ml, mw = 0.5 * aeb.box_margin_longitudinal, 0.5 * aeb.box_margin_lateral
            ego, obj = self._pairs(obs, ri, ji)
            # TTC is needed only up to the largest threshold that can still change
            # the decision; beyond it (or beyond reach) it counts as infinite
            horizon = self._needed_horizon(self._stage[case, ji], ego.speed)
            ttc = np.full(ri.size, np.inf)
            near = (horizon > 0.0) & (earliest_contact(ego, obj, aeb.prediction) <= horizon)
            visible = np.zeros(ri.size, dtype=bool)
            detected = np.zeros(ri.size, dtype=bool)
            if near.any():
                e, o = ego.take(near), obj.take(near)
                ce, se = np.cos(e.yaw), np.sin(e.yaw)
                mx, my = front[near] + sensor.mount_x, sensor.mount_y  # from the CG
                co, so = np.cos(o.yaw), np.sin(o.yaw)
                seen = outline_visible(
                    e.x + ce * mx - se * my, e.y + se * mx + ce * my,
                    e.yaw + sensor.mount_yaw, sensor.field_of_view, sensor.range,
                    o.x + o.centre_offset * co, o.y + o.centre_offset * so, o.yaw,
                    o.half_length - ml, o.half_width - mw)
                found = seen.copy()
                p = sensor.detection_probability
                if p <= 0.0:
                    found[:] = False
                elif p < 1.0 and seen.any():
                    found[seen] = self._draw(case[near][seen]) < p
                visible[near], detected[near] = seen, found
                sel = np.flatnonzero(near)[found]
                if sel.size:
                    ttc[sel] = time_to_collision(ego.take(sel), obj.take(sel), horizon[sel],
                                                 aeb.prediction, aeb.ctrv_tolerance,
                                                 aeb.ctrv_step)
            self._decide(case, ji, ttc, ego, obj, obs.road_friction[ri], detected | ~visible)
        self._queue.append(_Decision(obs.t + sensor.latency, self._stage.copy(),
                                     self._ttc.copy()))

    def _pairs(self, obs: PrecrashObservation, ri: np.ndarray,
               ji: np.ndarray) -> tuple[Motion, Motion]:
        """The egos (running row ``ri``, participant ``ji``) and their objects, outlines
        enlarged by the box margins [m]: the rows of :meth:`_packed_pairs`.
        """
        a, b = self._packed_pairs(obs, ri, ji)
        return Motion(*a), Motion(*b)

    def _packed_pairs(self, obs: PrecrashObservation, ri: np.ndarray,
                      ji: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The egos (running row ``ri``, participant ``ji``) and their objects packed for
        the compiled kernels (as :func:`vfs.adas.compiled.gather_pairs`: the fields of
        :class:`vfs.adas.threat.Motion` as rows, (10, m) each), gathered at once.
        """
        # the direction of motion is undefined at standstill: take the yaw there
        heading = np.where(obs.speed > 0.0, obs.heading, obs.yaw)
        kin = np.stack([obs.x, obs.y, obs.yaw, heading, obs.speed, obs.accel,
                        obs.yaw_rate]).reshape(7, -1)  # (7, 2 n): flat index 2 row + column
        ego = 2 * ri + ji
        obj = ego ^ 1  # the other participant of the row
        flat = 2 * obs.rows[ri]
        m = ri.shape[0]
        a, b = np.empty((10, m)), np.empty((10, m))
        np.take(kin, ego, axis=1, out=a[:7])
        np.take(self._outline, flat + ji, axis=1, out=a[7:])
        np.take(kin, obj, axis=1, out=b[:7])
        np.take(self._outline, flat + (1 - ji), axis=1, out=b[7:])
        return a, b

    def _needed_horizon(self, active: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """Horizon [s] per ego up to which the TTC can still change the decision.

        The thresholds of the stages that can trigger (inside the speed
        window, not active), the release thresholds of the active stages
        (release rule "ttc"), and the whole prediction horizon for the
        last-moment rule while full braking is off; capped at
        ``ttc_horizon``.  0 = nothing to decide.
        """
        aeb = self.aeb
        on = ~np.isnan(self._thresholds)
        window = (speed >= aeb.min_speed) & (speed <= aeb.max_speed)
        can_trigger = ~active & on[None, :] & window[:, None]
        need = np.where(can_trigger, np.nan_to_num(self._thresholds)[None, :], 0.0).max(axis=1)
        if aeb.release == "ttc":
            release = np.where(active & on[None, :], self._release_thresholds[None, :], 0.0)
            need = np.maximum(need, release.max(axis=1))
        if aeb.last_moment:
            need = np.where(window & ~active[:, 2], aeb.ttc_horizon, need)
        return np.minimum(need, aeb.ttc_horizon)

    def _decide(self, case: np.ndarray, col: np.ndarray, ttc: np.ndarray, ego: Motion,
                obj: Motion, friction: np.ndarray, update: np.ndarray) -> None:
        """Stage logic for the egos ``update``: trigger, hold or release."""
        aeb = self.aeb
        case, col, ttc = case[update], col[update], ttc[update]
        speed = ego.speed[update]
        active = self._stage[case, col]  # (m, 3)
        window = (speed >= aeb.min_speed) & (speed <= aeb.max_speed)
        trigger = (ttc[:, None] <= self._thresholds[None, :]) & window[:, None]
        if aeb.last_moment:
            trigger[:, 2] |= window & self._last_moment(ttc, ego.take(update),
                                                        obj.take(update), friction[update],
                                                        active[:, 2])
        if aeb.release == "ttc":
            release = (ttc[:, None] > self._release_thresholds[None, :]) | \
                np.isinf(ttc)[:, None]
        elif aeb.release == "standstill":
            release = np.broadcast_to((speed <= STANDSTILL_SPEED)[:, None], active.shape)
        else:
            release = np.zeros(active.shape, dtype=bool)
        self._stage[case, col] = np.where(active, ~release, trigger)
        self._ttc[case, col] = ttc

    def _last_moment(self, ttc: np.ndarray, ego: Motion, obj: Motion, friction: np.ndarray,
                     full_active: np.ndarray) -> np.ndarray:
        """Full braking is due by the last-moment rule (docs/aeb.md, section 3.7).

        Checked only where a contact is predicted (finite TTC) and full
        braking is not on yet, with the available deceleration
        min(full_deceleration, road friction x g, actuator limit).  Due when
        braking from the next decision (one cycle later, plus the latency and
        the actuator's equivalent delay, :func:`actuator_delay`) would no
        longer avoid the contact, and either braking from this decision
        still avoids it (the last moment) or nothing avoids it and the object
        lies ahead of the ego (braking mitigates; for an object from behind
        braking would not help).
        """
        out = np.zeros(ttc.shape[0], dtype=bool)
        check = np.isfinite(ttc) & ~full_active & (ego.speed > 0.0)
        if not check.any():
            return out
        aeb = self.aeb
        e, o = ego.take(check), obj.take(check)
        available = np.minimum(friction_limited_deceleration(friction[check],
                                                             aeb.full_deceleration),
                               self.brake.max_deceleration)
        now = aeb.sensor.latency + actuator_delay(self.brake, available, self._dt)
        cycle = max(aeb.sensor.cycle_time, self._dt)
        late = braked_contact(e, o, now + cycle, available, aeb.ttc_horizon, aeb.prediction)
        due = late.copy()
        if late.any():
            idx = np.flatnonzero(late)
            e, o = e.take(idx), o.take(idx)
            unavoidable = braked_contact(e, o, now[idx], available[idx], aeb.ttc_horizon,
                                         aeb.prediction)
            ahead = ((o.x + o.centre_offset * np.cos(o.yaw) - e.x
                      - e.centre_offset * np.cos(e.yaw)) * np.cos(e.heading)
                     + (o.y + o.centre_offset * np.sin(o.yaw) - e.y
                        - e.centre_offset * np.sin(e.yaw)) * np.sin(e.heading)) > 0.0
            due[idx] = ~unavoidable | ahead
        out[check] = due
        return out

    # ------------------------------------------------------------------ results

    def events(self) -> dict[str, np.ndarray]:
        """What happened in the last run, arrays (N, 2); NaN where it never happened.

        Keys: ``warning_time``, ``partial_time``, ``full_time`` -- first time
        [s, record time axis] the stage acted; ``ttc_at_trigger`` -- TTC [s]
        measured when the first stage triggered; ``driver_reaction_time`` --
        the sampled reaction time [s] of equipped participants whose driver
        brakes; ``driver_brake_time`` -- when the driver's demand started [s];
        ``driver_deceleration`` -- the sampled driver deceleration [m/s^2] of
        drivers who brake.
        """
        brakes = self._driver_brakes
        return {
            "warning_time": self._stage_time[..., 0].copy(),
            "partial_time": self._stage_time[..., 1].copy(),
            "full_time": self._stage_time[..., 2].copy(),
            "ttc_at_trigger": self._ttc_at_trigger.copy(),
            "driver_reaction_time": np.where(brakes, self._reaction, np.nan),
            "driver_brake_time": self._driver_time.copy(),
            "driver_deceleration": np.where(brakes, self._driver_decel, np.nan),
        }
