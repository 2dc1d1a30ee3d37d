"""The Euro NCAP AEB Car-to-Car test matrix as a database (``--db euro-ncap-c2c``).

The protocol is data: ``scenarios/euro-ncap-c2c/protocol.toml`` at the
repository root (speed grids, overlaps and their sign convention, CCRb target
deceleration and headway, turning radii, vehicle dimensions, colour bands and
points, each value with the protocol section it comes from or marked
ASSUMPTION).  :func:`protocol_path` is the only place that knows where it is.

:func:`ncap_test_matrix` expands the scenarios into one row per test (scenario x VUT
speed x GVT speed x overlap / impact location x deceleration x headway);
:func:`build_euro_ncap_database` turns every test into a case of vfs's database
format: participant 1 the vehicle under test (VUT), participant 2 the global
vehicle target (GVT), recorded trajectories the pre-crash re-simulation
follows (straight constant-speed approaches, the GVT braking in CCRb, the VUT's
left turn in CCFtap, the GVT crossing in CCCscp, the GVT's lane change in
CCFhol), no reconstruction: the protocol's measures are the impact speed and
the speed reduction, scored by :mod:`vfs.analysis.euro_ncap`.

The undisturbed record of every test collides at ``impact_time`` (the protocol's
impact location); coordinates follow ISO 8855 (x along the VUT's approach, y to
its left), SI units.  The database is written once into the package
(``scenarios/databases/euro-ncap-c2c``, like the crash-test database) with
``python -m vfs.scenarios.euro_ncap``; ``tests/scenarios/test_euro_ncap.py`` checks that
the bundled copy equals a fresh build.
"""

from __future__ import annotations

import math
import os
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database.database import Database, default_meta
from vfs.database.schema import TABLE_NAMES, empty_table, normalise_table
from vfs.errors import DataError, DataProblem
from vfs.units import KMH_PER_MS

#: ``--db`` name of the test matrix (a bundled database, vfs.database.source).
DATABASE_NAME = "euro-ncap-c2c"

#: Scenario kinds the builder knows (``kind`` in protocol.toml).
KINDS = ("rear", "turn", "crossing", "head_on", "head_on_lane_change")

#: Extra columns of the cases table (SI; NaN where a test has no such parameter).
MATRIX_COLUMNS = ("ncap_scenario", "ncap_vut_speed", "ncap_gvt_speed", "ncap_overlap",
                  "ncap_gvt_deceleration", "ncap_headway", "ncap_turn_radius",
                  "ncap_impact_location")

#: Unit and description of the matrix columns (``meta.json`` key ``columns``).
MATRIX_COLUMN_UNITS: dict[str, dict[str, str]] = {
    "ncap_scenario": {"unit": "", "description": "Euro NCAP test scenario (CCRs, CCRm, ...)"},
    "ncap_vut_speed": {"unit": "m/s", "description": "test speed of the vehicle under test"},
    "ncap_gvt_speed": {"unit": "m/s", "description": "speed of the global vehicle target"},
    "ncap_overlap": {"unit": "-", "description": "signed overlap share (protocol convention)"},
    "ncap_gvt_deceleration": {"unit": "m/s^2",
                              "description": "deceleration of the braking target (magnitude)"},
    "ncap_headway": {"unit": "m", "description": "gap between VUT and GVT at braking onset"},
    "ncap_turn_radius": {"unit": "m", "description": "radius of the VUT's turning path"},
    "ncap_impact_location": {"unit": "-",
                             "description": "impact point as share of the GVT's length from "
                             "its front"},
}


def protocol_path() -> Path:
    """The protocol file, ``scenarios/euro-ncap-c2c/protocol.toml`` of the catalogue."""
    from vfs.catalog import catalog_path

    return catalog_path("scenarios", DATABASE_NAME, "protocol.toml")


def read_protocol(path: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """The protocol file as a dict (units as named in its fields: km/h, m, m/s2, %).

    Raises
    ------
    DataError
        The file is missing or not valid TOML.
    """
    file = Path(path) if path is not None else protocol_path()
    try:
        with open(file, "rb") as f:
            return tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"{file}: cannot read the Euro NCAP protocol ({err})")) from err


