"""Synthetic accident scenes: vehicles, road and pre-crash trajectories by accident type.

This module (entry point :func:`generate_scenes`; the concepts live in
:mod:`~vfs.scenarios.fleet`, :mod:`~vfs.scenarios.catalogue`,
:mod:`~vfs.scenarios.speed_profile`, :mod:`~vfs.scenarios.road`,
:mod:`~vfs.scenarios.placement` and :mod:`~vfs.scenarios.designs`) builds the *scenes* of a
synthetic accident database: two passenger cars per case
(:data:`vfs.scenarios.fleet.FLEET`), the road (friction, surface, curvature) and
PreCrash-Matrix-like trajectories of both participants that collide at a designed time t*
(or pass each other at a designed lateral gap, for near misses).  Reconstructions (impact
outcomes) are not computed here.  Everything is SI inside (m, s, kg, rad, m/s); speeds given
in km/h in the documentation are converted where the defaults are defined.

Accident types (codes of the German/Austrian accident-type catalogue,
:data:`vfs.scenarios.catalogue.SCENARIO_TYPES`;
participant 1 is always the vehicle that causes the conflict; right-hand traffic, lanes
3.5 m wide):

- 241 head-on on a straight road: participant 1 drifts into the oncoming lane.
- 242 head-on in a bend: participant 1, on the inner lane of a right bend, is carried out
  of the bend into the oncoming lane.
- 243 head-on in a bend: participant 1 cuts the corner of a left bend, i.e. leaves the
  outer lane towards the inner side of the bend, into the oncoming lane.
- 264 head-on while overtaking: participant 1 has pulled out into the oncoming lane and
  steers back too late.
- 601 rear-end: participant 1 runs into participant 2 ahead in the same lane (about 30 %
  of the leads stand still).
- 321 crossing paths at a junction: the front of participant 1 strikes the side of
  participant 2.
- 211 left turn across the path of the oncoming participant 2, whose front strikes the
  turner's front-right corner or right side.

Construction (all steps are vectorised over the cases of one type)
-------------------------------------------------------------------
1. **Speed profiles.**  Each participant drives at its travel speed and possibly brakes
   late: from ``brake_lead_time`` before t* the deceleration builds up with a constant
   jerk to a level limited by road_friction * g.  Position, speed and acceleration follow
   in closed form (:func:`vfs.scenarios.speed_profile.longitudinal_motion`); after t*
   the braking continues (speed >= 0).  The distance before the impact
   sigma(t) = X(t*) - X(t) is exact.
2. **Road frame and manoeuvre.**  Each participant follows a road (a straight line or a
   circular arc of curvature k, curvilinear coordinates u along and l to the left of the
   centreline, travelled in direction +u or -u) with a heading offset phi(sigma) relative
   to the road direction at its own position (positive = to the vehicle's left): a
   raised-cosine ramp phi = A (1 + cos(pi min(sigma / S, 1))) / 2 (drift into the oncoming
   lane, evasive steering, late swerve or steer-back), a sin^2 bump (the lane change of an
   overtaker) and a turning arc of radius R (left turner).  Backwards from the impact pose,
   l(sigma) = l* - d int_0^sigma sin(phi) and u(sigma) = u* - d int_0^sigma cos(phi) /
   (1 - k l) (trapezoid rule on the sample grid); positions are the road points (u, l),
   yaw = road direction + phi (no side slip).  So the path is driven at exactly the speed
   of the record, and both participants of one road share its lanes even in bends.
3. **Contact placement.**  Participant 1's impact pose is designed; participant 2's
   heading follows from the type (opposite, same direction, crossing angle, ...).  Its
   position: a lateral offset perpendicular to the relative velocity v2 - v1 gives the
   designed overlap (share of the narrower projected face width), or a designed point of
   participant 2 is aimed at a designed point of participant 1 (crossing and turning
   types); then participant 2 slides along the relative velocity until the rectangles just
   touch (:func:`vfs.scenarios.placement.slide_to_contact`: ray casting of the corners of
   each rectangle against the edges of the other).  Near misses get a lateral gap instead
   and are placed where the outlines are about to pass each other.
4. **Lanes.**  The unknown lateral positions are solved so that every participant drives
   in its lane (lane centre +- ``lane_offset``) before its manoeuvre: the drift width of
   a head-on drifter, the lane-change width of an overtaker, the swerve length of a
   near-miss rear-end follower; rear-end crashes split the lateral offset between both
   lane positions; a left turner's position before the turn must lie in ``turner_lane``
   (else the design is redrawn, so the realised heading changes concentrate at 20-60 deg
   for turning radii of 8-15 m).
5. **Scene transform.**  Each case is rotated by a random angle and translated by up to
   1 km (the physics is frame independent).
6. **Replay check.**  All cases are replayed with :func:`vfs.physics.precrash.simulate_precrash`
   (no controller): a crash must collide with its first contact within
   :data:`CONTACT_TIME_TOLERANCE` of t*, a near miss must not collide and keep at least
   :data:`MIN_NEAR_MISS_DISTANCE` between the outlines.  To save time each case is
   replayed from the first sample at which the CGs come closer than the sum of the
   circumradii plus that distance plus one sample's travel (before it, the sample-wise
   CG distance proves that the outlines stay apart); the contact times equal those of a
   replay of the whole record.  Failing cases are redrawn from the same random stream
   (at most :data:`MAX_ATTEMPTS` draws per case), else :class:`vfs.errors.SimulationError`.

Physical plausibility limits: lateral accelerations of drifts, evasive steering and
turns are kept below ``max_lateral_accel`` (and 0.8 road_friction g; in bends what the
road's curvature leaves of it) by narrowing the angle ranges at high speed; bends take at
most half of that budget.  The overtaken vehicle of type 264 is not modelled (two
participants per case).

Python loops run over accident types, participants, blocks of :data:`CHUNK` cases
(memory) and redraw attempts only, never over single cases.
"""


