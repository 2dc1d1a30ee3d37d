"""OpenSCENARIO 1.3 export and import of cases (two vehicles, timed polylines).

Export (:func:`export_case`) writes per case an OpenSCENARIO file
``case_<id>.xosc`` and its road ``case_<id>.xodr`` (:mod:`vfs.interop.opendrive`):

* entities ``Ego`` (participant 1) and ``Target`` (participant 2), each a
  ``Vehicle`` with bounding box, mass, axles, generous performance limits and
  the vfs data OpenSCENARIO has no field for as ``Properties``
  (``vfs.cg_to_front_axle``, ``vfs.cg_height``, ``vfs.yaw_inertia``,
  ``vfs.vehicle_class``); a fixed object (barrier, pole) is a ``MiscObject``;
* positions refer to the OpenSCENARIO reference point: for a vehicle the
  centre of the rear axle on the ground, for a misc object the centre of its
  bounding box on the ground.  vfs stores CG positions; the reference point
  lies :func:`reference_offset` ahead of the CG along the vehicle's x axis
  (for a vehicle ``cg_to_front_axle - wheelbase``, i.e. behind it);
* ``Init``: each vehicle teleported to its first sample with its speed there;
* one ``Story``: per vehicle a ``FollowTrajectoryAction`` along a
  ``Polyline`` whose vertices carry the sample times (``TimeReference``
  ``Timing`` absolute, scale 1, offset 0; times counted from the first
  sample, which is simulation time 0), ``followingMode`` position;
* ``StopTrigger`` at the last sample time;
* ``FileHeader`` properties with the case's data (``vfs.case_id``,
  ``vfs.t0`` -- the record time of simulation time 0 --, accident type,
  friction, road curvature, collision, ...), so that :func:`import_xosc`
  restores the case.

Import (:func:`import_xosc`) reads that subset of any OpenSCENARIO 1.x file:
two entities (``Vehicle`` or ``MiscObject``), their dimensions, mass and
axles, and their trajectories (inline ``Polyline`` of timed ``WorldPosition``
vertices); the road only for its friction and curvature.  Missing vfs data
take the defaults of :class:`vfs.physics.vehicle.VehicleParams`.

Units: m, s, rad, kg, m/s.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.accident_types import accident_type_label
from vfs.atomic import write_text
from vfs.database import Database, default_meta
from vfs.database.schema import MAX_SAMPLE_SPACING, normalise_table
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.interop.extra import require_extra
from vfs.interop.motion import CaseMotion, ParticipantMotion, find_case, recorded_motion
from vfs.interop.opendrive import (
    LANE_WIDTH,
    CaseRoads,
    Road,
    case_roads,
    opendrive_document,
    read_opendrive,
    road_curvature_at,
)
from vfs.physics.vehicle import VehicleParams

__all__ = [
    "DEFAULT_HEIGHTS",
    "ENTITY_NAMES",
    "OSC_MINOR_VERSION",
    "WHEEL_DIAMETER",
    "XoscExport",
    "bounding_box_center",
    "export_case",
    "import_xosc",
    "reference_offset",
    "to_cg",
    "to_reference",
]

#: OpenSCENARIO version written: 1.OSC_MINOR_VERSION.
OSC_MINOR_VERSION = 3
#: Names of the scenario objects of participants 1 and 2.
ENTITY_NAMES: tuple[str, str] = ("Ego", "Target")
#: Height of the bounding box by vehicle class [m] (vfs stores no height); others 1.5 m.
DEFAULT_HEIGHTS: dict[str, float] = {"car": 1.5, "van": 2.0, "truck": 3.5, "bus": 3.2,
                                     "motorbike": 1.3, "bicycle": 1.5}
#: Height of a fixed object's bounding box [m].
FIXED_OBJECT_HEIGHT = 1.0
#: Wheel diameter written for both axles [m] (vfs stores none; a passenger-car wheel).
WHEEL_DIAMETER = 0.65
#: Largest steering angle of the front axle [rad] (about 29 degrees); the rear axle 0.
MAX_STEERING = 0.5
#: Performance limits written (the trajectory, not a driver model, moves the vehicles):
#: at least this speed [m/s], acceleration and deceleration [m/s^2].
MIN_MAX_SPEED, MAX_ACCELERATION, MAX_DECELERATION = 70.0, 10.0, 12.0
#: OpenSCENARIO vehicle categories; other vfs vehicle classes are written as "car".
VEHICLE_CATEGORIES: tuple[str, ...] = ("car", "van", "truck", "bus", "motorbike", "bicycle",
                                       "trailer", "semitrailer", "train", "tram")
#: OpenSCENARIO misc object categories for fixed objects; others are written as "obstacle".
MISC_CATEGORIES: tuple[str, ...] = ("barrier", "pole", "obstacle", "tree", "building",
                                    "railing", "streetLamp", "soundBarrier", "gantry")
#: Prefix of the vfs properties.
PREFIX = "vfs."
#: Accident type of imported cases without a vfs header ("other").
IMPORTED_ACCIDENT_TYPE = 799


# ----------------------------------------------------------------------------
# The reference point
# ----------------------------------------------------------------------------


def reference_offset(wheelbase: npt.ArrayLike, cg_to_front_axle: npt.ArrayLike,
                     front_overhang: npt.ArrayLike, length: npt.ArrayLike,
                     fixed_object: npt.ArrayLike = False) -> np.ndarray:
    """Distance from the CG forward to the OpenSCENARIO reference point [m].

    A vehicle's reference point is the centre of its rear axle, projected
    onto the ground: ``cg_to_front_axle - wheelbase`` (negative, behind the
    CG).  A misc object's (a fixed object's) is the centre of its bounding
    box: ``cg_to_front_axle + front_overhang - length / 2``.

    Parameters
    ----------
    wheelbase, cg_to_front_axle, front_overhang, length : array_like
        vfs vehicle geometry [m].
    fixed_object : array_like of bool
        Fixed objects are written as misc objects.
    """
    l1 = np.asarray(cg_to_front_axle, float)
    centre = l1 + np.asarray(front_overhang, float) - 0.5 * np.asarray(length, float)
    return np.where(np.asarray(fixed_object, bool), centre, l1 - np.asarray(wheelbase, float))


def bounding_box_center(wheelbase: npt.ArrayLike, front_overhang: npt.ArrayLike,
                        length: npt.ArrayLike, fixed_object: npt.ArrayLike = False
                        ) -> np.ndarray:
    """X of the bounding-box centre relative to the reference point [m]:
    ``wheelbase + front_overhang - length / 2`` for a vehicle, 0 for a misc object.
    """
    x = np.asarray(wheelbase, float) + np.asarray(front_overhang, float) \
        - 0.5 * np.asarray(length, float)
    return np.where(np.asarray(fixed_object, bool), 0.0, x)


def to_reference(x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
                 offset: float) -> tuple[np.ndarray, np.ndarray]:
    """CG positions [m] -> reference-point positions [m] (``offset`` from
    :func:`reference_offset`).
    """
    yaw_a = np.asarray(yaw, float)
    return (np.asarray(x, float) + offset * np.cos(yaw_a),
            np.asarray(y, float) + offset * np.sin(yaw_a))


def to_cg(x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
          offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Reference-point positions [m] -> CG positions [m] (inverse of :func:`to_reference`)."""
    yaw_a = np.asarray(yaw, float)
    return (np.asarray(x, float) - offset * np.cos(yaw_a),
            np.asarray(y, float) - offset * np.sin(yaw_a))