@dataclass(frozen=True)
class Car:
    """Outline and mass of a test participant [kg, m]."""

    mass: float
    length: float
    width: float
    wheelbase: float
    cg_to_front_axle: float
    front_overhang: float
    track_width: float
    cg_height: float

    @property
    def cg_to_front(self) -> float:
        """Centre of gravity to the front face [m]."""
        return self.cg_to_front_axle + self.front_overhang

    @property
    def cg_to_rear(self) -> float:
        """Centre of gravity to the rear face [m]."""
        return self.length - self.cg_to_front

    def row(self, case_id: int, participant: int) -> dict[str, Any]:
        """Participants-table row (SI)."""
        return {"case_id": case_id, "participant": participant, "mass": self.mass,
                "yaw_inertia": math.nan, "length": self.length, "width": self.width,
                "wheelbase": self.wheelbase, "cg_to_front_axle": self.cg_to_front_axle,
                "front_overhang": self.front_overhang, "track_width": self.track_width,
                "cg_height": self.cg_height, "vehicle_class": "car", "fixed_object": False}


def _car(table: dict[str, Any]) -> Car:
    return Car(**{name: float(table[f"{name}_{'kg' if name == 'mass' else 'm'}"])
                  for name in Car.__dataclass_fields__})


def vehicles(protocol: dict[str, Any]) -> tuple[Car, Car]:
    """The VUT and the GVT of ``protocol``."""
    return _car(protocol["vut"]), _car(protocol["gvt"])


def lateral_offset(overlap: float, vut_width: float, gvt_width: float,
                   negative_side: str) -> float:
    """Lateral position of the GVT's centreline relative to the VUT's [m], ISO 8855 (+y left).

    Parameters
    ----------
    overlap : float
        Share of the VUT's width overlapping the GVT [-], signed (``-0.5`` for -50 %).
    vut_width, gvt_width : float
        Widths [m].
    negative_side : {"left", "right"}
        Side of the VUT on which a negative overlap puts the GVT (protocol.toml
        ``[overlap] negative_side``).

    Returns
    -------
    float
        0 for 100 %; otherwise the offset that leaves ``|overlap| x vut_width``
        of the two widths overlapping.
    """
    if negative_side not in ("left", "right"):
        raise DataError(DataProblem("meta", "", None, None,
                                    f"[overlap] negative_side must be 'left' or 'right', got "
                                    f"{negative_side!r}"))
    share = abs(overlap)
    if share >= 1.0:
        return 0.0
    magnitude = max(0.0, 0.5 * (vut_width + gvt_width) - share * vut_width)
    left = (overlap < 0) == (negative_side == "left")
    return magnitude if left else -magnitude


def ncap_test_matrix(protocol: dict[str, Any] | None = None) -> pd.DataFrame:
    """One row per test of the protocol, in case order (SI units).

    Returns
    -------
    pandas.DataFrame
        ``case_id`` (1...), ``ncap_scenario``, ``ncap_vut_speed`` and
        ``ncap_gvt_speed`` [m/s], ``ncap_overlap`` [-] (signed share),
        ``ncap_gvt_deceleration`` [m/s^2] (magnitude), ``ncap_headway`` [m],
        ``ncap_turn_radius`` [m], ``ncap_impact_location`` [-] (share of the
        GVT's length from its front), ``kind``, ``accident_type``.
    """
    protocol = read_protocol() if protocol is None else protocol
    rows: list[dict[str, Any]] = []
    for name, sc in protocol["scenarios"].items():
        kind = sc["kind"]
        if kind not in KINDS:
            raise DataError(DataProblem("meta", "", None, None,
                                        f"scenario {name}: unknown kind {kind!r}; known: "
                                        f"{', '.join(KINDS)}"))
        vut = [float(v) for v in sc["vut_speeds_kmh"]]
        gvt = [float(v) for v in sc["gvt_speeds_kmh"]]
        if sc.get("gvt_speed_per_vut_speed"):
            if len(gvt) != len(vut):
                raise DataError(DataProblem("meta", "", None, None,
                                            f"scenario {name}: gvt_speed_per_vut_speed needs "
                                            "as many GVT speeds as VUT speeds"))
            pairs = list(zip(vut, gvt, strict=True))
        else:
            pairs = [(v, g) for v in vut for g in gvt]
        radii = sc.get("turn_radii_m")
        if radii is not None and len(radii) != len(vut):
            raise DataError(DataProblem("meta", "", None, None,
                                        f"scenario {name}: one turn radius per VUT speed"))
        for v, g in pairs:
            radius = float(radii[vut.index(v)]) if radii is not None else math.nan
            for ov in sc.get("overlaps_pct", [100]):
                for loc in sc.get("impact_location_pct", [math.nan]):
                    for dec in sc.get("gvt_decelerations_ms2", [math.nan]):
                        for gap in sc.get("headways_m", [math.nan]):
                            rows.append({
                                "ncap_scenario": name, "ncap_vut_speed": v / KMH_PER_MS,
                                "ncap_gvt_speed": g / KMH_PER_MS,
                                "ncap_overlap": float(ov) / 100.0,
                                "ncap_gvt_deceleration": float(dec),
                                "ncap_headway": float(gap), "ncap_turn_radius": radius,
                                "ncap_impact_location": float(loc) / 100.0,
                                "kind": kind, "accident_type": int(sc["accident_type"])})
    table = pd.DataFrame(rows)
    table.insert(0, "case_id", np.arange(1, len(table) + 1, dtype=np.int64))
    return table