from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import pandas as pd

from vfs.database.schema import normalise_table
from vfs.errors import ParameterError, SimulationError
from vfs.physics.paths import pack_paths
from vfs.physics.precrash import PrecrashParams, simulate_precrash
from vfs.physics.vehicle import VehicleArrays, corner_radius, vehicle_arrays
from vfs.scenarios.catalogue import SCENARIO_TYPES, ScenarioSpec
from vfs.scenarios.designs import DESIGNERS, DesignContext
from vfs.scenarios.fleet import FLEET, FLEET_COLUMNS, sample_fleet_arrays
from vfs.scenarios.placement import OutlineDims
from vfs.scenarios.road import PART_FIELDS, build_paths, heading_offset, new_part
from vfs.scenarios.speed_profile import NO_BRAKE
from vfs.scenarios.validation import check_count, check_rng, check_share
from vfs.units import wrap_angle

__all__ = ["SceneTables", "generate_scenes"]

#: Range of the designed impact time t* [s after the record start].
T_STAR_RANGE = (5.0, 6.0)
#: Record length after t* [s] for crashes and near misses.
AFTER_CRASH = 0.3
AFTER_NEAR_MISS = 1.0
#: Replay check: largest |first contact - t*| of a crash [s].
CONTACT_TIME_TOLERANCE = 0.25
#: Replay check: smallest outline distance of a near miss [m].
MIN_NEAR_MISS_DISTANCE = 0.1
#: Draws per case before :func:`generate_scenes` gives up (replay check).
MAX_ATTEMPTS = 5
#: Redraws of the design parameters of implausible scenes (vehicle outside its lane).
MAX_DESIGN_ATTEMPTS = 100
#: Half size of the square of random scene translations [m].
SCENE_EXTENT = 1000.0
#: Cases per block of the path construction and of the replay (memory bound).
CHUNK = 2000


