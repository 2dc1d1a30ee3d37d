"""Synthetic accident scenes: vehicles, road and pre-crash trajectories by accident type.

This module builds the *scenes* of a synthetic accident database: two passenger cars per
case (:data:`FLEET`), the road (friction, surface, curvature) and PreCrash-Matrix-like
trajectories of both participants that collide at a designed time t* (or pass each other
at a designed lateral gap, for near misses).  Reconstructions (impact outcomes) are not
computed here.  Everything is SI inside (m, s, kg, rad, m/s); speeds given in km/h in the
documentation are converted where the defaults are defined.

Accident types (codes of the German/Austrian accident-type catalogue, :data:`SCENARIO_TYPES`;
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
   in closed form (:func:`_motion`); after t* the braking continues (speed >= 0).  The
   distance before the impact sigma(t) = X(t*) - X(t) is exact.
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
   touch (:func:`_slide_to_contact`: ray casting of the corners of each rectangle against
   the edges of the other).  Near misses get a lateral gap instead and are placed where
   the outlines are about to pass each other.
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
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pandas as pd

from vfs.database.schema import normalise_table
from vfs.errors import ParameterError, SimulationError
from vfs.physics.geometry import outline_corners
from vfs.physics.paths import pack_paths
from vfs.physics.precrash import PrecrashParams, simulate_precrash
from vfs.physics.vehicle import VehicleArrays, vehicle_arrays
from vfs.units import KMH_PER_MS, G, wrap_angle

__all__ = [
    "FLEET",
    "SCENARIO_TYPES",
    "FleetClass",
    "ScenarioSpec",
    "SceneTables",
    "generate_scenes",
    "sample_fleet",
]

#: Lane width [m].
LANE_WIDTH = 3.5
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
#: Brake start [s after t*] used for participants that do not brake (never reached).
NO_BRAKE = 1.0e3
#: Default jerk [m/s^3] and deceleration [m/s^2] stored for participants that do not brake.
_IDLE_JERK, _IDLE_DECEL = 50.0, 6.0
#: Share of the road friction usable for lateral acceleration of manoeuvres [-].
_LATERAL_FRICTION_SHARE = 0.8


def _kmh(lo: float, hi: float) -> tuple[float, float]:
    """Speed range [km/h] -> [m/s]."""
    return (lo / KMH_PER_MS, hi / KMH_PER_MS)


def _deg(lo: float, hi: float) -> tuple[float, float]:
    """Angle range [deg] -> [rad]."""
    return (math.radians(lo), math.radians(hi))


def _check_range(name: str, value: object, lo: float = -math.inf,
                 hi: float = math.inf) -> None:
    ok = (isinstance(value, tuple) and len(value) == 2
          and all(isinstance(v, int | float) and math.isfinite(v) for v in value))
    if not ok or not lo <= value[0] <= value[1] <= hi:  # type: ignore[index]
        raise ParameterError(f"{name}={value!r} must be a (low, high) pair with "
                             f"{lo:g} <= low <= high <= {hi:g}")


def _check_share(name: str, value: object) -> None:
    if not (isinstance(value, int | float) and 0.0 <= value <= 1.0):
        raise ParameterError(f"{name}={value!r} must be a share in [0, 1]")



# ----------------------------------------------------------------------------
# Fleet
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class FleetClass:
    """One passenger-car segment of the fleet: share and parameter ranges (SI units).

    Each vehicle draws one size quantile q ~ U(0, 1); every parameter takes the quantile
    0.75 q + 0.25 u (u ~ U(0, 1) per parameter) of its range, so big cars are long, wide
    and heavy together while the parameters are not perfectly correlated.

    Attributes
    ----------
    name : str
        Segment name.
    share : float
        Share of the segment in the fleet [-] (shares are normalised over :data:`FLEET`).
    mass : tuple of float
        Mass range [kg] (kerb mass plus driver).
    length, width : tuple of float
        Outline length and width ranges [m].
    wheelbase : tuple of float
        Wheelbase range [m].
    front_overhang : tuple of float
        Front axle to front bumper [m].
    cg_ratio : tuple of float
        CG to front axle as a share of the wheelbase [-] (< 0.5: more load on the
        front axle).
    track_margin : tuple of float
        Width minus track width [m].
    cg_height : tuple of float
        Height of the CG [m].
    """

    name: str
    share: float
    mass: tuple[float, float]
    length: tuple[float, float]
    width: tuple[float, float]
    wheelbase: tuple[float, float]
    front_overhang: tuple[float, float]
    cg_ratio: tuple[float, float]
    track_margin: tuple[float, float] = (0.2, 0.3)
    cg_height: tuple[float, float] = (0.50, 0.58)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.share) and self.share >= 0.0):
            raise ParameterError(f"fleet class {self.name!r}: share={self.share} must be >= 0")
        for name in ("mass", "length", "width", "wheelbase", "front_overhang", "cg_ratio",
                     "track_margin", "cg_height"):
            _check_range(f"fleet class {self.name!r} {name}", getattr(self, name), lo=0.0)
        if self.front_overhang[1] + self.wheelbase[1] >= self.length[0]:
            raise ParameterError(f"fleet class {self.name!r}: front overhang + wheelbase "
                                 "must fit in the shortest length")
        if self.cg_ratio[1] >= 1.0 or self.track_margin[0] <= 0.0:
            raise ParameterError(f"fleet class {self.name!r}: cg_ratio must be < 1 and "
                                 "track_margin > 0")


#: Passenger-car fleet by segment.  Shares approximate the German passenger-car stock by
#: segment (KBA statistics, rounded; SUVs, off-roaders and vans together); parameter
#: ranges are typical of current models of each segment.  Overall masses 820-2600 kg.
FLEET: tuple[FleetClass, ...] = (
    FleetClass("mini", 0.07, mass=(820.0, 1100.0), length=(3.40, 3.75), width=(1.57, 1.68),
               wheelbase=(2.30, 2.50), front_overhang=(0.62, 0.75), cg_ratio=(0.38, 0.43),
               cg_height=(0.50, 0.56)),
    FleetClass("small", 0.18, mass=(1050.0, 1350.0), length=(3.80, 4.15), width=(1.66, 1.78),
               wheelbase=(2.45, 2.60), front_overhang=(0.70, 0.82), cg_ratio=(0.38, 0.44),
               cg_height=(0.51, 0.57)),
    FleetClass("compact", 0.24, mass=(1250.0, 1600.0), length=(4.15, 4.50),
               width=(1.75, 1.85), wheelbase=(2.60, 2.75), front_overhang=(0.80, 0.92),
               cg_ratio=(0.39, 0.45), cg_height=(0.52, 0.58)),
    FleetClass("mid-size", 0.15, mass=(1450.0, 1800.0), length=(4.50, 4.90),
               width=(1.80, 1.88), wheelbase=(2.70, 2.90), front_overhang=(0.85, 0.98),
               cg_ratio=(0.41, 0.46), cg_height=(0.52, 0.58)),
    FleetClass("large/executive", 0.08, mass=(1700.0, 2200.0), length=(4.90, 5.25),
               width=(1.85, 1.95), wheelbase=(2.90, 3.10), front_overhang=(0.88, 1.02),
               cg_ratio=(0.44, 0.48), cg_height=(0.53, 0.59)),
    FleetClass("SUV/van", 0.28, mass=(1450.0, 2600.0), length=(4.30, 5.00),
               width=(1.80, 2.00), wheelbase=(2.60, 3.00), front_overhang=(0.85, 1.00),
               cg_ratio=(0.42, 0.47), cg_height=(0.62, 0.75)),
)

#: Columns returned by :func:`sample_fleet` (table participants without the keys).
FLEET_COLUMNS = ("mass", "yaw_inertia", "length", "width", "wheelbase", "cg_to_front_axle",
                 "front_overhang", "track_width", "cg_height", "vehicle_class")
#: Weight of the vehicle's size quantile in each parameter's quantile [-].
_SIZE_CORRELATION = 0.75


def _check_rng(rng: object) -> None:
    if not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")


def _check_count(n: object, name: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
        raise ParameterError(f"{name}={n!r} must be an integer >= 0")
    return int(n)


def _sample_fleet_arrays(n: int, rng: np.random.Generator,
                         fleet: tuple[FleetClass, ...] = FLEET
                         ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Vehicle parameters (SI) of n cars as column arrays, and their segment indices."""
    shares = np.array([c.share for c in fleet], float)
    segment = rng.choice(len(fleet), size=n, p=shares / shares.sum())
    size_q = rng.random(n)
    fields = ("mass", "length", "width", "wheelbase", "front_overhang", "cg_ratio",
              "track_margin", "cg_height")
    quantile = (_SIZE_CORRELATION * size_q[:, None]
                + (1.0 - _SIZE_CORRELATION) * rng.random((n, len(fields))))
    lo = np.array([[getattr(c, f)[0] for f in fields] for c in fleet])[segment]
    hi = np.array([[getattr(c, f)[1] for f in fields] for c in fleet])[segment]
    values = dict(zip(fields, (lo + quantile * (hi - lo)).T, strict=True))
    wheelbase = values["wheelbase"]
    cols = {
        "mass": values["mass"],
        "yaw_inertia": np.full(n, np.nan),
        "length": values["length"],
        "width": values["width"],
        "wheelbase": wheelbase,
        "cg_to_front_axle": values["cg_ratio"] * wheelbase,
        "front_overhang": values["front_overhang"],
        "track_width": values["width"] - values["track_margin"],
        "cg_height": values["cg_height"],
    }
    return cols, segment