# ----------------------------------------------------------------------------- geometry

@dataclass(frozen=True)
class Motion:
    """A participant's record: CG position [m], yaw [rad], speed [m/s], accel [m/s^2]."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray
    accel: np.ndarray


def _straight(t: np.ndarray, x_at: float, y: float, yaw: float, speed: float,
              t_at: float) -> Motion:
    """Constant speed along ``yaw`` through (x_at, y) at ``t_at``."""
    s = speed * (t - t_at)
    return Motion(x_at + s * math.cos(yaw), y + s * math.sin(yaw) + 0.0 * t,
                  np.full_like(t, yaw), np.full_like(t, speed), np.zeros_like(t))


def _turning_arc(s: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CG path of a left turn through 90 deg: straight (s < 0), arc, straight along +y [m, rad]."""
    quarter = 0.5 * math.pi * radius
    on_arc = np.clip(s, 0.0, quarter) / radius
    x = np.where(s < 0, s, radius * np.sin(on_arc))
    y = np.where(s < 0, 0.0, radius * (1.0 - np.cos(on_arc)))
    after = np.maximum(s - quarter, 0.0)
    return x, y + after, on_arc


def turn_sync_angle(radius: float, cg_to_front: float, lane_offset: float) -> float:
    """Heading [rad] of the turning VUT when its front centre reaches ``y = lane_offset``.

    Solves ``R (1 - cos a) + d sin a = lane_offset`` on [0, pi/2] by bisection.
    """
    def front_y(a: float) -> float:
        return radius * (1.0 - math.cos(a)) + cg_to_front * math.sin(a)

    if front_y(0.5 * math.pi) < lane_offset:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"turn radius {radius} m never reaches the lane at "
                                    f"{lane_offset} m"))
    lo, hi = 0.0, 0.5 * math.pi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if front_y(mid) < lane_offset else (lo, mid)
    return 0.5 * (lo + hi)