class SceneTables(NamedTuple):
    """Output of :func:`generate_scenes`.

    Attributes
    ----------
    cases : pandas.DataFrame
        Database table ``cases`` (normalised, :mod:`vfs.database.schema`).
    participants : pandas.DataFrame
        Database table ``participants``.
    trajectories : pandas.DataFrame
        Database table ``trajectories`` (t [s] from 0, sample_interval spacing).
    design : pandas.DataFrame
        Ground truth per case (not a database table), one row per case in the order of
        ``cases``, SI units (suffix 1/2 = participant):

        - case_id, accident_type, collision; attempts (draws until the replay check
          passed), design_draws (redraws of implausible designs in the last draw),
          plausible (False only if :data:`MAX_DESIGN_ATTEMPTS` did not suffice);
        - t_star [s]; overlap [-] (designed overlap share; NaN for the aimed crossing and
          turning impacts; for near misses minus the lateral gap [m]); side (+1 = 2 on
          1's left, perpendicular to the relative velocity);
        - road_friction [-], wet, road_curvature [1/m], bend_radius [m];
        - travel_speed, impact_speed [m/s]; brake (bool), brake_start [s on the record
          axis], brake_deceleration [m/s^2], brake_jerk [m/s^3] (NaN without braking);
        - x, y [m], yaw [rad] at t* (global); heading_offset [rad] (to the road at t*,
          positive = left); relative_heading [rad] (yaw2 - yaw1, wrapped);
        - manoeuvres [rad, s, m]: drift_angle, drift_width, drift_length (head-on);
          steer_back_angle, steer_back_time, lane_change_time, lane_change_width
          (overtaking); evasive, evasive_angle, evasive_time, swerve_length1, standing2
          (rear-end); crossing_angle, from_right, impact_position (crossing; impact point
          on the struck side as share of the length); turn_radius, turn_angle (left turn);
          lane1, lane2 (lateral position [m] before the manoeuvre, road centreline 0,
          left positive for participant 1's direction of travel; crossing: each on its
          own road);
        - segment (fleet segment); scene_rotation [rad], scene_x, scene_y [m] (scene
          transform); contact_time [s] and min_distance [m] of the replay check.
    """

    cases: pd.DataFrame
    participants: pd.DataFrame
    trajectories: pd.DataFrame
    design: pd.DataFrame


# ----------------------------------------------------------------------------
# Batches of cases
# ----------------------------------------------------------------------------

_SAMPLE_FIELDS = ("x", "y", "yaw", "speed", "accel")


class _Batch:
    """All arrays of the N cases being generated (filled block-wise, redrawn per row)."""

    def __init__(self, types: np.ndarray, near: np.ndarray, m: int) -> None:
        n = types.shape[0]
        self.types = types
        self.near = near
        self.m = m
        self.k_star = np.zeros(n, dtype=np.int64)
        self.count = np.zeros(n, dtype=np.int64)
        self.mu = np.zeros(n)
        self.wet = np.zeros(n, dtype=bool)
        self.curvature = np.zeros(n)
        self.vehicles = [{f: np.zeros(n) for f in FLEET_COLUMNS[:-1]} for _ in range(2)]
        self.segment = [np.zeros(n, dtype=np.int64) for _ in range(2)]
        self.parts = [new_part(n), new_part(n)]
        self.samples = {f: np.zeros((n, 2, m)) for f in _SAMPLE_FIELDS}  # (case, part, t)
        self.extra: dict[str, np.ndarray] = {}
        self.scene = np.zeros((n, 3))  # rotation [rad], translation x, y [m]
        self.plausible = np.ones(n, dtype=bool)
        self.design_draws = np.zeros(n, dtype=np.int64)

    def put_extra(self, rows: np.ndarray, values: Mapping[str, np.ndarray]) -> None:
        n = self.types.shape[0]
        for name, v in values.items():
            v = np.asarray(v)
            if name not in self.extra:
                self.extra[name] = (np.zeros(n, bool) if v.dtype == bool
                                    else np.full(n, np.nan))
            self.extra[name][rows] = v

    def dims(self, rows: np.ndarray, i: int) -> OutlineDims:
        veh = self.vehicles[i]
        front = veh["front_overhang"][rows] + veh["cg_to_front_axle"][rows]
        return OutlineDims(front, veh["length"][rows] - front, veh["width"][rows])

    def vehicle_arrays(self, rows: np.ndarray, i: int) -> VehicleArrays:
        veh = self.vehicles[i]
        return vehicle_arrays(*(veh[f][rows] for f in (
            "mass", "length", "width", "wheelbase", "cg_to_front_axle", "front_overhang",
            "track_width", "cg_height")),  # type: ignore[misc]  # the star fills the 8 sizes
            yaw_inertia=veh["yaw_inertia"][rows])


