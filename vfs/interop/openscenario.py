"""OpenSCENARIO 1.3 export of cases (two vehicles, timed polylines) and the reference point.

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
  friction, road curvature, collision, ...), so that an import restores
  the case.

:func:`vfs.interop.scenario_import.import_xosc` reads that subset back.

Units: m, s, rad, kg, m/s.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.accident_types import accident_type_label
from vfs.atomic import write_text
from vfs.database import Database
from vfs.errors import DataError, DataProblem
from vfs.interop.extra import require_extra
from vfs.interop.motion import CaseMotion, ParticipantMotion, find_case, recorded_motion
from vfs.interop.opendrive import (
    LANE_WIDTH,
    CaseRoads,
    case_roads,
    opendrive_document,
)

__all__ = [
    "DEFAULT_HEIGHTS",
    "ENTITY_NAMES",
    "OSC_MINOR_VERSION",
    "PREFIX",
    "WHEEL_DIAMETER",
    "XoscExport",
    "bounding_box_center",
    "export_case",
    "reference_offset",
    "scenario_document",
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
#: Decimals written for positions [m] (1 micrometre), headings [rad] and vertex times [s].
POSITION_DECIMALS, HEADING_DECIMALS, TIME_DECIMALS = 6, 9, 9
#: Prefix of the vfs properties.
PREFIX = "vfs."


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


def _world_position(xosc: Any, x: float, y: float, h: float) -> Any:
    """A WorldPosition on the ground, rounded (:data:`POSITION_DECIMALS` etc.)."""
    return xosc.WorldPosition(round(float(x), POSITION_DECIMALS),
                              round(float(y), POSITION_DECIMALS), 0.0,
                              round(float(h), HEADING_DECIMALS))


def _trajectory(xosc: Any, name: str, motion: ParticipantMotion, offset: float,
                t_start: float) -> Any:
    xr, yr = to_reference(motion.x, motion.y, motion.yaw, offset)
    positions = [_world_position(xosc, a, b, h) for a, b, h in zip(xr, yr, motion.yaw,
                                                                   strict=True)]
    times = [round(float(t - t_start), TIME_DECIMALS) for t in motion.t]
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
    t_end = round(float(max(m.t[-1] for m in motion.participants)) - t_start, TIME_DECIMALS)
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
            _world_position(xosc, xr[0], yr[0], m.yaw[0])))
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