# ----------------------------------------------------------------------------
# Export
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class XoscExport:
    """What :func:`export_case` wrote.

    Attributes
    ----------
    xosc, xodr : Path
        The scenario and its road.
    roads : CaseRoads
        The road network (mode, fit error).
    motion : CaseMotion
        The exported motion.
    """

    xosc: Path
    xodr: Path
    roads: CaseRoads
    motion: CaseMotion


def _num(value: object) -> str:
    """A number as XML text: shortest repr that reads back to the same double."""
    return repr(float(value))  # type: ignore[arg-type]


def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", str(text)).strip("_") or "x"


def _participant_rows(db: Database, case_id: object) -> list[pd.Series]:
    parts = db.participants[db.participants["case_id"] == case_id]
    rows = []
    for number in (1, 2):
        hit = parts[parts["participant"] == number]
        if hit.empty:
            raise DataError(DataProblem("participants", "participant", None, case_id,
                                        f"case has no participant {number}"))
        rows.append(hit.iloc[0])
    return rows


def _entity(xosc: Any, name: str, row: pd.Series, max_speed: float) -> Any:
    """The Vehicle or MiscObject of one participant."""
    fixed = bool(row.get("fixed_object", False))
    vclass = str(row.get("vehicle_class", "car") or "car")
    length, width = float(row["length"]), float(row["width"])
    wheelbase, fo = float(row["wheelbase"]), float(row["front_overhang"])
    height = float(row["height"]) if "height" in row.index and pd.notna(row["height"]) else (
        FIXED_OBJECT_HEIGHT if fixed else DEFAULT_HEIGHTS.get(vclass, 1.5))
    bbox = xosc.BoundingBox(width, length, height,
                            float(bounding_box_center(wheelbase, fo, length, fixed)), 0.0,
                            0.5 * height)
    if fixed:
        category = vclass if vclass in MISC_CATEGORIES else "obstacle"
        entity = xosc.MiscObject(name, float(row["mass"]),
                                 getattr(xosc.MiscObjectCategory, category), bbox)
    else:
        category = vclass if vclass in VEHICLE_CATEGORIES else "car"
        track = float(row["track_width"])
        front = xosc.Axle(MAX_STEERING, WHEEL_DIAMETER, track, wheelbase, 0.5 * WHEEL_DIAMETER)
        rear = xosc.Axle(0.0, WHEEL_DIAMETER, track, 0.0, 0.5 * WHEEL_DIAMETER)
        entity = xosc.Vehicle(name, getattr(xosc.VehicleCategory, category), bbox, front, rear,
                              max_speed, MAX_ACCELERATION, MAX_DECELERATION,
                              mass=float(row["mass"]))
    props: dict[str, str] = {
        "participant": str(int(row["participant"])),
        "reference_point": "bounding box centre on the ground" if fixed
        else "rear axle centre on the ground",
        "cg_to_front_axle": _num(row["cg_to_front_axle"]),
        "cg_height": _num(row["cg_height"]),
        "vehicle_class": vclass,
        "fixed_object": "true" if fixed else "false",
    }
    if fixed:  # a misc object has no axles: keep the vfs layout
        props.update(wheelbase=_num(wheelbase), track_width=_num(row["track_width"]),
                     front_overhang=_num(fo))
    if pd.notna(row.get("yaw_inertia", np.nan)):
        props["yaw_inertia"] = _num(row["yaw_inertia"])
    for key, value in props.items():
        entity.add_property(PREFIX + key, value)
    return entity