def _draw(batch: _Batch, rows: np.ndarray, rng: np.random.Generator,
          specs: Mapping[int, ScenarioSpec], wet_share: float, dt: float) -> None:
    """(Re)draw the cases ``rows`` of the batch: vehicles, road, design, samples."""
    n = rows.shape[0]
    batch.wet[rows] = rng.random(n) < wet_share
    batch.mu[rows] = np.where(batch.wet[rows], rng.uniform(0.4, 0.65, n),
                              rng.uniform(0.7, 1.0, n))
    for i in range(2):
        cols, segment = sample_fleet_arrays(n, rng)
        for name, values in cols.items():
            batch.vehicles[i][name][rows] = values
        batch.segment[i][rows] = segment
    k_lo = math.ceil(T_STAR_RANGE[0] / dt - 1e-9)
    k_hi = math.floor(T_STAR_RANGE[1] / dt + 1e-9)
    batch.k_star[rows] = rng.integers(k_lo, k_hi + 1, n)
    after = np.where(batch.near[rows], math.ceil(AFTER_NEAR_MISS / dt - 1e-9),
                     math.ceil(AFTER_CRASH / dt - 1e-9))
    batch.count[rows] = batch.k_star[rows] + after + 1
    rotation = rng.uniform(-np.pi, np.pi, n)
    shift = rng.uniform(-SCENE_EXTENT, SCENE_EXTENT, (n, 2))
    batch.scene[rows] = np.column_stack([rotation, shift])
    batch.design_draws[rows] = 0
    for code in np.unique(batch.types[rows]):
        spec = specs[int(code)]
        sub = rows[batch.types[rows] == code]
        pending = sub
        for _ in range(MAX_DESIGN_ATTEMPTS):
            ctx = DesignContext(rng, spec, batch.dims(pending, 0), batch.dims(pending, 1),
                       batch.mu[pending], batch.near[pending])
            design = DESIGNERS[spec.kind](ctx)
            for i, part in enumerate((design.p1, design.p2)):
                for name in PART_FIELDS:
                    batch.parts[i][name][pending] = part[name]
            batch.curvature[pending] = design.road_curvature
            batch.put_extra(pending, design.extra)
            batch.plausible[pending] = design.ok
            batch.design_draws[pending] += 1
            pending = pending[~design.ok]
            if pending.size == 0:
                break
    # scene transform: rotate and translate both road frames
    c, s = np.cos(rotation), np.sin(rotation)
    for part in batch.parts:
        x, y = part["road_x"][rows], part["road_y"][rows]
        part["road_x"][rows] = c * x - s * y + shift[:, 0]
        part["road_y"][rows] = s * x + c * y + shift[:, 1]
        part["road_theta"][rows] = part["road_theta"][rows] + rotation
    for lo in range(0, n, CHUNK):
        block = rows[lo:lo + CHUNK]
        for i in range(2):
            part = {name: batch.parts[i][name][block] for name in PART_FIELDS}
            samples = build_paths(part, batch.k_star[block], batch.m, dt)
            for name in _SAMPLE_FIELDS:
                batch.samples[name][block, i] = samples[name]