def sample_fleet(n: int, rng: np.random.Generator) -> pd.DataFrame:
    """Draw n passenger cars from :data:`FLEET`.

    Parameters
    ----------
    n : int
        Number of vehicles (>= 0).
    rng : numpy.random.Generator
        Source of randomness.

    Returns
    -------
    pandas.DataFrame
        One row per vehicle with the columns of table ``participants`` except
        ``case_id`` and ``participant``: mass [kg], yaw_inertia [kg m^2] (NaN = unknown,
        the default formula of :mod:`vfs.physics.vehicle` applies), length, width, wheelbase,
        cg_to_front_axle, front_overhang, track_width, cg_height [m] and vehicle_class
        ("car").  Every row satisfies :func:`vfs.physics.vehicle.validate_vehicle_values`.
    """
    n = _check_count(n)
    _check_rng(rng)
    cols, _ = _sample_fleet_arrays(n, rng)
    frame = pd.DataFrame(cols)
    frame["vehicle_class"] = "car"
    return frame[list(FLEET_COLUMNS)]


# ----------------------------------------------------------------------------
# Scenario specifications
# ----------------------------------------------------------------------------

#: Scene constructions known to :func:`generate_scenes` (:attr:`ScenarioSpec.kind`).
KINDS = ("head_on", "overtaking", "rear_end", "crossing", "left_turn")


@dataclass(frozen=True)
class ScenarioSpec:
    """Distributions of the scene parameters of one accident type (SI units).

    Ranges are (low, high) pairs of uniform distributions.  Change a preset with
    :func:`dataclasses.replace`, e.g. ``replace(SCENARIO_TYPES[241],
    speed1=(20.0, 35.0))``.

    Attributes
    ----------
    name : str
        Short name.
    kind : str
        Scene construction, one of :data:`KINDS`: 'head_on' (participant 1 drifts into
        the oncoming lane), 'overtaking', 'rear_end', 'crossing', 'left_turn'.
    description : str
        Text of the cases table (near-miss, evasion and road notes are added).
    bend : int
        Road of head-on types: 0 straight, +1 left bend, -1 right bend (seen by
        participant 1).
    speed1, speed2 : tuple of float
        Travel speeds [m/s] of participants 1 and 2 before any braking.
    standing2_share : float
        Share of cases in which participant 2 stands still throughout [-] (rear-end).
    min_closing_speed : float
        Smallest closing speed at the impact [m/s] (rear-end: follower faster than the
        lead, at the impact and before the braking).
    min_impact_speed_share : float
        Late braking leaves each participant at least this share of its travel speed [-]
        (a late brake does not stop the car before the impact; the standing lead of a
        rear-end excepted).
    brake_prob : tuple of float
        Probability that participant 1 / 2 brakes late [-].
    brake_lead_time : tuple of float
        Brake start before t* [s].
    brake_jerk : tuple of float
        Deceleration build-up [m/s^3].
    brake_deceleration : tuple of float
        Target deceleration [m/s^2], limited to road_friction * g.
    evasive_prob : tuple of float
        Probability of evasive steering of participant 1 / 2 [-] (participant 1: only
        the late swerve of a rear-end follower; near-miss rear-ends always swerve).
    evasive_angle : tuple of float
        Heading offset at the impact of evasive steering [rad] (narrowed at high speed
        by ``max_lateral_accel``).
    evasive_time : tuple of float
        Time over which the evasive offset (and the overtaker's steer-back) builds up
        [s].
    heading_angle : tuple of float
        Head-on types: drift angle of participant 1 (its heading offset to the road at
        the impact) [rad]; overtaking: its steer-back angle.
    overlap : tuple of float
        Overlap of the faces perpendicular to the relative velocity as a share of the
        narrower face [-] (head-on: fronts, rear-end: front of 1 and rear of 2).
    near_miss_gap : tuple of float
        Lateral gap of near misses perpendicular to the relative velocity [m].
    bend_lateral_accel : tuple of float
        Bends: lateral acceleration of participant 1 at its travel speed on the road
        centreline [m/s^2], which sets the radius ...
    bend_radius : tuple of float
        ... clipped to this range [m].
    crossing_angle : tuple of float
        Crossing: angle between the headings [rad].
    crossing_from_right_share : float
        Crossing: share of cases with participant 2 coming from participant 1's right
        [-].
    impact_position : tuple of float
        Crossing: point of impact on participant 2's side as a share of its length from
        the rear [-]; left turn: on the turner's right side as a share of its length
        from the front [-].
    striker_offset : float
        Aimed point on the striking front (crossing, left turn) within +- this share of
        the width from the centre of the front [-].
    turn_radius : tuple of float
        Left turn: radius of the turning arc of participant 1 [m].
    turn_angle : tuple of float
        Left turn: heading change of the turner at the impact [rad].
    turner_lane : tuple of float
        Left turn: allowed lateral position of the turner's CG before the turn [m] (road
        centreline 0, own lane centre -1.75); draws outside are redrawn.
    lane_change_time : tuple of float
        Overtaking: duration of participant 1's lane change into the oncoming lane [s].
    lane_change_gap : tuple of float
        Overtaking: time between the end of the lane change and the start of the
        steer-back [s].
    lane_change_width : tuple of float
        Overtaking: allowed lateral shift of participant 1 by its lane change [m]
        (from its lane position to the oncoming lane plus what the steer-back takes
        back); draws outside are redrawn.
    swerve_left_share : float
        Rear-end: share of left swerves of the follower [-].
    lane_offset : float
        Lateral position in the lane before any manoeuvre: lane centre +- this [m].
    max_lateral_accel : float
        Upper bound of the lateral acceleration of drifts, evasive steering and turns
        [m/s^2] (also at most 0.8 road_friction g).
    """

    name: str
    kind: str
    description: str
    bend: int = 0
    speed1: tuple[float, float] = _kmh(50.0, 100.0)
    speed2: tuple[float, float] = _kmh(50.0, 100.0)
    standing2_share: float = 0.0
    min_closing_speed: float = 1.0
    min_impact_speed_share: float = 0.3
    brake_prob: tuple[float, float] = (0.4, 0.4)
    brake_lead_time: tuple[float, float] = (0.2, 1.5)
    brake_jerk: tuple[float, float] = (40.0, 60.0)
    brake_deceleration: tuple[float, float] = (4.0, 9.0)
    evasive_prob: tuple[float, float] = (0.0, 0.3)
    evasive_angle: tuple[float, float] = _deg(2.0, 10.0)
    evasive_time: tuple[float, float] = (0.5, 1.0)
    heading_angle: tuple[float, float] = _deg(1.0, 12.0)
    overlap: tuple[float, float] = (0.1, 1.0)
    near_miss_gap: tuple[float, float] = (0.2, 1.5)
    bend_lateral_accel: tuple[float, float] = (1.5, 4.0)
    bend_radius: tuple[float, float] = (60.0, 800.0)
    crossing_angle: tuple[float, float] = _deg(70.0, 110.0)
    crossing_from_right_share: float = 0.5
    impact_position: tuple[float, float] = (0.1, 0.9)
    striker_offset: float = 0.3
    turn_radius: tuple[float, float] = (8.0, 15.0)
    turn_angle: tuple[float, float] = _deg(15.0, 75.0)
    turner_lane: tuple[float, float] = (-2.6, -0.2)
    lane_change_time: tuple[float, float] = (3.0, 5.0)
    lane_change_gap: tuple[float, float] = (0.0, 1.5)
    lane_change_width: tuple[float, float] = (2.0, 5.0)
    swerve_left_share: float = 0.7
    lane_offset: float = 0.4
    max_lateral_accel: float = 5.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ParameterError(f"scenario {self.name!r}: kind={self.kind!r} is not one of "
                                 f"{KINDS}")
        if self.bend not in (-1, 0, 1):
            raise ParameterError(f"scenario {self.name!r}: bend={self.bend!r} must be -1, 0 "
                                 "or 1")
        where = f"scenario {self.name!r}"
        for name in ("speed1", "speed2"):
            _check_range(f"{where} {name}", getattr(self, name), lo=0.0, hi=100.0)
        _check_range(f"{where} brake_lead_time", self.brake_lead_time, lo=0.0, hi=4.0)
        _check_range(f"{where} brake_jerk", self.brake_jerk, lo=1.0)
        _check_range(f"{where} brake_deceleration", self.brake_deceleration, lo=0.5, hi=15.0)
        _check_range(f"{where} evasive_angle", self.evasive_angle, lo=0.0, hi=0.6)
        _check_range(f"{where} evasive_time", self.evasive_time, lo=0.1, hi=4.0)
        _check_range(f"{where} heading_angle", self.heading_angle, lo=1e-3, hi=0.6)
        _check_range(f"{where} overlap", self.overlap, lo=0.0, hi=1.0)
        _check_range(f"{where} near_miss_gap", self.near_miss_gap, lo=0.15, hi=10.0)
        _check_range(f"{where} bend_lateral_accel", self.bend_lateral_accel, lo=0.05)
        _check_range(f"{where} bend_radius", self.bend_radius, lo=10.0)
        _check_range(f"{where} crossing_angle", self.crossing_angle, lo=0.2, hi=math.pi - 0.2)
        _check_range(f"{where} impact_position", self.impact_position, lo=0.0, hi=1.0)
        _check_range(f"{where} turn_radius", self.turn_radius, lo=3.0)
        _check_range(f"{where} turn_angle", self.turn_angle, lo=0.05, hi=math.pi / 2)
        _check_range(f"{where} turner_lane", self.turner_lane)
        _check_range(f"{where} lane_change_time", self.lane_change_time, lo=0.5)
        _check_range(f"{where} lane_change_gap", self.lane_change_gap, lo=0.0)
        _check_range(f"{where} lane_change_width", self.lane_change_width, lo=0.1)
        for name in ("brake_prob", "evasive_prob"):
            pair = getattr(self, name)
            if not (isinstance(pair, tuple) and len(pair) == 2):
                raise ParameterError(f"{where} {name}={pair!r} must be a pair of shares")
            for p in pair:
                _check_share(f"{where} {name}", p)
        for name in ("standing2_share", "min_impact_speed_share", "crossing_from_right_share",
                     "swerve_left_share", "striker_offset"):
            _check_share(f"{where} {name}", getattr(self, name))
        for name, lo, hi in (("min_closing_speed", 0.1, 50.0), ("lane_offset", 0.0, 1.5),
                             ("max_lateral_accel", 0.5, 15.0)):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and lo <= value <= hi):
                raise ParameterError(f"{where} {name}={value!r} outside [{lo:g}, {hi:g}]")