def _trajectory(xosc: Any, name: str, motion: ParticipantMotion, offset: float,
                t_start: float) -> Any:
    xr, yr = to_reference(motion.x, motion.y, motion.yaw, offset)
    positions = [xosc.WorldPosition(float(a), float(b), 0.0, float(h))
                 for a, b, h in zip(xr, yr, motion.yaw, strict=True)]
    times = [float(t - t_start) for t in motion.t]
    traj = xosc.Trajectory(f"{name}_trajectory", False)
    traj.add_shape(xosc.Polyline(times, positions))
    return traj


def _case_header(db: Database, case_id: object, motion: CaseMotion,
                 t_start: float) -> dict[str, str]:
    row = db.cases.set_index("case_id").loc[case_id]
    props = {
        "case_id": str(case_id),
        "database": str(db.meta.get("name", "")),
        "motion": motion.source,
        "t0": _num(t_start),
        "accident_type": str(int(row["accident_type"])),
        "road_friction": _num(row["road_friction"]),
        "road_surface": str(row["road_surface"]),
        "road_curvature": _num(row["road_curvature"]),
        "weight": _num(row.get("weight", 1.0)),
        "collision": "true" if bool(row["collision"]) else "false",
        "motion_collides": "true" if motion.collided else "false",
    }
    if motion.collided and math.isfinite(motion.impact_time):
        props["impact_time"] = _num(motion.impact_time)
    for i, note in enumerate(motion.notes, start=1):
        props[f"note{i}"] = note
    if str(row.get("description", "")):
        props["description"] = str(row["description"])
    return props