class _Replay(NamedTuple):
    collided: np.ndarray
    contact_time: np.ndarray  # [s]
    min_distance: np.ndarray  # [m]


def _replay_start(batch: _Batch, rows: np.ndarray, dt: float) -> np.ndarray:
    """First sample of the replay window of each case in ``rows``.

    Before it, at every sample the CG distance exceeds the sum of the outlines'
    circumradii plus :data:`MIN_NEAR_MISS_DISTANCE` plus the distance both can cover in
    one sample interval, so the outlines neither touch nor come closer than
    :data:`MIN_NEAR_MISS_DISTANCE` there (an outline lies within its circumradius of the
    CG).  The window starts 2 samples before the first sample that fails this test, and
    at least 0.5 s before t*.
    """
    start = np.zeros(rows.shape[0], dtype=np.int64)
    for lo in range(0, rows.shape[0], CHUNK):
        block = rows[lo:lo + CHUNK]
        d1, d2 = batch.dims(block, 0), batch.dims(block, 1)
        reach = (corner_radius(d1.front, d1.rear, d1.width)
                 + corner_radius(d2.front, d2.rear, d2.width))
        x, y, v = (batch.samples[f][block] for f in ("x", "y", "speed"))
        distance = np.hypot(x[:, 0] - x[:, 1], y[:, 0] - y[:, 1])
        margin = MIN_NEAR_MISS_DISTANCE + 0.05 + (v[:, 0] + v[:, 1]) * dt
        close = distance <= reach[:, None] + margin
        close |= np.arange(batch.m)[None, :] >= batch.count[block, None]
        first = np.argmax(close, axis=1)
        latest = batch.k_star[block] - math.ceil(0.5 / dt)
        start[lo:lo + CHUNK] = np.clip(np.minimum(first - 2, latest), 0, None)
    return start


def _replay(batch: _Batch, rows: np.ndarray, dt: float) -> _Replay:
    """Replay the records of ``rows`` with simulate_precrash (no controller).

    Each case is replayed from the start of its window (:func:`_replay_start`); cases
    are processed in blocks of similar window length.  Contact times are returned on
    the record's time axis.
    """
    n = rows.shape[0]
    collided = np.zeros(n, dtype=bool)
    contact = np.full(n, np.nan)
    distance = np.full(n, np.nan)
    params = PrecrashParams(dt=min(PrecrashParams().dt, dt), extra_time=0.0)
    first = _replay_start(batch, rows, dt)
    order = np.argsort(batch.count[rows] - first, kind="stable")
    for lo in range(0, n, CHUNK):
        pos = order[lo:lo + CHUNK]
        block = rows[pos]
        nb = block.shape[0]
        j0 = first[pos]
        count = batch.count[block] - j0
        width = int(count.max())
        cols = j0[:, None] + np.arange(width)[None, :]
        mask = np.arange(width)[None, :] < count[:, None]
        cols = np.where(mask, cols, 0)
        t = np.broadcast_to(np.arange(width) * dt, (nb, width))[mask]
        long = {}
        for name in _SAMPLE_FIELDS:
            values = batch.samples[name][block]
            long[name] = np.concatenate([np.take_along_axis(values[:, i], cols, axis=1)[mask]
                                         for i in range(2)])
        group = np.concatenate([np.repeat(np.arange(nb), count),
                                np.repeat(np.arange(nb, 2 * nb), count)])
        paths = pack_paths(np.concatenate([t, t]), long["x"], long["y"], long["yaw"],
                           long["speed"], group, long["accel"])
        res = simulate_precrash(batch.vehicle_arrays(block, 0), batch.vehicle_arrays(block, 1),
                                paths, batch.mu[block], params=params)
        collided[pos] = res.collided
        contact[pos] = res.contact_time + j0 * dt
        distance[pos] = res.min_distance
    return _Replay(collided, contact, distance)