_HEAD_ON = dict(speed1=_kmh(60.0, 110.0), speed2=_kmh(50.0, 100.0), brake_prob=(0.3, 0.5),
                evasive_prob=(0.0, 0.3), overlap=(0.1, 1.0))

#: The accident types by code of the German/Austrian accident-type catalogue.
SCENARIO_TYPES: dict[int, ScenarioSpec] = {
    241: ScenarioSpec("head-on, straight road", "head_on",
                      "head-on on a straight road: participant 1 drifted into the oncoming "
                      "lane", **_HEAD_ON),  # type: ignore[arg-type]
    242: ScenarioSpec("head-on in a bend", "head_on",
                      "head-on in a right bend: participant 1 was carried out of the bend "
                      "into the oncoming lane", bend=-1, **_HEAD_ON),  # type: ignore[arg-type]
    243: ScenarioSpec("head-on in a bend, corner cut", "head_on",
                      "head-on in a left bend: participant 1 cut the corner into the "
                      "oncoming lane", bend=1, **_HEAD_ON),  # type: ignore[arg-type]
    264: ScenarioSpec("head-on while overtaking", "overtaking",
                      "head-on while overtaking: participant 1 overtook in the oncoming lane "
                      "and met participant 2", speed1=_kmh(80.0, 130.0),
                      speed2=_kmh(60.0, 100.0), brake_prob=(0.5, 0.5),
                      evasive_prob=(0.0, 0.3), evasive_time=(0.5, 1.2),
                      heading_angle=_deg(1.0, 12.0)),
    601: ScenarioSpec("rear-end", "rear_end",
                      "rear-end: participant 1 ran into participant 2 ahead in the same lane",
                      speed1=_kmh(40.0, 100.0), speed2=_kmh(5.0, 60.0), standing2_share=0.3,
                      min_closing_speed=2.0, brake_prob=(0.6, 0.4), evasive_prob=(0.2, 0.15),
                      evasive_angle=_deg(2.0, 7.0), overlap=(0.3, 1.0)),
    321: ScenarioSpec("crossing at a junction", "crossing",
                      "crossing paths at a junction: participant 1 struck the side of "
                      "participant 2", speed1=_kmh(25.0, 70.0), speed2=_kmh(25.0, 70.0),
                      brake_prob=(0.4, 0.4), evasive_prob=(0.0, 0.0),
                      impact_position=(0.1, 0.9)),
    211: ScenarioSpec("left turn, oncoming", "left_turn",
                      "left turn: participant 1 turned left across the path of oncoming "
                      "participant 2", speed1=_kmh(10.0, 30.0), speed2=_kmh(40.0, 90.0),
                      brake_prob=(0.3, 0.5), evasive_prob=(0.0, 0.2),
                      impact_position=(0.0, 0.6), striker_offset=0.35),
}


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
# Speed profiles
# ----------------------------------------------------------------------------