def scenario_document(db: Database, case_id: object, motion: CaseMotion, road_file: str,
                      description: str = "") -> ET.Element:
    """The OpenSCENARIO document of a case (``scenariogeneration``); see the module text.

    Parameters
    ----------
    db : Database
        Vehicles and case data.
    case_id : object
    motion : CaseMotion
        Trajectories of both vehicles (CG; converted to the reference point).
    road_file : str
        Path of the OpenDRIVE file as written in ``RoadNetwork/LogicFile``.
    description : str
        ``FileHeader`` description (default: generated).
    """
    xosc = require_extra("scenariogeneration.xosc")
    from vfs.version import __version__

    rows = _participant_rows(db, case_id)
    t_start = float(min(m.t[0] for m in motion.participants))
    t_end = float(max(m.t[-1] for m in motion.participants)) - t_start
    vmax = max(float(np.max(m.speed)) for m in motion.participants)
    entities = xosc.Entities()
    init = xosc.Init()
    story = xosc.Story(f"case_{_safe(str(case_id))}")
    start = xosc.ValueTrigger("start_at_0", 0, xosc.ConditionEdge.none,
                              xosc.SimulationTimeCondition(0, xosc.Rule.greaterOrEqual))
    act = xosc.Act("pre_crash", start)
    for name, row, m in zip(ENTITY_NAMES, rows, motion.participants, strict=True):
        fixed = bool(row.get("fixed_object", False))
        offset = float(reference_offset(row["wheelbase"], row["cg_to_front_axle"],
                                        row["front_overhang"], row["length"], fixed))
        entities.add_scenario_object(name, _entity(xosc, f"case{case_id}_participant"
                                                   f"{int(row['participant'])}", row,
                                                   max(MIN_MAX_SPEED, 1.2 * vmax)))
        xr, yr = to_reference(m.x[:1], m.y[:1], m.yaw[:1], offset)
        init.add_init_action(name, xosc.TeleportAction(
            xosc.WorldPosition(float(xr[0]), float(yr[0]), 0.0, float(m.yaw[0]))))
        if not fixed:
            init.add_init_action(name, xosc.AbsoluteSpeedAction(
                float(m.speed[0]), xosc.TransitionDynamics(xosc.DynamicsShapes.step,
                                                           xosc.DynamicsDimension.time, 0)))
        if fixed and np.ptp(m.x) == 0 and np.ptp(m.y) == 0 and np.ptp(m.yaw) == 0:
            continue  # a fixed object that does not move: placed by Init only
        follow = xosc.FollowTrajectoryAction(
            _trajectory(xosc, name, m, offset, t_start), xosc.FollowingMode.position,
            xosc.ReferenceContext.absolute, 1, 0, initialDistanceOffset=0)
        event = xosc.Event(f"{name}_follows_trajectory", xosc.Priority.override)
        event.add_action(f"{name}_trajectory", follow)
        event.add_trigger(xosc.ValueTrigger(
            f"{name}_start", 0, xosc.ConditionEdge.none,
            xosc.SimulationTimeCondition(0, xosc.Rule.greaterOrEqual)))
        maneuver = xosc.Maneuver(f"{name}_maneuver")
        maneuver.add_event(event)
        group = xosc.ManeuverGroup(f"{name}_maneuver_group")
        group.add_actor(name)
        group.add_maneuver(maneuver)
        act.add_maneuver_group(group)
    story.add_act(act)
    stop = xosc.ValueTrigger("end_of_trajectories", 0, xosc.ConditionEdge.none,
                             xosc.SimulationTimeCondition(t_end, xosc.Rule.greaterOrEqual),
                             "stop")
    board = xosc.StoryBoard(init, stop)
    board.add_story(story)
    header_props = xosc.Properties()
    for key, value in _case_header(db, case_id, motion, t_start).items():
        header_props.add_property(PREFIX + key, value)
    atype = db.cases.set_index("case_id").loc[case_id, "accident_type"]
    text = description or (f"vfs case {case_id} ({accident_type_label(atype)}): "
                           + ("recorded pre-crash motion" if motion.source == "recorded"
                              else f"pre-crash motion with AEB {motion.source}"))
    scenario = xosc.Scenario(text, f"vfs {__version__}", xosc.ParameterDeclarations(),
                             entities, board, xosc.RoadNetwork(road_file), xosc.Catalog(),
                             osc_minor_version=OSC_MINOR_VERSION,
                             creation_date=_dt.datetime.now().replace(microsecond=0),
                             header_properties=header_props)
    root: ET.Element = scenario.get_element()
    return root


def _xml_text(root: ET.Element) -> str:
    ET.indent(root, space="    ")
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") \
        + "\n"


def export_case(db: Database, case_id: object, out: str | os.PathLike[str], *,
                motion: CaseMotion | None = None, road: str = "auto",
                lane_width: float = LANE_WIDTH, validate: bool = False) -> XoscExport:
    """Write a case as OpenSCENARIO + OpenDRIVE files into folder ``out``.

    Parameters
    ----------
    db : Database
    case_id : object
        Case identifier (also as text).
    out : path
        Output folder (created); files ``case_<id>.xodr`` and
        ``case_<id>.xosc`` (``case_<id>_<system>.xosc`` for a simulated
        motion) are replaced.
    motion : CaseMotion, optional
        Motion to write (default: the recorded one,
        :func:`vfs.interop.motion.recorded_motion`).  The road is always
        built from the recorded paths.
    road : {"auto", "straight", "path"}
        Road construction (:func:`vfs.interop.opendrive.case_roads`).
    lane_width : float
        [m]
    validate : bool
        Validate both files against the ASAM schemas
        (:func:`vfs.interop.schemas.validate_file`; needs xmlschema).

    Returns
    -------
    XoscExport
    """
    cid = find_case(db, case_id)
    recorded = recorded_motion(db, cid)
    motion = motion or recorded
    friction = float(db.cases.set_index("case_id").loc[cid, "road_friction"])
    curvature = float(db.cases.set_index("case_id").loc[cid, "road_curvature"])
    p1, p2 = recorded.participants
    roads = case_roads(p1.x, p1.y, p1.yaw, p2.x, p2.y, p2.yaw, road_curvature=curvature,
                       mode=road, lane_width=lane_width, friction=friction)
    folder = Path(out)
    stem = f"case_{_safe(str(cid))}"
    xodr_path = folder / f"{stem}.xodr"
    suffix = "" if motion.source == "recorded" else "_" + _safe(motion.source.split(" ", 1)[-1])
    xosc_path = folder / f"{stem}{suffix}.xosc"
    write_text(xodr_path, _xml_text(opendrive_document(roads, f"vfs case {cid}")))
    write_text(xosc_path, _xml_text(scenario_document(db, cid, motion, xodr_path.name)))
    if validate:
        from vfs.interop.schemas import validate_file

        validate_file(xodr_path)
        validate_file(xosc_path)
    return XoscExport(xosc_path, xodr_path, roads, motion)


