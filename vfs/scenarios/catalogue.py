"""Accident-type catalogue of the synthetic scenes: one :class:`ScenarioSpec` per type code.

The types are data: ``scenarios/accident-types/<code>.toml`` (read through
:mod:`vfs.catalog`; every field in ``scenarios/README.md``), loaded into
:data:`SCENARIO_TYPES` when this module is imported.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from vfs.accident_types import ACCIDENT_TYPES
from vfs.catalog import Field, catalog_path, read_fields, read_toml
from vfs.errors import DefinitionError, ParameterError
from vfs.scenarios.validation import check_range, check_share
from vfs.units import KMH_PER_MS

__all__ = ["KINDS", "SCENARIO_TYPES", "SPEC_FIELDS", "ScenarioSpec", "load_scenario_types",
           "scenario_from_dict"]


def _kmh(lo: float, hi: float) -> tuple[float, float]:
    """Speed range [km/h] -> [m/s]."""
    return (lo / KMH_PER_MS, hi / KMH_PER_MS)


def _deg(lo: float, hi: float) -> tuple[float, float]:
    """Angle range [deg] -> [rad]."""
    return (math.radians(lo), math.radians(hi))


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
            check_range(f"{where} {name}", getattr(self, name), lo=0.0, hi=100.0)
        check_range(f"{where} brake_lead_time", self.brake_lead_time, lo=0.0, hi=4.0)
        check_range(f"{where} brake_jerk", self.brake_jerk, lo=1.0)
        check_range(f"{where} brake_deceleration", self.brake_deceleration, lo=0.5, hi=15.0)
        check_range(f"{where} evasive_angle", self.evasive_angle, lo=0.0, hi=0.6)
        check_range(f"{where} evasive_time", self.evasive_time, lo=0.1, hi=4.0)
        check_range(f"{where} heading_angle", self.heading_angle, lo=1e-3, hi=0.6)
        check_range(f"{where} overlap", self.overlap, lo=0.0, hi=1.0)
        check_range(f"{where} near_miss_gap", self.near_miss_gap, lo=0.15, hi=10.0)
        check_range(f"{where} bend_lateral_accel", self.bend_lateral_accel, lo=0.05)
        check_range(f"{where} bend_radius", self.bend_radius, lo=10.0)
        check_range(f"{where} crossing_angle", self.crossing_angle, lo=0.2, hi=math.pi - 0.2)
        check_range(f"{where} impact_position", self.impact_position, lo=0.0, hi=1.0)
        check_range(f"{where} turn_radius", self.turn_radius, lo=3.0)
        check_range(f"{where} turn_angle", self.turn_angle, lo=0.05, hi=math.pi / 2)
        check_range(f"{where} turner_lane", self.turner_lane)
        check_range(f"{where} lane_change_time", self.lane_change_time, lo=0.5)
        check_range(f"{where} lane_change_gap", self.lane_change_gap, lo=0.0)
        check_range(f"{where} lane_change_width", self.lane_change_width, lo=0.1)
        for name in ("brake_prob", "evasive_prob"):
            pair = getattr(self, name)
            if not (isinstance(pair, tuple) and len(pair) == 2):
                raise ParameterError(f"{where} {name}={pair!r} must be a pair of shares")
            for p in pair:
                check_share(f"{where} {name}", p)
        for name in ("standing2_share", "min_impact_speed_share", "crossing_from_right_share",
                     "swerve_left_share", "striker_offset"):
            check_share(f"{where} {name}", getattr(self, name))
        for name, lo, hi in (("min_closing_speed", 0.1, 50.0), ("lane_offset", 0.0, 1.5),
                             ("max_lateral_accel", 0.5, 15.0)):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and lo <= value <= hi):
                raise ParameterError(f"{where} {name}={value!r} outside [{lo:g}, {hi:g}]")


def _pair(name: str, of: str, lo: float = -math.inf, hi: float = math.inf,
          ordered: bool = True) -> Field:
    return Field(name, "pair", lo=lo, hi=hi, pair_of=of, ordered=ordered)


#: The fields of an accident-type file (``scenarios/accident-types/<code>.toml``); the
#: ranges are checked by :class:`ScenarioSpec` itself (its messages give them).
SPEC_FIELDS: tuple[Field, ...] = (
    Field("code", "int", lo=100, hi=799),
    Field("name", "text"), Field("kind", "text", choices=KINDS), Field("description", "text"),
    Field("bend", "int", lo=-1, hi=1),
    _pair("speed1", "speed"), _pair("speed2", "speed"),
    Field("standing2_share", "ratio"), Field("min_closing_speed", "speed"),
    Field("min_impact_speed_share", "ratio"),
    _pair("brake_prob", "ratio", ordered=False), _pair("brake_lead_time", "time"),
    _pair("brake_jerk", "jerk"), _pair("brake_deceleration", "acceleration"),
    _pair("evasive_prob", "ratio", ordered=False), _pair("evasive_angle", "angle"),
    _pair("evasive_time", "time"), _pair("heading_angle", "angle"), _pair("overlap", "ratio"),
    _pair("near_miss_gap", "length"), _pair("bend_lateral_accel", "acceleration"),
    _pair("bend_radius", "length"), _pair("crossing_angle", "angle"),
    Field("crossing_from_right_share", "ratio"), _pair("impact_position", "ratio"),
    Field("striker_offset", "ratio"), _pair("turn_radius", "length"),
    _pair("turn_angle", "angle"), _pair("turner_lane", "length"),
    _pair("lane_change_time", "time"), _pair("lane_change_gap", "time"),
    _pair("lane_change_width", "length"), Field("swerve_left_share", "ratio"),
    Field("lane_offset", "length"), Field("max_lateral_accel", "acceleration"),
)


def scenario_from_dict(data: Mapping[str, Any], path: str | os.PathLike[str],
                       base: ScenarioSpec | None = None) -> tuple[int | None, ScenarioSpec]:
    """The accident code and :class:`ScenarioSpec` of a parsed accident-type table.

    Parameters
    ----------
    data : mapping
        The table (:data:`SPEC_FIELDS`; units in the keys).
    path : path
        The file, for messages.
    base : ScenarioSpec, optional
        Fields left out are taken from it (a preset's override of a catalogue type);
        otherwise from the defaults of :class:`ScenarioSpec`, the name from
        :data:`vfs.accident_types.ACCIDENT_TYPES`.

    Raises
    ------
    DefinitionError
        Naming the file, the field and the allowed values.
    """
    values = read_fields(data, SPEC_FIELDS, path=path)
    code = values.pop("code", None)
    if base is None:
        if code is None:
            raise DefinitionError(str(path), "code", "missing", "an integer in [100, 799]")
        if "name" not in values:
            if code not in ACCIDENT_TYPES:
                raise DefinitionError(str(path), "name", f"missing (code {code} has no "
                                      "catalogue name)", "text")
            values["name"] = ACCIDENT_TYPES[code]
        for key in ("kind", "description"):
            if key not in values:
                raise DefinitionError(str(path), key, "missing", "text")
    try:
        spec = replace(base, **values) if base is not None else ScenarioSpec(**values)
    except (ParameterError, TypeError) as exc:
        raise DefinitionError(str(path), "", str(exc)) from None
    return code, spec


def load_scenario_types(folder: str | os.PathLike[str] | None = None) -> dict[int, ScenarioSpec]:
    """The accident types of a folder of ``<code>.toml`` files, by code (sorted by file).

    Parameters
    ----------
    folder : path, optional
        Default ``scenarios/accident-types`` of the catalogue (:mod:`vfs.catalog`).
    """
    root = Path(folder) if folder is not None else catalog_path("scenarios", "accident-types")
    out: dict[int, ScenarioSpec] = {}
    for file in sorted(root.glob("*.toml")):
        code, spec = scenario_from_dict(read_toml(file), file)
        if code in out:
            raise DefinitionError(str(file), "code", f"{code} is defined twice in {root}")
        out[int(code)] = spec  # type: ignore[arg-type]
    return out


#: The accident types by code of the German/Austrian accident-type catalogue: the files
#: ``scenarios/accident-types/<code>.toml`` (names from
#: :data:`vfs.accident_types.ACCIDENT_TYPES`), in the order of their codes.
SCENARIO_TYPES: dict[int, ScenarioSpec] = dict(sorted(load_scenario_types().items()))