def _brake_ramp(s: np.ndarray, jerk: np.ndarray, decel: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Speed [m/s] and distance [m] taken off by braking for s [s] >= 0 after its start.

    The deceleration rises with ``jerk`` [m/s^3] to ``decel`` [m/s^2] (after s_r =
    decel / jerk) and stays there.
    """
    s_r = decel / jerk
    ramp = s <= s_r
    dv = np.where(ramp, 0.5 * jerk * s**2, decel * (s - 0.5 * s_r))
    dx = np.where(ramp, jerk * s**3 / 6.0,
                  0.5 * decel * s**2 - 0.5 * decel * s_r * s + decel * s_r**2 / 6.0)
    return dv, dx


def _brake_time_for_drop(drop: np.ndarray, jerk: np.ndarray, decel: np.ndarray) -> np.ndarray:
    """Braking time [s] that takes ``drop`` [m/s] off the speed (inverse of the ramp)."""
    s_r = decel / jerk
    return np.where(drop <= 0.5 * decel * s_r, np.sqrt(2.0 * np.maximum(drop, 0.0) / jerk),
                    drop / decel + 0.5 * s_r)


def _motion(tau: np.ndarray, v_travel: np.ndarray, brake_time: np.ndarray,
            jerk: np.ndarray, decel: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed-form longitudinal motion at times tau [s, relative to t*].

    Parameters
    ----------
    tau : ndarray
        Times relative to the designed impact [s] (broadcast with the others).
    v_travel : ndarray
        Travel speed before braking [m/s].
    brake_time : ndarray
        Brake start relative to t* [s] (:data:`NO_BRAKE` = never).
    jerk, decel : ndarray
        Brake build-up [m/s^3] and deceleration level [m/s^2].

    Returns
    -------
    position : ndarray
        Distance travelled [m] relative to the brake start (any fixed reference).
    speed : ndarray
        Speed [m/s] (>= 0; a braked vehicle stays at rest).
    accel : ndarray
        Longitudinal acceleration [m/s^2] (negative while braking).
    """
    s_stop = _brake_time_for_drop(v_travel, jerk, decel)
    s = tau - brake_time
    sc = np.clip(s, 0.0, s_stop)
    dv, dx = _brake_ramp(sc, jerk, decel)
    position = v_travel * np.minimum(s, s_stop) - dx
    speed = np.maximum(v_travel - dv, 0.0)
    accel = np.where((s > 0.0) & (s < s_stop), -np.minimum(jerk * s, decel), 0.0)
    return position, speed, accel


class _Motion(NamedTuple):
    """Speed-profile parameters of n participants (arrays (n,))."""

    v_travel: np.ndarray  # [m/s]
    brake_time: np.ndarray  # brake start relative to t* [s], NO_BRAKE if none
    jerk: np.ndarray  # [m/s^3]
    decel: np.ndarray  # [m/s^2]

    @property
    def braking(self) -> np.ndarray:
        return self.brake_time < 0.5 * NO_BRAKE

    def at(self, tau: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position [m], speed [m/s] and acceleration [m/s^2] at tau [s, relative to t*]."""
        return _motion(np.asarray(tau, float), self.v_travel, self.brake_time, self.jerk,
                       self.decel)

    def speed_at(self, tau: np.ndarray | float) -> np.ndarray:
        """Speed [m/s] at tau [s, relative to t*]."""
        return self.at(tau)[1]

    def distance_before(self, lead: np.ndarray | float) -> np.ndarray:
        """Distance [m] covered in the ``lead`` [s] before t*."""
        return self.at(0.0)[0] - self.at(-np.asarray(lead, float))[0]


def _draw_motion(rng: np.random.Generator, n: int, speed: tuple[float, float],
                 brake_prob: float, spec: ScenarioSpec, mu: np.ndarray,
                 min_share: float) -> _Motion:
    """Travel speeds and late braking of n participants."""
    v = rng.uniform(speed[0], speed[1], n)
    brake = rng.random(n) < brake_prob
    lead = rng.uniform(*spec.brake_lead_time, n)
    jerk = rng.uniform(*spec.brake_jerk, n)
    decel = np.minimum(rng.uniform(*spec.brake_deceleration, n), mu * G)
    # a late brake leaves at least min_share of the travel speed at t*
    lead = np.minimum(lead, _brake_time_for_drop(v * (1.0 - min_share), jerk, decel))
    brake &= (v > 0.0) & (lead > 1e-3)
    return _Motion(v, np.where(brake, -lead, NO_BRAKE), np.where(brake, jerk, _IDLE_JERK),
                   np.where(brake, decel, _IDLE_DECEL))


def _capped(u: np.ndarray, bounds: tuple[float, float], cap: np.ndarray) -> np.ndarray:
    """Uniform draw (quantile u) from [lo, min(hi, cap)]; cap where cap < lo."""
    lo, hi = bounds
    top = np.minimum(hi, cap)
    return np.where(top >= lo, lo + u * (top - lo), np.maximum(top, 0.0))


def _ramp_cap(distance: np.ndarray, speed: np.ndarray, a_lat: np.ndarray) -> np.ndarray:
    """Largest ramp amplitude [rad] over ``distance`` [m] at ``speed`` [m/s] within a_lat.

    The raised cosine A (1 + cos(pi sigma / S)) / 2 has the largest curvature A pi / (2 S),
    so the lateral acceleration v^2 A pi / (2 S) stays below a_lat [m/s^2].
    """
    with np.errstate(divide="ignore"):
        return np.where(speed > 0.1, 2.0 * a_lat * distance / (np.pi * speed**2), np.inf)


# ----------------------------------------------------------------------------
# Manoeuvres (heading offset to the road) and roads
# ----------------------------------------------------------------------------

#: Per-participant parameters of a scene, in the order of the arrays of a batch.
_PART_FIELDS = (
    "v_travel", "brake_time", "jerk", "decel",
    "road_x", "road_y", "road_theta", "road_k", "direction", "u_star", "l_star",
    "ramp_angle", "ramp_dist", "bump_angle", "bump_start", "bump_dist",
    "turn_curv", "turn_dist",
)
_PART_DEFAULTS = {"brake_time": NO_BRAKE, "jerk": _IDLE_JERK, "decel": _IDLE_DECEL,
                  "direction": 1.0, "ramp_dist": 1.0, "bump_dist": 1.0}


def _new_part(n: int) -> dict[str, np.ndarray]:
    return {f: np.full(n, _PART_DEFAULTS.get(f, 0.0)) for f in _PART_FIELDS}


def _heading_offset(p: Mapping[str, np.ndarray], sigma: np.ndarray) -> np.ndarray:
    """Heading offset to the road [rad] at distances ``sigma`` [m] before the impact.

    Sum of a raised-cosine ramp (amplitude ``ramp_angle`` reached at the impact, built
    over ``ramp_dist`` [m], held after the impact), a sin^2 bump (``bump_angle`` between
    ``bump_start`` and ``bump_start + bump_dist`` [m] before the impact) and a turning arc
    (curvature ``turn_curv`` [1/m] over the last ``turn_dist`` [m] before the impact,
    continued after it up to a heading change of 90 deg).
    """
    x = np.clip(sigma / np.maximum(p["ramp_dist"], 1e-6), 0.0, 1.0)
    phi = p["ramp_angle"] * 0.5 * (1.0 + np.cos(np.pi * x))
    xb = (sigma - p["bump_start"]) / np.maximum(p["bump_dist"], 1e-6)
    phi = phi + np.where((xb > 0.0) & (xb < 1.0), p["bump_angle"] * np.sin(np.pi * xb) ** 2,
                         0.0)
    curv = p["turn_curv"]
    with np.errstate(divide="ignore", invalid="ignore"):
        quarter = np.where(curv > 0.0, 0.5 * np.pi / curv, 0.0)
    arc = np.clip(p["turn_dist"] - sigma, 0.0, quarter)
    return phi + curv * arc


def _road_point(k: np.ndarray, u: np.ndarray, l: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Road-frame point (x, y) [m] and road direction [rad] at curvilinear (u, l) [m].

    The centreline passes the origin in direction +x with curvature k [1/m] (positive =
    left); l is measured along its left normal.  Stable for k -> 0.
    """
    ku = k * u
    cx = u * np.sinc(ku / np.pi)  # sin(ku) / k
    cy = u * np.sin(0.5 * ku) * np.sinc(ku / (2.0 * np.pi))  # (1 - cos(ku)) / k
    return cx - l * np.sin(ku), cy + l * np.cos(ku), ku


def _road_coords(k: np.ndarray, x: np.ndarray, y: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Curvilinear (u, l) [m] of road-frame points (x, y) [m] (inverse of _road_point)."""
    straight = np.abs(k) < 1e-9
    kk = np.where(straight, 1.0, k)
    sign = np.sign(kk)
    rx, ry = x, y - 1.0 / kk
    rho = np.hypot(rx, ry)
    l = 1.0 / kk - sign * rho
    u = np.arctan2(rx * sign, -ry * sign) / kk
    return np.where(straight, x, u), np.where(straight, y, l)


# ----------------------------------------------------------------------------
# Contact placement
# ----------------------------------------------------------------------------


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _ray_hits(points: np.ndarray, direction: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Ray parameters where points + lam * direction cross the polygon edges.

    Parameters
    ----------
    points : ndarray (n, 4, 2)
        Ray origins [m].
    direction : ndarray (n, 2)
        Unit ray direction.
    polygon : ndarray (n, 4, 2)
        Polygon corners [m] (edge j from corner j to corner j + 1).

    Returns
    -------
    ndarray (n, 4, 4)
        lam [m] per (point, edge); inf where the ray misses the edge or runs parallel.
    """
    start = polygon[:, None, :, :]
    edge = np.roll(polygon, -1, axis=1)[:, None, :, :] - start
    d = direction[:, None, None, :]
    r = start - points[:, :, None, :]
    denom = _cross(d, edge)
    ok = np.abs(denom) > 1e-12 * np.hypot(edge[..., 0], edge[..., 1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        lam = _cross(r, edge) / denom
        mu = _cross(r, d) / denom
    hit = ok & (mu >= -1e-9) & (mu <= 1.0 + 1e-9)
    return np.where(hit, lam, np.inf)


def _slide_to_contact(fixed: np.ndarray, moving: np.ndarray,
                      direction: np.ndarray) -> np.ndarray:
    """Shift along ``direction`` at which ``moving`` first touches ``fixed``.

    ``moving`` translated by lam * direction touches ``fixed`` for lam in an interval;
    its lower end (first contact while moving along +direction) is the smallest lam at
    which a corner of one rectangle lies on an edge of the other: corners of ``moving``
    cast along +direction against the edges of ``fixed`` and corners of ``fixed`` along
    -direction against the edges of ``moving`` (32 ray-segment tests per pair).

    Parameters
    ----------
    fixed, moving : ndarray (n, 4, 2)
        Rectangle corners [m] (any consistent order around the rectangle).
    direction : ndarray (n, 2)
        Unit direction of the relative motion of ``moving``.

    Returns
    -------
    ndarray (n,)
        lam [m] (may be negative); NaN where the rectangles never touch along the line.
    """
    lam = np.concatenate([_ray_hits(moving, direction, fixed).reshape(len(fixed), -1),
                          _ray_hits(fixed, -direction, moving).reshape(len(fixed), -1)],
                         axis=1).min(axis=1)
    return np.where(np.isfinite(lam), lam, np.nan)


class _Dims(NamedTuple):
    """Outline of n vehicles relative to the CG [m] (arrays (n,))."""

    front: np.ndarray  # CG to front bumper
    rear: np.ndarray  # CG to rear bumper
    width: np.ndarray

    @property
    def length(self) -> np.ndarray:
        return self.front + self.rear


def _unit(angle: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def _corners(p: np.ndarray, yaw: np.ndarray, dims: _Dims) -> np.ndarray:
    return outline_corners(p[:, 0], p[:, 1], yaw, dims.front, dims.rear, dims.width)


def _rel_direction(yaw1: np.ndarray, v1: np.ndarray, yaw2: np.ndarray,
                   v2: np.ndarray) -> np.ndarray:
    """Unit direction of v2 - v1 (participant 2's motion relative to participant 1)."""
    w = v2[:, None] * _unit(yaw2) - v1[:, None] * _unit(yaw1)
    return w / np.maximum(np.hypot(w[:, 0], w[:, 1]), 1e-12)[:, None]


def _rect_extent(yaw: np.ndarray, dims: _Dims, axis: np.ndarray) -> np.ndarray:
    """Half extent [m] of outline rectangles projected on unit vectors ``axis`` (n, 2)."""
    t, n = _unit(yaw), _unit(yaw + 0.5 * np.pi)
    return (0.5 * dims.length * np.abs((t * axis).sum(axis=1))
            + 0.5 * dims.width * np.abs((n * axis).sum(axis=1)))


class _Pair(NamedTuple):
    """Impact poses and speeds of both participants of n cases (P1 at the origin)."""

    yaw1: np.ndarray  # [rad]
    v1: np.ndarray  # [m/s]
    dims1: _Dims
    yaw2: np.ndarray
    v2: np.ndarray
    dims2: _Dims


def _place_overlap(pair: _Pair, face2: float, share: np.ndarray,
                   side: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CG of participant 2 [m] (participant 1's CG at the origin) for a designed overlap.

    The front of participant 1 and the front (``face2`` = +1) or rear (-1) of participant
    2 overlap by ``share`` of the narrower face width, both projected perpendicular to the
    relative velocity; ``side`` +1 puts participant 2 to participant 1's left.  Then
    participant 2 slides along the relative velocity to first contact.  Returns the
    position and a flag (False where the rectangles can never touch).
    """
    d = _rel_direction(pair.yaw1, pair.v1, pair.yaw2, pair.v2)
    e = np.stack([-d[:, 1], d[:, 0]], axis=1)
    t1, n1 = _unit(pair.yaw1), _unit(pair.yaw1 + 0.5 * np.pi)
    t2, n2 = _unit(pair.yaw2), _unit(pair.yaw2 + 0.5 * np.pi)
    h1 = 0.5 * pair.dims1.width * np.abs((n1 * e).sum(axis=1))
    h2 = 0.5 * pair.dims2.width * np.abs((n2 * e).sum(axis=1))
    sep = h1 + h2 - share * 2.0 * np.minimum(h1, h2)
    sgn = side * np.where((n1 * e).sum(axis=1) >= 0.0, 1.0, -1.0)
    face1 = t1 * pair.dims1.front[:, None]
    offset2 = t2 * np.where(face2 > 0, pair.dims2.front, -pair.dims2.rear)[:, None]
    base = face1 + (sgn * sep)[:, None] * e - offset2
    return _slide(pair, base, d)


def _place_target(pair: _Pair, point1: np.ndarray,
                  point2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CG of participant 2 [m] aiming its point ``point2`` at participant 1's ``point1``.

    Points are given in the vehicle frames (n, 2) [m]; participant 2 then slides along the
    relative velocity to first contact.
    """
    d = _rel_direction(pair.yaw1, pair.v1, pair.yaw2, pair.v2)
    c1, s1 = np.cos(pair.yaw1), np.sin(pair.yaw1)
    c2, s2 = np.cos(pair.yaw2), np.sin(pair.yaw2)
    target = np.stack([c1 * point1[:, 0] - s1 * point1[:, 1],
                       s1 * point1[:, 0] + c1 * point1[:, 1]], axis=1)
    arm = np.stack([c2 * point2[:, 0] - s2 * point2[:, 1],
                    s2 * point2[:, 0] + c2 * point2[:, 1]], axis=1)
    return _slide(pair, target - arm, d)


def _slide(pair: _Pair, base: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = base.shape[0]
    fixed = _corners(np.zeros((n, 2)), pair.yaw1, pair.dims1)
    moving = _corners(base, pair.yaw2, pair.dims2)
    lam = _slide_to_contact(fixed, moving, d)
    ok = np.isfinite(lam)
    return base + np.where(ok, lam, 0.0)[:, None] * d, ok


def _place_gap(pair: _Pair, gap: np.ndarray, side: np.ndarray) -> np.ndarray:
    """CG of participant 2 [m] for a near miss with lateral ``gap`` [m].

    Perpendicular to the relative velocity the outlines are ``gap`` apart (participant 2
    on participant 1's left for ``side`` +1); along it they are about to pass each other
    (the projections just start to overlap), so that with straight relative motion the
    outlines pass at exactly ``gap``.
    """
    d = _rel_direction(pair.yaw1, pair.v1, pair.yaw2, pair.v2)
    e = np.stack([-d[:, 1], d[:, 0]], axis=1)
    t1, n1 = _unit(pair.yaw1), _unit(pair.yaw1 + 0.5 * np.pi)
    t2 = _unit(pair.yaw2)
    centre1 = t1 * (0.5 * (pair.dims1.front - pair.dims1.rear))[:, None]
    h = _rect_extent(pair.yaw1, pair.dims1, e) + _rect_extent(pair.yaw2, pair.dims2, e)
    k = _rect_extent(pair.yaw1, pair.dims1, d) + _rect_extent(pair.yaw2, pair.dims2, d)
    sgn = side * np.where((n1 * e).sum(axis=1) >= 0.0, 1.0, -1.0)
    centre2 = centre1 + (sgn * (h + gap))[:, None] * e - k[:, None] * d
    return centre2 - t2 * (0.5 * (pair.dims2.front - pair.dims2.rear))[:, None]


# ----------------------------------------------------------------------------
# Scene designers (one per kind)
# ----------------------------------------------------------------------------


class _Ctx(NamedTuple):
    """Inputs of a scene designer for n cases of one type."""

    rng: np.random.Generator
    spec: ScenarioSpec
    dims1: _Dims
    dims2: _Dims
    mu: np.ndarray  # road friction [-]
    near: np.ndarray  # near miss (bool)

    @property
    def n(self) -> int:
        return int(self.mu.shape[0])

    @property
    def a_lat(self) -> np.ndarray:
        """Lateral acceleration bound of manoeuvres [m/s^2]."""
        return np.minimum(self.spec.max_lateral_accel, _LATERAL_FRICTION_SHARE * self.mu * G)


class _Design(NamedTuple):
    """Scene of n cases in the local frame (P1's road frame), before the scene transform."""

    p1: dict[str, np.ndarray]
    p2: dict[str, np.ndarray]
    road_curvature: np.ndarray  # [1/m]
    extra: dict[str, np.ndarray]  # design columns
    ok: np.ndarray  # plausible and placeable


def _lanes(ctx: _Ctx, centre: float) -> np.ndarray:
    return centre + ctx.rng.uniform(-ctx.spec.lane_offset, ctx.spec.lane_offset, ctx.n)


def _set_motion(part: dict[str, np.ndarray], motion: _Motion) -> None:
    for name in _Motion._fields:
        part[name] = getattr(motion, name)


def _evasion(ctx: _Ctx, motion: _Motion, prob: float, angle_range: tuple[float, float],
             time_range: tuple[float, float], a_lat: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Evasive steering: flag, amplitude [rad] (>= 0), build-up time [s] and distance [m].

    The amplitude is capped so that the lateral acceleration stays below ``a_lat``
    [m/s^2] (default: the scenario's bound).
    """
    rng, n = ctx.rng, ctx.n
    flag = rng.random(n) < prob
    lead = rng.uniform(*time_range, n)
    q = rng.random(n)
    dist = np.maximum(motion.distance_before(lead), 1e-3)
    bound = ctx.a_lat if a_lat is None else a_lat
    angle = _capped(q, angle_range, _ramp_cap(dist, motion.speed_at(-lead), bound))
    flag &= motion.speed_at(0.0) > 0.5
    return flag, angle, lead, dist


def _common_extra(ctx: _Ctx, m1: _Motion, m2: _Motion) -> dict[str, np.ndarray]:
    return {"travel_speed1": m1.v_travel, "travel_speed2": m2.v_travel,
            "impact_speed1": m1.speed_at(0.0), "impact_speed2": m2.speed_at(0.0)}


def _design_head_on(ctx: _Ctx, overtaking: bool = False) -> _Design:
    """Head-on: participant 1 drifts (or has overtaken) into the oncoming lane.

    Participant 2 drives in its lane (and may steer to its right); participant 1's
    lateral position at t* follows from the contact placement, its drift width (or
    lane-change width) from its own lane position.  In bends the road's lateral
    acceleration (at the faster participant's travel speed at most half the budget)
    leaves the rest of ``max_lateral_accel`` to the manoeuvres.
    """
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    m1 = _draw_motion(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m2 = _draw_motion(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu,
                      spec.min_impact_speed_share)
    v1s, v2s = m1.speed_at(0.0), m2.speed_at(0.0)
    a_lat = ctx.a_lat
    a_bend = np.minimum(rng.uniform(*spec.bend_lateral_accel, n), 0.5 * a_lat)
    radius = np.clip(np.maximum(m1.v_travel, m2.v_travel) ** 2 / a_bend, *spec.bend_radius)
    k = spec.bend / radius
    budget1 = np.maximum(a_lat - m1.v_travel**2 * np.abs(k), 0.3)
    budget2 = np.maximum(a_lat - m2.v_travel**2 * np.abs(k), 0.3)
    ev2, e2, t2, s2 = _evasion(ctx, m2, spec.evasive_prob[1], spec.evasive_angle,
                               spec.evasive_time, budget2)
    ramp2 = np.where(ev2, -e2, 0.0)  # participant 2 steers to its right
    lane1, lane2 = _lanes(ctx, -0.5 * LANE_WIDTH), _lanes(ctx, 0.5 * LANE_WIDTH)
    share = rng.uniform(*spec.overlap, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    q_angle = rng.random(n)
    l2_target = lane2 - ramp2 * s2 * 0.5  # moving in -u: l* = lane - shift
    straight = k == 0.0
    kk = np.where(straight, 1.0, k)
    yaw2 = k * (ctx.dims1.front + ctx.dims2.front) + np.pi + ramp2  # road direction estimate

    def place(yaw1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Participant 2 relative to 1, participant 1's lateral position, placement flag."""
        pair = _Pair(yaw1, v1s, ctx.dims1, yaw2, v2s, ctx.dims2)
        r, placed = _place_overlap(pair, +1.0, share, np.ones(n))
        r = np.where(ctx.near[:, None], _place_gap(pair, gap, np.ones(n)), r)
        # lateral position of participant 1 such that participant 2 is in its lane: on
        # the circle of participant 2's lane (straight: l2 - r_y)
        b = 1.0 / kk - l2_target
        a = r[:, 1] + np.sign(kk) * np.sqrt(np.maximum(b**2 - r[:, 0] ** 2, 0.0))
        l1 = np.where(straight, l2_target - r[:, 1], 1.0 / kk - a)
        return r, l1, placed | ctx.near

    p1, p2 = _new_part(n), _new_part(n)
    extra = _common_extra(ctx, m1, m2)
    if overtaking:
        # steer-back of the overtaker over the last t_back seconds, angle -delta
        t_back = rng.uniform(*spec.evasive_time, n)
        t_gap = rng.uniform(*spec.lane_change_gap, n)
        t_change = rng.uniform(*spec.lane_change_time, n)
        s_back = np.maximum(m1.distance_before(t_back), 1e-3)
        delta = _capped(q_angle, spec.heading_angle,
                        _ramp_cap(s_back, m1.speed_at(-t_back), budget1))
        r, l1, ok = place(-delta)
        s_gap = m1.distance_before(t_back + t_gap)
        s_start = m1.distance_before(t_back + t_gap + t_change)
        shift = l1 - lane1 + delta * s_back * 0.5
        bump_dist = s_start - s_gap
        p1.update(ramp_angle=-delta, ramp_dist=s_back, bump_start=s_gap, bump_dist=bump_dist,
                  bump_angle=2.0 * shift / bump_dist)
        extra.update(steer_back_angle=delta, steer_back_time=t_back,
                     lane_change_time=t_change, lane_change_width=shift)
        ok &= (shift >= spec.lane_change_width[0]) & (shift <= spec.lane_change_width[1])
    else:
        # raised-cosine drift of width D: lateral acceleration v^2 delta^2 pi / (4 D);
        # the angle is capped with the drift width of a first placement, then placed again
        w1, w2 = ctx.dims1.width, ctx.dims2.width
        offset_est = np.where(ctx.near, 0.5 * (w1 + w2) + gap,
                              0.5 * (w1 + w2) - share * np.minimum(w1, w2))
        drift = np.maximum(l2_target - offset_est - lane1, 0.5)
        for _ in range(2):
            cap = np.sqrt(4.0 * budget1 * drift / (np.pi * m1.v_travel**2))
            delta = _capped(q_angle, spec.heading_angle, cap)
            r, l1, ok = place(delta)
            drift = np.maximum(l1 - lane1, 0.3)
        peak = m1.v_travel**2 * delta**2 * np.pi / (4.0 * drift)
        ok &= peak <= 1.2 * budget1
        p1.update(ramp_angle=delta, ramp_dist=2.0 * drift / delta)
        extra.update(drift_angle=delta, drift_width=drift, drift_length=2.0 * drift / delta)
        extra["bend_radius"] = np.where(straight, np.nan, radius)
    u2, l2 = _road_coords(k, r[:, 0], l1 + r[:, 1])
    ramp2_actual = wrap_angle(yaw2 - (k * u2 + np.pi))  # bend: correction of the estimate
    p2.update(u_star=u2, l_star=l2, direction=np.full(n, -1.0), road_k=k,
              ramp_angle=ramp2_actual, ramp_dist=s2)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(u_star=np.zeros(n), l_star=l1, road_k=k)
    extra.update(evasive2=ev2, evasive_angle2=np.where(ev2, e2, np.nan),
                 evasive_time2=np.where(ev2, t2, np.nan),
                 overlap=np.where(ctx.near, -gap, share), side=np.ones(n), lane1=lane1,
                 lane2=lane2)
    return _Design(p1, p2, k, extra, ok)


def _design_overtaking(ctx: _Ctx) -> _Design:
    return _design_head_on(ctx, overtaking=True)


def _design_rear_end(ctx: _Ctx) -> _Design:
    """Rear-end: participant 1 runs into participant 2 ahead in the same lane.

    Crashes: both start in the lane; their lateral offset (from the designed overlap and
    any late swerve) is split evenly between their lane positions.  Near misses: the
    follower swerves around the lead; its swerve (angle at t*, raised cosine) is as long as
    needed to reach the designed gap from its lane position.
    """
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    m1 = _draw_motion(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m2 = _draw_motion(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu, 0.0)
    standing = rng.random(n) < spec.standing2_share
    m2 = _Motion(np.where(standing, 0.0, m2.v_travel),
                 np.where(standing, NO_BRAKE, m2.brake_time),
                 np.where(standing, _IDLE_JERK, m2.jerk), np.where(standing, _IDLE_DECEL,
                                                                   m2.decel))
    v1s, v2s = m1.speed_at(0.0), m2.speed_at(0.0)
    closing = spec.min_closing_speed
    ok = (v1s - v2s >= closing) & (m1.v_travel - m2.v_travel >= closing)
    ev1, e1, t1, s1 = _evasion(ctx, m1, spec.evasive_prob[0], spec.evasive_angle,
                               spec.evasive_time)
    ev2, e2, t2, s2 = _evasion(ctx, m2, spec.evasive_prob[1], spec.evasive_angle,
                               spec.evasive_time)
    left = np.where(rng.random(n) < spec.swerve_left_share, 1.0, -1.0)
    random_side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    side2 = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    share = rng.uniform(*spec.overlap, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    noise = rng.uniform(-spec.lane_offset, spec.lane_offset, (2, n))
    q_swerve = rng.random(n)
    w1, w2 = ctx.dims1.width, ctx.dims2.width
    # near miss: the follower always swerves, over the distance its lateral shift needs
    shift_est = np.maximum(0.5 * (w1 + w2) + gap - spec.lane_offset, 0.5)
    e_near = _capped(q_swerve, spec.evasive_angle,
                     np.sqrt(4.0 * ctx.a_lat * shift_est / (np.pi * m1.v_travel**2)))
    ev1 |= ctx.near
    e1 = np.where(ctx.near, e_near, e1)
    ramp1 = np.where(ev1, left * e1, 0.0)
    # the lead steers away from the follower's side in a near miss, randomly otherwise
    ramp2 = np.where(ev2, np.where(ctx.near, -left, side2) * e2, 0.0)
    # participant 2 lies opposite to the follower's swerve
    side = np.where(ev1, -left, random_side)
    pair = _Pair(ramp1, v1s, ctx.dims1, ramp2, v2s, ctx.dims2)
    r, placed = _place_overlap(pair, -1.0, share, side)
    r = np.where(ctx.near[:, None], _place_gap(pair, gap, side), r)
    ok &= placed | ctx.near
    shift2 = ramp2 * s2 * 0.5
    # crashes: split the lateral mismatch between both lane positions
    shift1 = ramp1 * s1 * 0.5
    mismatch = r[:, 1] + shift1 - shift2
    lane1 = -0.5 * LANE_WIDTH + noise[0] - 0.5 * mismatch
    lane2 = -0.5 * LANE_WIDTH + noise[0] + 0.5 * mismatch
    # near misses: both in the lane, the follower's swerve bridges the offset
    near_lane1 = -0.5 * LANE_WIDTH + noise[0]
    near_lane2 = -0.5 * LANE_WIDTH + noise[1]
    near_shift1 = near_lane2 + shift2 - r[:, 1] - near_lane1
    ok &= ~ctx.near | (near_shift1 * left > 0.3)
    s1 = np.where(ctx.near, 2.0 * np.abs(near_shift1) / np.maximum(e1, 1e-3), s1)
    lane1 = np.where(ctx.near, near_lane1, lane1)
    lane2 = np.where(ctx.near, near_lane2, lane2)
    shift1 = np.where(ctx.near, near_shift1, shift1)
    l1 = lane1 + shift1
    p1, p2 = _new_part(n), _new_part(n)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(l_star=l1, ramp_angle=ramp1, ramp_dist=s1)
    p2.update(u_star=r[:, 0], l_star=l1 + r[:, 1], ramp_angle=ramp2, ramp_dist=s2)
    extra = _common_extra(ctx, m1, m2)
    extra.update(standing2=standing, evasive1=ev1, evasive2=ev2,
                 evasive_angle1=np.where(ev1, e1, np.nan),
                 evasive_angle2=np.where(ev2, e2, np.nan),
                 evasive_time1=np.where(ev1 & ~ctx.near, t1, np.nan),
                 evasive_time2=np.where(ev2, t2, np.nan),
                 swerve_length1=np.where(ev1, s1, np.nan),
                 overlap=np.where(ctx.near, -gap, share), side=side, lane1=lane1,
                 lane2=lane2)
    return _Design(p1, p2, np.zeros(n), extra, ok)


def _design_crossing(ctx: _Ctx) -> _Design:
    """Crossing paths: the front of participant 1 strikes the side of participant 2."""
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    m1 = _draw_motion(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m2 = _draw_motion(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu,
                      spec.min_impact_speed_share)
    from_right = rng.random(n) < spec.crossing_from_right_share
    angle = rng.uniform(*spec.crossing_angle, n)
    yaw2 = np.where(from_right, angle, -angle)
    position = rng.uniform(*spec.impact_position, n)
    aim = rng.uniform(-spec.striker_offset, spec.striker_offset, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    lane1, lane2 = _lanes(ctx, -0.5 * LANE_WIDTH), _lanes(ctx, -0.5 * LANE_WIDTH)
    pair = _Pair(np.zeros(n), m1.speed_at(0.0), ctx.dims1, yaw2, m2.speed_at(0.0), ctx.dims2)
    point1 = np.stack([ctx.dims1.front, aim * ctx.dims1.width], axis=1)
    # struck side faces participant 1: left side if 2 comes from 1's right
    point2 = np.stack([-ctx.dims2.rear + position * ctx.dims2.length,
                       np.where(from_right, 0.5, -0.5) * ctx.dims2.width], axis=1)
    r, ok = _place_target(pair, point1, point2)
    r = np.where(ctx.near[:, None], _place_gap(pair, gap, side), r)
    ok |= ctx.near
    p1, p2 = _new_part(n), _new_part(n)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(l_star=lane1)
    # participant 2 on its own road through its impact position
    pos2 = r + np.stack([np.zeros(n), lane1], axis=1)
    normal2 = _unit(yaw2 + 0.5 * np.pi)
    origin2 = pos2 - lane2[:, None] * normal2
    p2.update(road_x=origin2[:, 0], road_y=origin2[:, 1], road_theta=yaw2, l_star=lane2)
    extra = _common_extra(ctx, m1, m2)
    extra.update(crossing_angle=angle, from_right=from_right,
                 impact_position=np.where(ctx.near, np.nan, position),
                 overlap=np.where(ctx.near, -gap, np.nan), side=np.where(ctx.near, side, np.nan),
                 lane1=lane1, lane2=lane2)
    return _Design(p1, p2, np.zeros(n), extra, ok)


def _design_left_turn(ctx: _Ctx) -> _Design:
    """Left turn across the path of oncoming participant 2 (its front into 1's right)."""
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    radius = rng.uniform(*spec.turn_radius, n)
    v_cap = np.sqrt(ctx.a_lat * radius)
    q_speed = rng.random(n)
    v1 = _capped(q_speed, spec.speed1, v_cap)
    m1 = _draw_motion(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m1 = _Motion(v1, m1.brake_time, m1.jerk, m1.decel)
    # re-apply the minimum impact speed to the capped travel speed
    lead = np.minimum(-m1.brake_time, _brake_time_for_drop(
        v1 * (1.0 - spec.min_impact_speed_share), m1.jerk, m1.decel))
    m1 = m1._replace(brake_time=np.where(m1.braking, -lead, NO_BRAKE))
    m2 = _draw_motion(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu,
                      spec.min_impact_speed_share)
    beta = rng.uniform(*spec.turn_angle, n)
    ev2, e2, t2, s2 = _evasion(ctx, m2, spec.evasive_prob[1], spec.evasive_angle,
                               spec.evasive_time)
    ramp2 = np.where(ev2, -e2, 0.0)
    position = rng.uniform(*spec.impact_position, n)
    aim = rng.uniform(-spec.striker_offset, spec.striker_offset, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    lane2 = _lanes(ctx, 0.5 * LANE_WIDTH)
    pair = _Pair(beta, m1.speed_at(0.0), ctx.dims1, np.pi + ramp2, m2.speed_at(0.0),
                 ctx.dims2)
    # participant 2 (moving) aims its front at the turner's front-right / right side
    point1 = np.stack([ctx.dims1.front - position * ctx.dims1.length,
                       -0.5 * ctx.dims1.width], axis=1)
    point2 = np.stack([ctx.dims2.front, aim * ctx.dims2.width], axis=1)
    r, ok = _place_target(pair, point1, point2)
    r = np.where(ctx.near[:, None], _place_gap(pair, gap, side), r)
    ok |= ctx.near
    l2 = lane2 - ramp2 * s2 * 0.5  # moving in -u
    l1 = l2 - r[:, 1]
    lane1 = l1 - radius * (1.0 - np.cos(beta))
    ok &= (lane1 >= spec.turner_lane[0]) & (lane1 <= spec.turner_lane[1])
    p1, p2 = _new_part(n), _new_part(n)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(l_star=l1, turn_curv=1.0 / radius, turn_dist=beta * radius)
    p2.update(u_star=r[:, 0], l_star=l2, direction=np.full(n, -1.0), ramp_angle=ramp2,
              ramp_dist=s2)
    extra = _common_extra(ctx, m1, m2)
    extra.update(turn_radius=radius, turn_angle=beta, evasive2=ev2,
                 evasive_angle2=np.where(ev2, e2, np.nan),
                 evasive_time2=np.where(ev2, t2, np.nan),
                 impact_position=np.where(ctx.near, np.nan, position),
                 overlap=np.where(ctx.near, -gap, np.nan), side=np.where(ctx.near, side, np.nan),
                 lane1=lane1, lane2=lane2)
    return _Design(p1, p2, np.zeros(n), extra, ok)


_DESIGNERS: dict[str, Callable[[_Ctx], _Design]] = {
    "head_on": _design_head_on,
    "overtaking": _design_overtaking,
    "rear_end": _design_rear_end,
    "crossing": _design_crossing,
    "left_turn": _design_left_turn,
}


# ----------------------------------------------------------------------------
# Paths on the sample grid
# ----------------------------------------------------------------------------


def _cumtrapz(values: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of values d(sigma) along axis 1 (0 at column 0)."""
    out = np.zeros_like(values)
    np.cumsum(0.5 * (values[:, 1:] + values[:, :-1]) * np.diff(sigma, axis=1), axis=1,
              out=out[:, 1:])
    return out


def _build_paths(p: Mapping[str, np.ndarray], k_star: np.ndarray, m: int,
                 dt: float) -> dict[str, np.ndarray]:
    """Samples x, y [m], yaw [rad], speed [m/s], accel [m/s^2] of n paths, shape (n, m).

    Sample j is at t = j dt; the impact is at sample ``k_star``.
    """
    n = k_star.shape[0]
    col = {name: p[name][:, None] for name in _PART_FIELDS}
    tau = (np.arange(m)[None, :] - k_star[:, None]) * dt
    pos, speed, accel = _motion(tau, col["v_travel"], col["brake_time"], col["jerk"],
                                col["decel"])
    pos0 = _motion(np.zeros((n, 1)), col["v_travel"], col["brake_time"], col["jerk"],
                   col["decel"])[0]
    sigma = pos0 - pos
    phi = _heading_offset(col, sigma)
    rows = np.arange(n)
    d, k = col["direction"], col["road_k"]
    f = _cumtrapz(np.sin(phi), sigma)
    l = col["l_star"] - d * (f - f[rows, k_star][:, None])
    f = _cumtrapz(np.cos(phi) / (1.0 - k * l), sigma)
    u = col["u_star"] - d * (f - f[rows, k_star][:, None])
    xr, yr, theta = _road_point(k, u, l)
    c0, s0 = np.cos(col["road_theta"]), np.sin(col["road_theta"])
    x = col["road_x"] + c0 * xr - s0 * yr
    y = col["road_y"] + s0 * xr + c0 * yr
    yaw = col["road_theta"] + theta + np.where(d < 0.0, np.pi, 0.0) + phi
    return {"x": x, "y": y, "yaw": yaw, "speed": speed, "accel": accel}


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
        self.parts = [_new_part(n), _new_part(n)]
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

    def dims(self, rows: np.ndarray, i: int) -> _Dims:
        veh = self.vehicles[i]
        front = veh["front_overhang"][rows] + veh["cg_to_front_axle"][rows]
        return _Dims(front, veh["length"][rows] - front, veh["width"][rows])

    def vehicle_arrays(self, rows: np.ndarray, i: int) -> VehicleArrays:
        veh = self.vehicles[i]
        return vehicle_arrays(*(veh[f][rows] for f in (
            "mass", "length", "width", "wheelbase", "cg_to_front_axle", "front_overhang",
            "track_width", "cg_height")), yaw_inertia=veh["yaw_inertia"][rows])


def _draw(batch: _Batch, rows: np.ndarray, rng: np.random.Generator,
          specs: Mapping[int, ScenarioSpec], wet_share: float, dt: float) -> None:
    """(Re)draw the cases ``rows`` of the batch: vehicles, road, design, samples."""
    n = rows.shape[0]
    batch.wet[rows] = rng.random(n) < wet_share
    batch.mu[rows] = np.where(batch.wet[rows], rng.uniform(0.4, 0.65, n),
                              rng.uniform(0.7, 1.0, n))
    for i in range(2):
        cols, segment = _sample_fleet_arrays(n, rng)
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
            ctx = _Ctx(rng, spec, batch.dims(pending, 0), batch.dims(pending, 1),
                       batch.mu[pending], batch.near[pending])
            design = _DESIGNERS[spec.kind](ctx)
            for i, part in enumerate((design.p1, design.p2)):
                for name in _PART_FIELDS:
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
            part = {name: batch.parts[i][name][block] for name in _PART_FIELDS}
            samples = _build_paths(part, batch.k_star[block], batch.m, dt)
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
        reach = (np.hypot(np.maximum(d1.front, d1.rear), 0.5 * d1.width)
                 + np.hypot(np.maximum(d2.front, d2.rear), 0.5 * d2.width))
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
    params = PrecrashParams(dt=min(0.01, dt), extra_time=0.0)
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
            "heading_offset" + j: _heading_offset(
                {f: p[f] for f in _PART_FIELDS}, np.zeros(n)),
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
    if not ok or not 100 <= int(code) <= 799:  # type: ignore[call-overload]
        raise ParameterError(f"accident type {code!r} must be an integer code in [100, 799]")
    return int(code)  # type: ignore[call-overload]


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
    n = _check_count(n)
    _check_rng(rng)
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
        _check_share(name, value)
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