# ----------------------------------------------------------------------------
# Import
# ----------------------------------------------------------------------------


class _Reader:
    """Attribute access with ``$parameter`` substitution and clear errors."""

    def __init__(self, file: Path, root: ET.Element) -> None:
        self.where = file.name
        self.params: dict[str, str] = {}
        for decl in root.findall("ParameterDeclarations/ParameterDeclaration"):
            if decl.get("name"):
                self.params[str(decl.get("name"))] = str(decl.get("value", ""))

    def problem(self, message: str, column: str = "") -> DataError:
        return DataError(DataProblem(self.where, column, None, None, message))

    def text(self, element: ET.Element, name: str, default: str | None = None) -> str | None:
        value = element.get(name)
        if value is None:
            return default
        if value.startswith("${"):
            raise self.problem(f"{element.tag}@{name}={value!r}: expressions are not supported "
                               "(give the value or a $parameter)", name)
        if value.startswith("$"):
            key = value[1:]
            if key not in self.params:
                raise self.problem(f"{element.tag}@{name} refers to undeclared parameter "
                                   f"{value}", name)
            return self.params[key]
        return value

    def number(self, element: ET.Element | None, name: str,
               default: float | None = None) -> float:
        text = None if element is None else self.text(element, name)
        tag = "element" if element is None else element.tag
        if text is None:
            if default is None:
                raise self.problem(f"{tag} has no attribute {name}", name)
            return default
        try:
            return float(text)
        except ValueError:
            raise self.problem(f"{tag}@{name}={text!r} is not a number", name) from None


def _properties(element: ET.Element | None) -> dict[str, str]:
    if element is None:
        return {}
    return {str(p.get("name")): str(p.get("value", ""))
            for p in element.findall("Properties/Property") if p.get("name")}


def _vehicle_row(reader: _Reader, obj: ET.Element) -> tuple[dict[str, Any], float]:
    """Participants-table values of one scenario object and its reference offset [m]."""
    vehicle = obj.find("Vehicle")
    misc = obj.find("MiscObject")
    if vehicle is None and misc is None:
        kind = obj[0].tag if len(obj) else "nothing"
        raise reader.problem(f"scenario object {obj.get('name')!r} is a {kind}; only inline "
                             "Vehicle and MiscObject entities are read (catalog references "
                             "are not resolved)")
    node: ET.Element = vehicle if vehicle is not None else misc  # type: ignore[assignment]
    props = {k[len(PREFIX):]: v for k, v in _properties(node).items() if k.startswith(PREFIX)}
    default = VehicleParams()
    bbox = node.find("BoundingBox")
    dims = None if bbox is None else bbox.find("Dimensions")
    centre = None if bbox is None else bbox.find("Center")
    length = reader.number(dims, "length", default.length)
    width = reader.number(dims, "width", default.width)
    cx = reader.number(centre, "x", 0.0)

    def prop(name: str, fallback: float) -> float:
        if name not in props:
            return fallback
        try:
            return float(props[name])
        except ValueError:
            raise reader.problem(f"property {PREFIX}{name}={props[name]!r} is not a number",
                                 name) from None

    fixed = vehicle is None
    if vehicle is not None:
        front = vehicle.find("Axles/FrontAxle")
        rear = vehicle.find("Axles/RearAxle")
        x_front = reader.number(front, "positionX", default.wheelbase)
        x_rear = reader.number(rear, "positionX", 0.0)
        wheelbase = x_front - x_rear
        track = reader.number(front, "trackWidth", min(default.track_width, width))
        front_overhang = cx + 0.5 * length - x_front  # bbox front ahead of the front axle
        mass = reader.number(vehicle, "mass", default.mass)
        l1 = prop("cg_to_front_axle", wheelbase * default.cg_to_front_axle / default.wheelbase)
        offset = l1 - wheelbase - x_rear  # reference point = rear axle
        vclass = props.get("vehicle_class", vehicle.get("vehicleCategory", "car"))
    else:
        wheelbase = prop("wheelbase", 0.5 * length)
        track = prop("track_width", min(default.track_width, width))
        l1 = prop("cg_to_front_axle", 0.5 * wheelbase)
        front_overhang = prop("front_overhang", 0.5 * length - l1)
        mass = reader.number(node, "mass", default.mass)
        offset = l1 + front_overhang - 0.5 * length - cx  # reference point = bbox centre
        vclass = props.get("vehicle_class", node.get("miscObjectCategory", "obstacle"))
    values: dict[str, Any] = {
        "mass": mass, "yaw_inertia": prop("yaw_inertia", math.nan),
        "length": length, "width": width, "wheelbase": wheelbase,
        "cg_to_front_axle": l1, "front_overhang": front_overhang,
        "track_width": track, "cg_height": prop("cg_height", default.cg_height),
        "vehicle_class": vclass, "fixed_object": fixed,
    }
    return values, offset