def _accel(speed: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.gradient(speed, t) if t.size > 1 else np.zeros_like(t)


def _braking_gvt(t: np.ndarray, rear_at_brake: float, speed: float, decel: float,
                 t_brake: float, cg_to_rear: float, y: float) -> Motion:
    """GVT at ``speed`` braking at ``decel`` from ``t_brake`` to standstill (CCRb)."""
    tau = np.clip(t - t_brake, None, speed / decel)
    s = np.where(tau < 0, speed * tau, speed * tau - 0.5 * decel * tau**2)
    v = np.where(tau < 0, speed, speed - decel * tau)
    braking = (t >= t_brake) & (v > 0)
    return Motion(rear_at_brake + cg_to_rear + s, np.full_like(t, y), np.zeros_like(t),
                  np.maximum(v, 0.0), np.where(braking, -decel, 0.0))


def ccrb_impact_after_braking(headway: float, speed: float, decel: float) -> float:
    """Time [s] from the GVT's brake onset to the undisturbed impact in CCRb.

    The VUT keeps ``speed``; the GVT, ``headway`` ahead at the same speed,
    brakes at ``decel`` to standstill: ``headway = decel t^2 / 2`` while it
    moves, ``speed t = headway + speed^2 / (2 decel)`` once it stands.
    """
    t_moving = math.sqrt(2.0 * headway / decel)
    if t_moving <= speed / decel:
        return t_moving
    return (headway + speed**2 / (2.0 * decel)) / speed


def ncap_test_motions(test: pd.Series, vut: Car, gvt: Car, protocol: dict[str, Any]
                 ) -> tuple[np.ndarray, float, Motion, Motion]:
    """Time axis [s], undisturbed impact time [s] and the records of VUT and GVT of one test."""
    general = protocol["protocol"]
    sc = protocol["scenarios"][test["ncap_scenario"]]
    dt, lead = float(general["time_step_s"]), float(general["lead_time_s"])
    after = float(general["after_impact_s"])
    lane = float(general["lane_width_m"])
    side = protocol["overlap"]["negative_side"]
    v, g, kind = float(test["ncap_vut_speed"]), float(test["ncap_gvt_speed"]), test["kind"]
    t_impact = lead
    if kind == "rear" and not math.isnan(test["ncap_gvt_deceleration"]):
        t_brake = float(sc["steady_before_braking_s"])
        t_impact = t_brake + ccrb_impact_after_braking(float(test["ncap_headway"]), g,
                                                       float(test["ncap_gvt_deceleration"]))
    n = int(round((t_impact + after) / dt))
    t = np.round(np.arange(n + 1) * dt, 10)
    front_v = vut.cg_to_front
    offset = lateral_offset(float(test["ncap_overlap"]), vut.width, gvt.width, side)
    if kind == "rear":
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        if math.isnan(test["ncap_gvt_deceleration"]):
            m2 = _straight(t, gvt.cg_to_rear, offset, 0.0, g, t_impact)
        else:
            rear_at_brake = float(test["ncap_headway"])  # VUT front at x = 0 at the onset
            m1 = _straight(t, -front_v, 0.0, 0.0, v, t_brake)
            m2 = _braking_gvt(t, rear_at_brake, g, float(test["ncap_gvt_deceleration"]),
                              t_brake, gvt.cg_to_rear, offset)
    elif kind == "turn":
        radius = float(test["ncap_turn_radius"])
        angle = turn_sync_angle(radius, front_v, lane)
        s = v * (t - t_impact) + radius * angle
        x, y, yaw = _turning_arc(s, radius)
        m1 = Motion(x, y, yaw, np.full_like(t, v), np.zeros_like(t))
        sync_x = radius * math.sin(angle) + front_v * math.cos(angle)
        m2 = _straight(t, sync_x + gvt.cg_to_front, lane, math.pi, g, t_impact)
    elif kind == "crossing":
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        loc = float(test["ncap_impact_location"])
        sign = 1.0 if sc.get("gvt_from", "right") == "right" else -1.0
        # the VUT's front centre meets the GVT's side loc x length behind its front
        cg_y = -sign * (gvt.cg_to_front - loc * gvt.length)
        m2 = _straight(t, 0.5 * gvt.width, cg_y, sign * 0.5 * math.pi, g, t_impact)
    elif kind == "head_on":
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        m2 = _straight(t, gvt.cg_to_front, offset, math.pi, g, t_impact)
    else:  # head_on_lane_change
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        end = t_impact - float(sc["lane_change_end_before_impact_s"])
        duration = float(sc["lane_change_duration_s"])
        phase = np.clip((t - (end - duration)) / duration, 0.0, 1.0)
        y = offset + lane * 0.5 * (1.0 + np.cos(math.pi * phase))
        vy = np.where((phase > 0) & (phase < 1),
                      -lane * 0.5 * math.pi / duration * np.sin(math.pi * phase), 0.0)
        x = gvt.cg_to_front - g * (t - t_impact)
        speed = np.hypot(g, vy)
        m2 = Motion(x, y, np.arctan2(vy, -g), speed, _accel(speed, t))
    return t, t_impact, m1, m2


def _frame(case_id: int, participant: int, t: np.ndarray, m: Motion) -> pd.DataFrame:
    return pd.DataFrame({"case_id": case_id, "participant": participant, "t": t, "x": m.x,
                         "y": m.y, "yaw": m.yaw, "speed": m.speed, "accel": m.accel})


def _describe(test: pd.Series) -> str:
    parts = [f"Euro NCAP {test['ncap_scenario']}: VUT {test['ncap_vut_speed'] * KMH_PER_MS:g} km/h",
             f"GVT {test['ncap_gvt_speed'] * KMH_PER_MS:g} km/h"]
    if test["kind"] in ("rear", "head_on", "head_on_lane_change"):
        parts.append(f"overlap {100 * test['ncap_overlap']:+g} %")
    if not math.isnan(test["ncap_gvt_deceleration"]):
        parts.append(f"GVT braking {test['ncap_gvt_deceleration']:g} m/s^2 at headway "
                     f"{test['ncap_headway']:g} m")
    if not math.isnan(test["ncap_turn_radius"]):
        parts.append(f"turn radius {test['ncap_turn_radius']:g} m")
    if not math.isnan(test["ncap_impact_location"]):
        parts.append(f"impact at {100 * test['ncap_impact_location']:g} % of the GVT's length")
    return ", ".join(parts)


def build_euro_ncap_database(protocol: dict[str, Any] | None = None) -> Database:
    """The whole test matrix as a database (SI units; see the module's description).

    Parameters
    ----------
    protocol : dict, optional
        :func:`read_protocol`'s result; default the repository's protocol file.

    Returns
    -------
    Database
        One case per test (:func:`ncap_test_matrix`), participant 1 the VUT,
        participant 2 the GVT, no reconstruction
        (``meta["has_reconstruction"] = False``).
    """
    protocol = read_protocol() if protocol is None else protocol
    matrix = ncap_test_matrix(protocol)
    vut, gvt = vehicles(protocol)
    friction = float(protocol["protocol"]["road_friction"])
    cases, parts, trajs = [], [], []
    for _, test in matrix.iterrows():
        cid = int(test["case_id"])
        t, _, m1, m2 = ncap_test_motions(test, vut, gvt, protocol)
        trajs += [_frame(cid, 1, t, m1), _frame(cid, 2, t, m2)]
        parts += [vut.row(cid, 1), gvt.row(cid, 2)]
        cases.append({"case_id": cid, "accident_type": int(test["accident_type"]),
                      "road_friction": friction, "road_surface": "dry",
                      "road_curvature": 0.0, "weight": 1.0, "collision": True,
                      "description": _describe(test),
                      **{c: test[c] for c in MATRIX_COLUMNS}})
    frames = {"cases": pd.DataFrame(cases), "participants": pd.DataFrame(parts),
              "trajectories": pd.concat(trajs, ignore_index=True)}
    tables = {name: normalise_table(frames.get(name, empty_table(name)), name)
              for name in TABLE_NAMES}
    meta = default_meta(
        name=DATABASE_NAME, created_by="vfs.scenarios.euro_ncap",
        description=f"Euro NCAP AEB Car-to-Car test matrix ({len(matrix)} tests: "
        + ", ".join(f"{k} {v}" for k, v in matrix["ncap_scenario"].value_counts(
            sort=False).items())
        + "); participant 1 the VUT, 2 the GVT; protocol: scenarios/euro-ncap-c2c/"
        "protocol.toml (sources and assumptions there)")
    meta["has_reconstruction"] = False
    meta["equip"] = "1"  # the VUT carries the system; `vfs study` takes it as --equip default
    meta["test_protocol"] = str(protocol["protocol"]["test_protocol"])
    meta["columns"] = {"cases": MATRIX_COLUMN_UNITS}
    return Database(**tables, meta=meta)


def main(argv: list[str] | None = None) -> int:
    """Write the database to the folder given as the only argument (default the bundled one)."""
    from vfs.database.io import save_database

    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0] if args else os.path.join("scenarios", "databases", DATABASE_NAME))
    save_database(build_euro_ncap_database(), folder)
    print(f"wrote {folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
