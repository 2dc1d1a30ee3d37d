"""OpenSCENARIO import: the subset vfs writes (:mod:`vfs.interop.openscenario`), from any file.

:func:`import_xosc` reads from an OpenSCENARIO 1.x file two entities
(``Vehicle`` or ``MiscObject``: dimensions, mass, axles), their trajectories
(``FollowTrajectoryAction`` with an inline ``Polyline`` of timed
``WorldPosition`` vertices; a misc object may instead stand where ``Init``
teleports it) and, from the OpenDRIVE road, its friction and curvature.  The
vfs properties of a file written by vfs restore the case exactly; missing
vehicle data take the defaults of :class:`vfs.physics.vehicle.VehicleParams`.
Reading needs no optional package.  Units: m, s, rad, kg, m/s.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database import Database, default_meta
from vfs.database.schema import MAX_SAMPLE_SPACING, empty_table, normalise_table
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.interop.opendrive import Road, read_opendrive, road_curvature_at
from vfs.interop.openscenario import PREFIX, to_cg
from vfs.physics.vehicle import VehicleParams

__all__ = ["IMPORTED_ACCIDENT_TYPE", "import_xosc"]

#: Accident type of imported cases without a vfs header ("other").
IMPORTED_ACCIDENT_TYPE = 799


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