# ----------------------------------------------------------------------------
# Public entry point
# ----------------------------------------------------------------------------


def _largest_remainder(n: int, shares: np.ndarray) -> np.ndarray:
    """Integer counts summing to n, proportional to shares (largest remainder method)."""
    raw = n * shares / shares.sum()
    counts = np.floor(raw).astype(np.int64)
    rest = n - int(counts.sum())
    order = np.lexsort((np.arange(shares.size), -(raw - counts)))
    counts[order[:rest]] += 1
    return counts


def _descriptions(batch: _Batch, specs: Mapping[int, ScenarioSpec]) -> np.ndarray:
    """Short case descriptions (one per case)."""
    n = batch.types.shape[0]
    text = np.empty(n, dtype=object)
    for code in np.unique(batch.types):
        text[batch.types == code] = specs[int(code)].description
    text = pd.Series(text, dtype=object)
    gap = np.char.mod("%.1f", -np.nan_to_num(batch.extra.get("overlap", np.zeros(n))))
    prefix = np.where(batch.near, "near miss (lateral gap " + gap.astype(object) + " m), ", "")
    text = pd.Series(prefix, dtype=object) + text
    for key, note in (("standing2", "; participant 2 was standing"),
                      ("evasive1", "; participant 1 swerved"),
                      ("evasive2", "; participant 2 steered away")):
        if key in batch.extra:
            text = text + np.where(batch.extra[key] == 1, note, "")
    braking = [batch.parts[i]["brake_time"] < 0.5 * NO_BRAKE for i in range(2)]
    brake_note = np.select([braking[0] & braking[1], braking[0], braking[1]],
                           ["; both braked late", "; participant 1 braked late",
                            "; participant 2 braked late"], "")
    text = text + brake_note + np.where(batch.wet, "; wet road", "; dry road")
    return text.to_numpy(dtype=object)