def _timed_polyline(reader: _Reader, action: ET.Element, name: str
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Times [s] and reference-point poses (x, y [m], h [rad]) of a FollowTrajectoryAction."""
    traj = action.find("TrajectoryRef/Trajectory")
    if traj is None:
        traj = action.find("Trajectory")
    if traj is None:
        raise reader.problem(f"the trajectory of {name!r} is not inline (catalog references "
                             "are not resolved)")
    vertices = traj.findall("Shape/Polyline/Vertex")
    if not vertices:
        kind = traj.find("Shape")
        what = kind[0].tag if kind is not None and len(kind) else "no shape"
        raise reader.problem(f"the trajectory of {name!r} is a {what}; only Polyline shapes "
                             "are read")
    timing = action.find("TimeReference/Timing")
    if timing is None:
        raise reader.problem(f"the trajectory of {name!r} has no Timing: its vertices need "
                             "times (TimeReference/Timing)")
    scale = reader.number(timing, "scale", 1.0)
    shift = reader.number(timing, "offset", 0.0)
    if reader.text(timing, "domainAbsoluteRelative", "absolute") != "absolute":
        raise reader.problem(f"the timing of {name!r} is relative; only absolute timing is "
                             "read")
    t, x, y, h = [], [], [], []
    for k, v in enumerate(vertices):
        if v.get("time") is None:
            raise reader.problem(f"vertex {k} of {name!r} has no time")
        pos = v.find("Position/WorldPosition")
        if pos is None:
            other = v.find("Position")
            what = other[0].tag if other is not None and len(other) else "no position"
            raise reader.problem(f"vertex {k} of {name!r} is a {what}; only WorldPosition "
                                 "vertices are read")
        t.append(reader.number(v, "time") * scale + shift)
        x.append(reader.number(pos, "x"))
        y.append(reader.number(pos, "y"))
        h.append(reader.number(pos, "h", math.nan))
    return np.array(t), np.array(x), np.array(y), np.array(h)


def _fill_headings(x: np.ndarray, y: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Missing headings: the direction of travel (the previous one where standing)."""
    if not np.isnan(h).any():
        return h
    d = np.arctan2(np.gradient(y), np.gradient(x)) if len(x) > 1 else np.zeros(len(x))
    out = np.where(np.isnan(h), d, h)
    return np.unwrap(out)


def _densify(t: np.ndarray, cols: list[np.ndarray]) -> tuple[np.ndarray, list[np.ndarray]]:
    """Linear interpolation into gaps wider than the schema's sample spacing."""
    gaps = np.diff(t) > MAX_SAMPLE_SPACING + 1e-12
    if not gaps.any():
        return t, cols
    pieces = [t[:1]]
    for a, b in zip(t[:-1], t[1:], strict=True):
        n = max(1, int(math.ceil((b - a) / MAX_SAMPLE_SPACING - 1e-9)))
        pieces.append(np.linspace(a, b, n + 1)[1:])
    new_t = np.concatenate(pieces)
    return new_t, [np.interp(new_t, t, c) for c in cols]


def _cg_speed(t: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """CG speed [m/s] from positions (second-order finite differences)."""
    if len(t) < 3:
        v = math.hypot(x[-1] - x[0], y[-1] - y[0]) / (t[-1] - t[0])
        return np.full(len(t), v)
    return np.hypot(np.gradient(x, t, edge_order=2), np.gradient(y, t, edge_order=2))


def _storyboard_trajectories(reader: _Reader, root: ET.Element) -> dict[str, ET.Element]:
    """Entity name -> its FollowTrajectoryAction (the first one found)."""
    found: dict[str, ET.Element] = {}
    for group in root.iter("ManeuverGroup"):
        actors = [str(e.get("entityRef")) for e in group.findall("Actors/EntityRef")]
        for private in group.iter("PrivateAction"):
            action = private.find("RoutingAction/FollowTrajectoryAction")
            if action is None:
                continue
            for actor in actors:
                found.setdefault(actor, action)
    for private in root.findall("Storyboard/Init/Actions/Private"):
        ref = str(private.get("entityRef"))
        for action in private.findall("PrivateAction/RoutingAction/FollowTrajectoryAction"):
            found.setdefault(ref, action)
    return found


def _init_poses(reader: _Reader, root: ET.Element) -> dict[str, tuple[float, float, float]]:
    """Entity name -> its Init teleport pose (WorldPosition x, y [m], h [rad])."""
    out: dict[str, tuple[float, float, float]] = {}
    for private in root.findall("Storyboard/Init/Actions/Private"):
        pos = private.find("PrivateAction/TeleportAction/Position/WorldPosition")
        if pos is not None:
            out.setdefault(str(private.get("entityRef")),
                           (reader.number(pos, "x"), reader.number(pos, "y"),
                            reader.number(pos, "h", 0.0)))
    return out


def _pick_entities(reader: _Reader, objects: list[ET.Element], with_trajectory: set[str],
                   placed: set[str]) -> list[ET.Element]:
    """Participant 1 and 2: objects with a trajectory (an ego first), then a misc object
    that only stands where Init puts it.
    """
    moving = [o for o in objects if o.get("name") in with_trajectory]
    standing = [o for o in objects if o.get("name") not in with_trajectory
                and o.get("name") in placed and o.find("MiscObject") is not None]
    ego_names = ("ego", "hero", "vut", "ego_vehicle")
    moving.sort(key=lambda o: str(o.get("name", "")).lower() not in ego_names)
    chosen = (moving + standing)[:2]
    if len(chosen) < 2 or not moving:
        names = [str(o.get("name")) for o in objects]
        raise reader.problem(f"need two entities, at least one with a polyline trajectory "
                             f"(the other may be a misc object placed by Init); found "
                             f"{len(moving)} moving of {len(names)} ({', '.join(names)})")
    return chosen


def _read_case(file: Path, default_id: int) -> tuple[dict[str, Any], list[dict[str, Any]],
                                                       list[pd.DataFrame], list[str]]:
    try:
        root = ET.parse(file).getroot()
    except (OSError, ET.ParseError) as exc:
        raise DataError(DataProblem(file.name, "", None, None,
                                    f"cannot read OpenSCENARIO file: {exc}")) from None
    if root.tag != "OpenSCENARIO" or root.find("FileHeader") is None:
        raise DataError(DataProblem(file.name, "", None, None,
                                    "not an OpenSCENARIO file (no OpenSCENARIO/FileHeader)"))
    reader = _Reader(file, root)
    header = {k[len(PREFIX):]: v for k, v in
              _properties(root.find("FileHeader")).items() if k.startswith(PREFIX)}
    notes: list[str] = []
    actions = _storyboard_trajectories(reader, root)
    poses = _init_poses(reader, root)
    objects = root.findall("Entities/ScenarioObject")
    chosen = _pick_entities(reader, objects, set(actions), set(poses))
    if len(objects) > 2:
        notes.append(f"{file.name}: {len(objects)} entities; read "
                     f"{chosen[0].get('name')} and {chosen[1].get('name')}")
    t0 = float(header.get("t0", 0.0))
    participants: list[dict[str, Any]] = []
    trajectories: list[pd.DataFrame] = []
    times = None
    for number, obj in enumerate(chosen, start=1):
        name = str(obj.get("name"))
        values, offset = _vehicle_row(reader, obj)
        if name in actions:
            t, xr, yr, h = _timed_polyline(reader, actions[name], name)
            if len(t) < 2 or not np.all(np.diff(t) > 0):
                raise reader.problem(f"the vertex times of {name!r} must be strictly "
                                     "increasing (at least two vertices)")
            h = _fill_headings(xr, yr, h)
            t, (xr, yr, h) = _densify(t, [xr, yr, h])
            times = t if times is None else times
        else:  # a misc object standing where Init puts it, sampled like the other one
            if times is None:  # cannot happen: the moving entity comes first
                raise reader.problem(f"{name!r} has no trajectory")
            t = times
            xr, yr, h = (np.full(len(t), v) for v in poses[name])
        x, y = to_cg(xr, yr, h, offset)
        t_rec = t + t0
        participants.append({"participant": number, **values})
        trajectories.append(pd.DataFrame({"participant": number, "t": t_rec, "x": x, "y": y,
                                          "yaw": h, "speed": _cg_speed(t_rec, x, y),
                                          "accel": np.nan}))
    # both records must start together: cut the earlier one at the later start
    start = max(float(tr["t"].iloc[0]) for tr in trajectories)
    for k, tr in enumerate(trajectories):
        if float(tr["t"].iloc[0]) < start - 1e-12:
            cols = ["x", "y", "yaw", "speed"]
            first = {c: float(np.interp(start, tr["t"], tr[c])) for c in cols}
            rest = tr[tr["t"] > start + 1e-9]
            trajectories[k] = pd.concat([pd.DataFrame({"participant": tr["participant"].iloc[0],
                                                       "t": [start], **{c: [first[c]]
                                                                         for c in cols},
                                                       "accel": np.nan}), rest],
                                        ignore_index=True)
            notes.append(f"{file.name}: trajectory of participant {k + 1} cut to the later "
                         f"start at {start:g} s")
    case = _case_row(reader, file, header, default_id, trajectories, participants, root)
    return case, participants, trajectories, notes


def _case_row(reader: _Reader, file: Path, header: dict[str, str], default_id: int,
              trajectories: list[pd.DataFrame], participants: list[dict[str, Any]],
              root: ET.Element) -> dict[str, Any]:
    def get(name: str, fallback: Any, kind: type = float) -> Any:
        if name not in header:
            return fallback
        try:
            return kind(header[name])
        except ValueError:
            raise reader.problem(f"header property {PREFIX}{name}={header[name]!r} is not "
                                 f"a {kind.__name__}", name) from None

    roads: list[Road] = []
    logic = root.find("RoadNetwork/LogicFile")
    if logic is not None and logic.get("filepath"):
        road_file = (file.parent / str(logic.get("filepath"))).resolve()
        if road_file.exists():
            roads = read_opendrive(road_file)
    friction = roads[0].friction if roads else 0.8
    end = trajectories[0].iloc[-1]
    curvature = road_curvature_at(roads, float(end["x"]), float(end["y"])) if roads else 0.0
    case_id = header.get("case_id", str(default_id))
    try:
        cid: Any = int(case_id)
    except ValueError:
        cid = default_id
    # the file's motion may be another than the recorded one (an AEB run): its own flag
    collision = header.get("motion_collides", header.get("collision"))
    return {
        "case_id": cid,
        "accident_type": get("accident_type", IMPORTED_ACCIDENT_TYPE, int),
        "road_friction": get("road_friction", friction),
        "road_surface": header.get("road_surface", "dry"),
        "road_curvature": get("road_curvature", float(np.clip(curvature, -0.2, 0.2))),
        "weight": get("weight", 1.0),
        "collision": None if collision is None else collision == "true",
        "description": header.get("description", f"imported from {file.name}"),
    }


def import_xosc(files: Sequence[str | os.PathLike[str]] | str | os.PathLike[str], *,
                name: str = "") -> Database:
    """Read OpenSCENARIO files (one case each) into a vfs database.

    For every file: the two scenario objects with a polyline trajectory
    (an object named Ego/hero first, else file order) become participants 1
    and 2; their vertices (reference point, converted to the CG with
    :func:`to_cg`) become the trajectories, with the CG speed from the
    positions (second-order finite differences) and the acceleration unknown
    (NaN); gaps wider than the schema's sample spacing are filled by linear
    interpolation, and a trajectory that starts earlier than the other is
    cut to the later start.  Case data come from the vfs header properties
    where present; otherwise friction and road curvature (at participant
    1's last position) from the OpenDRIVE file, accident type 799 (other),
    and the collision flag from a vfs replay of the two trajectories.

    Parameters
    ----------
    files : path or sequence of paths
        ``.xosc`` files.
    name : str
        Database name for ``meta.json``.

    Returns
    -------
    Database
        Normalised and validated; no reconstruction
        (``meta["has_reconstruction"]`` false).

    Raises
    ------
    DataError
        A file outside the subset read (the message names file and element),
        duplicate case ids, or a database that does not validate.
    """
    from vfs.database.validation import validate_database

    paths = [Path(files)] if isinstance(files, str | os.PathLike) else [Path(f) for f in files]
    if not paths:
        raise ParameterError("no OpenSCENARIO file given")
    read = [_read_case(file, k) for k, file in enumerate(paths, start=1)]
    ids = [case["case_id"] for case, _, _, _ in read]
    notes = [note for *_, file_notes in read for note in file_notes]
    dupes = sorted({i for i in ids if ids.count(i) > 1}, key=str)
    if dupes:  # e.g. a case exported with and without a system: number in file order
        ids = list(range(1, len(read) + 1))
        notes.append(f"case ids {dupes} occur more than once: cases numbered 1..{len(ids)} "
                     "in file order")
    cases, parts, trajs = [], [], []
    for cid, (case, participants, trajectories, _) in zip(ids, read, strict=True):
        cases.append({**case, "case_id": cid})
        parts += [{"case_id": cid, **p} for p in participants]
        trajs += [tr.assign(case_id=cid) for tr in trajectories]
    meta = default_meta(name or "imported-openscenario", "vfs db import-xosc",
                        "imported from " + ", ".join(p.name for p in paths))
    meta["has_reconstruction"] = False
    if notes:
        meta["import_notes"] = notes
    from vfs.database.schema import empty_table

    db = Database(pd.DataFrame(cases), pd.DataFrame(parts),
                  pd.concat(trajs, ignore_index=True), empty_table("reconstruction"), meta)
    db = _with_collision_flags(db.normalised())
    validate_database(db)
    return db


def _with_collision_flags(db: Database) -> Database:
    """Fill unknown collision flags by a vfs replay of the recorded trajectories."""
    flags = db.cases["collision"]
    unknown = flags.isna() if flags.dtype == object else pd.Series(False, index=flags.index)
    if not unknown.any():
        return db
    from vfs.simulation import CaseBatch, simulate_cases

    ids = db.cases.loc[unknown, "case_id"].to_numpy()
    res = simulate_cases(CaseBatch.from_database(db, ids, impact_parameters="default"))
    cases = db.cases.copy()
    cases["collision"] = cases["collision"].astype(object)
    cases.loc[unknown, "collision"] = res.precrash.collided
    cases["collision"] = cases["collision"].astype(bool)
    return Database(normalise_table(cases, "cases"), db.participants, db.trajectories,
                    db.reconstruction, db.meta)