def _tables(batch: _Batch, specs: Mapping[int, ScenarioSpec], case_ids: np.ndarray,
            dt: float, attempts: np.ndarray, replay: _Replay) -> SceneTables:
    n = batch.types.shape[0]
    cases = pd.DataFrame({
        "case_id": case_ids,
        "accident_type": batch.types,
        "road_friction": batch.mu,
        "road_surface": np.where(batch.wet, "wet", "dry"),
        "road_curvature": batch.curvature,
        "weight": np.ones(n),
        "collision": ~batch.near,
        "description": _descriptions(batch, specs),
    })
    part_cols: dict[str, np.ndarray] = {
        "case_id": np.repeat(case_ids, 2),
        "participant": np.tile(np.array([1, 2], dtype=np.int64), n),
    }
    for name in FLEET_COLUMNS[:-1]:
        part_cols[name] = np.column_stack([batch.vehicles[0][name],
                                           batch.vehicles[1][name]]).ravel()
    participants = pd.DataFrame(part_cols)
    participants["vehicle_class"] = "car"
    m = batch.m
    # trajectories: one gather per column from the (case, participant, sample) arrays,
    # built directly with the schema dtypes and column order (normalise_table leaves it
    # unchanged; copying 10^7 rows through it would double the time of this step)
    flat = np.flatnonzero(np.broadcast_to(
        (np.arange(m)[None, :] < batch.count[:, None])[:, None, :], (n, 2, m)))
    traj: dict[str, np.ndarray] = {
        "case_id": case_ids[flat // (2 * m)],
        "participant": (flat // m) % 2 + 1,
        "t": (flat % m) * dt,
    }
    for name in _SAMPLE_FIELDS:
        traj[name] = batch.samples[name].reshape(-1)[flat]
    trajectories = pd.DataFrame(traj, copy=False)
    rows = np.arange(n)
    design: dict[str, object] = {
        "case_id": case_ids, "accident_type": batch.types, "collision": ~batch.near,
        "attempts": attempts, "design_draws": batch.design_draws,
        "plausible": batch.plausible,
        "t_star": batch.k_star * dt, "road_friction": batch.mu, "wet": batch.wet,
        "road_curvature": batch.curvature,
    }
    yaw_at = []
    for i in range(2):
        p = batch.parts[i]
        s = {f: batch.samples[f][:, i] for f in _SAMPLE_FIELDS}
        braking = p["brake_time"] < 0.5 * NO_BRAKE
        k = batch.k_star
        yaw_at.append(s["yaw"][rows, k])
        j = str(i + 1)
        design.update({
            "x" + j: s["x"][rows, k], "y" + j: s["y"][rows, k],
            "yaw" + j: wrap_angle(s["yaw"][rows, k]),
            "brake" + j: braking,
            "brake_start" + j: np.where(braking, k * dt + p["brake_time"], np.nan),
            "brake_deceleration" + j: np.where(braking, p["decel"], np.nan),
            "brake_jerk" + j: np.where(braking, p["jerk"], np.nan),
            "heading_offset" + j: heading_offset(
                {f: p[f] for f in PART_FIELDS}, np.zeros(n)),
            "segment" + j: np.array([c.name for c in FLEET])[batch.segment[i]],
        })
    design["relative_heading"] = wrap_angle(yaw_at[1] - yaw_at[0])
    for name in sorted(batch.extra):
        design.setdefault(name, batch.extra[name])
    for key in ("evasive1", "evasive2", "standing2"):
        design.setdefault(key, np.zeros(n, dtype=bool))
    design.update(scene_rotation=batch.scene[:, 0], scene_x=batch.scene[:, 1],
                  scene_y=batch.scene[:, 2], contact_time=replay.contact_time,
                  min_distance=np.where(replay.collided, 0.0, replay.min_distance))
    return SceneTables(normalise_table(cases, "cases"),
                       normalise_table(participants, "participants"),
                       trajectories,
                       pd.DataFrame(design))


def _type_code(code: object) -> int:
    """Accident-type code as int; ParameterError unless an integer in [100, 799]."""
    ok = isinstance(code, int | np.integer) and not isinstance(code, bool)
    if not ok or not 100 <= int(code) <= 799:
        raise ParameterError(f"accident type {code!r} must be an integer code in [100, 799]")
    return int(code)


def generate_scenes(n: int, rng: np.random.Generator, type_shares: Mapping[int, float], *,
                    specs: Mapping[int, ScenarioSpec] | None = None,
                    near_miss_share: float = 0.0, wet_share: float = 0.3,
                    sample_interval: float = 0.01, first_case_id: int = 1) -> SceneTables:
    """Generate n synthetic accident scenes (vehicles, road, pre-crash trajectories).

    Parameters
    ----------
    n : int
        Number of cases (>= 0).
    rng : numpy.random.Generator
        The only source of randomness; the result is a deterministic function of its state.
    type_shares : mapping of int to float
        Accident-type code -> share [-] (normalised by the sum).  Case counts are n times
        the shares, rounded by the largest-remainder method; the order of the cases is
        shuffled.
    specs : mapping of int to ScenarioSpec, optional
        Overrides or additions to :data:`SCENARIO_TYPES`.
    near_miss_share : float
        Share of near misses in each type [-] (lateral gap instead of overlap;
        collision=False).  Counts per type are rounded.
    wet_share : float
        Probability of a wet road [-]: friction U(0.4, 0.65), else dry U(0.7, 1.0).
    sample_interval : float
        Trajectory sample spacing [s], in (0, 0.1].  t* is a multiple of it in [5, 6] s;
        records run from t = 0 to 0.3 s (near misses 1.0 s) after t*.
    first_case_id : int
        case_id of the first case; the others follow consecutively.

    Returns
    -------
    SceneTables
        Normalised tables cases, participants, trajectories (valid for
        :func:`vfs.database.validate_database` without reconstruction) and the design
        table.

    Raises
    ------
    ParameterError
        For invalid arguments.
    SimulationError
        If cases still fail the replay check after :data:`MAX_ATTEMPTS` draws.
    """
    n = check_count(n)
    check_rng(rng)
    merged: dict[int, ScenarioSpec] = dict(SCENARIO_TYPES)
    if specs is not None:
        if not isinstance(specs, Mapping):
            raise ParameterError("specs must be a mapping code -> ScenarioSpec")
        for code, spec in specs.items():
            if not isinstance(spec, ScenarioSpec):
                raise ParameterError(f"specs[{code!r}] must be a ScenarioSpec")
            merged[_type_code(code)] = spec
    if not isinstance(type_shares, Mapping) or not type_shares:
        raise ParameterError("type_shares must be a non-empty mapping code -> share")
    share_of: dict[int, float] = {}
    for code, share in type_shares.items():
        if not isinstance(share, int | float | np.integer | np.floating):
            raise ParameterError(f"type_shares[{code!r}]={share!r} is not a number")
        share_of[_type_code(code)] = float(share)
    codes = sorted(share_of)
    unknown = [c for c in codes if c not in merged]
    if unknown:
        raise ParameterError(f"unknown accident types {unknown}; known: {sorted(merged)}")
    shares = np.array([share_of[c] for c in codes])
    if not (np.isfinite(shares).all() and (shares >= 0).all() and shares.sum() > 0):
        raise ParameterError(f"type shares {shares.tolist()} must be >= 0 with a positive sum")
    for name, value in (("near_miss_share", near_miss_share), ("wet_share", wet_share)):
        check_share(name, value)
    if not (isinstance(sample_interval, int | float) and 1e-4 <= sample_interval <= 0.1):
        raise ParameterError(f"sample_interval={sample_interval!r} s must lie in "
                             "[0.0001, 0.1]")
    if isinstance(first_case_id, bool) or not isinstance(first_case_id, int | np.integer):
        raise ParameterError(f"first_case_id={first_case_id!r} must be an integer")
    dt = float(sample_interval)

    counts = _largest_remainder(n, shares)
    types = rng.permutation(np.repeat(np.array(codes, dtype=np.int64), counts))
    near = np.zeros(n, dtype=bool)
    for code, count in zip(codes, counts, strict=True):
        idx = np.flatnonzero(types == code)
        k = int(round(count * near_miss_share))
        near[rng.permutation(idx)[:k]] = True
    m = (math.floor(T_STAR_RANGE[1] / dt + 1e-9) + math.ceil(AFTER_NEAR_MISS / dt - 1e-9)
         + 1)
    batch = _Batch(types, near, m)
    case_ids = first_case_id + np.arange(n, dtype=np.int64)
    attempts = np.zeros(n, dtype=np.int64)
    replay = _Replay(np.zeros(n, bool), np.full(n, np.nan), np.full(n, np.nan))
    pending = np.arange(n)
    for attempt in range(1, MAX_ATTEMPTS + 1):
        if pending.size == 0:
            break
        _draw(batch, pending, rng, merged, wet_share, dt)
        attempts[pending] = attempt
        res = _replay(batch, pending, dt)
        for full, part in zip(replay, res, strict=True):
            full[pending] = part
        t_star = batch.k_star[pending] * dt
        crash_ok = res.collided & (np.abs(res.contact_time - t_star) <= CONTACT_TIME_TOLERANCE)
        miss_ok = ~res.collided & (res.min_distance >= MIN_NEAR_MISS_DISTANCE)
        good = np.where(batch.near[pending], miss_ok, crash_ok)
        pending = pending[~good]
    if pending.size:
        raise SimulationError(
            f"{pending.size} case(s) failed the replay check after {MAX_ATTEMPTS} draws: "
            f"case_id {case_ids[pending][:50].tolist()}")
    return _tables(batch, merged, case_ids, dt, attempts, replay)
