"""The Euro NCAP Car-to-Car test matrix as a database (``--db euro-ncap-c2c``).

One named protocol version end to end.  Each version is one data file in
``scenarios/euro-ncap-c2c`` and one bundled database:

============  ======================  =================================================
version       ``--db``                protocol file
============  ======================  =================================================
2026          ``euro-ncap-c2c``       ``protocol.toml`` (Frontal Collisions v1.1, default)
2023          ``euro-ncap-c2c-2023``  ``protocol-2023.toml`` (AEB Car-to-Car v4.3.1)
============  ======================  =================================================

Each file holds the speed grids, lateral positions (2026: impact location, 0 %
at the VUT's right edge, 50 % full overlap; 2023: signed overlap), the CCRb
deceleration and headway, the CCFtap path radii, the CCFhol lane change, the
CCCscp impact point, the vehicles, colour bands, points and maxima, each value
with the section it comes from or marked ASSUMPTION.  :func:`protocol_path` is
the only place that knows where they are; :func:`read_protocol` checks that
every table the builder and the scoring need is there.

:func:`ncap_test_matrix` expands the scenarios into one row per test;
:func:`build_euro_ncap_database` turns every test into a case of vfs's database
format: participant 1 the vehicle under test (VUT), participant 2 the global
vehicle target (GVT), recorded trajectories the pre-crash re-simulation
follows (straight approaches, the GVT braking in CCRb, the VUT's
clothoid-arc-clothoid left turn in CCFtap, the GVT crossing in CCCscp, the
GVT's lane change in CCFhol), no reconstruction: the protocol's measures are
the impact speed and the speed reduction, scored by :mod:`vfs.analysis.euro_ncap`.

The undisturbed record of every test collides at ``ncap_impact_time`` at the
protocol's impact point; coordinates follow ISO 8855 (x along the VUT's
approach, y to its left), SI units.  The databases are written once into the
catalogue (``scenarios/databases/<name>``) with ``python -m
vfs.scenarios.euro_ncap``; ``tests/scenarios/test_euro_ncap.py`` checks that the
bundled copies equal a fresh build.  Two databases rather than a ``--protocol``
flag: a bundled database is what study tasks carry to the workers by name, what
``vfs study replay`` and ``vfs db`` find in any install, and what the study's
data hash covers; a flag would have to travel beside ``--db`` through all of them.
"""

from __future__ import annotations

import itertools
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
from vfs.errors import DataError, DataProblem, DefinitionError, VfsError
from vfs.units import KMH_PER_MS

#: Protocol versions: version -> (``--db`` name, protocol file in ``scenarios/euro-ncap-c2c``).
PROTOCOL_VERSIONS: dict[str, tuple[str, str]] = {
    "2026": ("euro-ncap-c2c", "protocol.toml"),
    "2023": ("euro-ncap-c2c-2023", "protocol-2023.toml"),
}

#: The version ``--db euro-ncap-c2c`` follows.
DEFAULT_VERSION = "2026"

#: ``--db`` name of the default version's matrix (a bundled database, vfs.database.source).
DATABASE_NAME = PROTOCOL_VERSIONS[DEFAULT_VERSION][0]

#: ``--db`` names of every version.
DATABASE_NAMES = tuple(name for name, _ in PROTOCOL_VERSIONS.values())

#: Scenario kinds the builder knows (``kind`` in the protocol file).
KINDS = ("rear", "turn", "crossing", "head_on", "head_on_lane_change")

#: Colour-band rules the scoring knows (``band`` in the protocol file) and the
#: ``[assessment]`` table each one needs.
BANDS = {"mitigation_or_avoidance": "mitigation_or_avoidance", "avoidance": "avoidance",
         "mitigation": "mitigation"}

#: Lateral conventions (``[lateral] convention``).
LATERAL_CONVENTIONS = ("impact_location", "overlap")

#: Extra columns of the cases table (SI; NaN where a test has no such parameter).
MATRIX_COLUMNS = ("ncap_protocol", "ncap_scenario", "ncap_vut_speed", "ncap_gvt_speed",
                  "ncap_overlap", "ncap_lateral_location", "ncap_gvt_deceleration",
                  "ncap_headway", "ncap_turn_radius", "ncap_impact_location",
                  "ncap_gvt_side", "ncap_impact_time")

#: Unit and description of the matrix columns (``meta.json`` key ``columns``).
MATRIX_COLUMN_UNITS: dict[str, dict[str, str]] = {
    "ncap_protocol": {"unit": "", "description": "protocol version (2026, 2023)"},
    "ncap_scenario": {"unit": "", "description": "Euro NCAP test scenario (CCRs, CCRm, ...)"},
    "ncap_vut_speed": {"unit": "m/s", "description": "test speed of the vehicle under test "
                       "(0: start from stop)"},
    "ncap_gvt_speed": {"unit": "m/s", "description": "speed of the global vehicle target"},
    "ncap_overlap": {"unit": "-", "description": "signed overlap share (2023 convention)"},
    "ncap_lateral_location": {"unit": "-", "description": "impact location across the VUT's "
                              "front (2026: 0 right edge, 0.5 centre, 1 left edge)"},
    "ncap_gvt_deceleration": {"unit": "m/s^2",
                              "description": "deceleration of the braking target (magnitude)"},
    "ncap_headway": {"unit": "m", "description": "gap between VUT and GVT at braking onset"},
    "ncap_turn_radius": {"unit": "m", "description": "radius of the VUT's turning path"},
    "ncap_impact_location": {"unit": "-",
                             "description": "impact point as share of the GVT's length from "
                             "its front"},
    "ncap_gvt_side": {"unit": "-", "description": "crossing GVT from the VUT's right (+1, "
                      "nearside) or left (-1, farside)"},
    "ncap_impact_time": {"unit": "s", "description": "time of the undisturbed impact"},
}


def protocol_version_of(database: str) -> str:
    """The protocol version of a ``--db`` name of the matrix.

    Raises
    ------
    DataError
        Not a Euro NCAP matrix name.
    """
    for version, (name, _) in PROTOCOL_VERSIONS.items():
        if name == database:
            return version
    raise DataError(DataProblem("meta", "", None, None,
                                f"{database!r} is not a Euro NCAP matrix; known: "
                                f"{', '.join(DATABASE_NAMES)}"))


def protocol_path(version: str = DEFAULT_VERSION) -> Path:
    """The protocol file of ``version`` in the catalogue (``scenarios/euro-ncap-c2c/...``).

    Raises
    ------
    DataError
        Unknown version.
    """
    from vfs.catalog import catalog_path

    if version not in PROTOCOL_VERSIONS:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"unknown Euro NCAP protocol version {version!r}; known: "
                                    f"{', '.join(PROTOCOL_VERSIONS)}"))
    return catalog_path("scenarios", "euro-ncap-c2c", PROTOCOL_VERSIONS[version][1])


def _require(file: Path, table: dict[str, Any], where: str, keys: tuple[str, ...]) -> None:
    """Raise :class:`DefinitionError` for the first of ``keys`` missing from ``table``."""
    for key in keys:
        if key not in table:
            field = f"{where}.{key}" if where else key
            raise DefinitionError(str(file), field,
                                  f"the Euro NCAP protocol file has no [{field}] (table or "
                                  "field); every version's file needs it",
                                  "see scenarios/euro-ncap-c2c/protocol.toml")


def check_protocol(protocol: dict[str, Any], file: str | os.PathLike[str] = "<protocol>"
                   ) -> None:
    """Check that a protocol dict has every table and field the builder and the scoring read.

    Raises
    ------
    DefinitionError
        Naming the file and the missing table or field (e.g. ``assessment.avoidance``).
    """
    path = Path(file)
    _require(path, protocol, "", ("protocol", "lateral", "vut", "gvt", "scenarios",
                                  "assessment"))
    _require(path, protocol["protocol"], "protocol",
             ("name", "version", "test_protocol", "assessment", "time_step_s", "lead_time_s",
              "after_impact_s", "road_friction", "lane_width_m"))
    conv = protocol["lateral"].get("convention")
    if conv not in LATERAL_CONVENTIONS:
        raise DefinitionError(str(path), "lateral.convention", f"got {conv!r}",
                              " or ".join(LATERAL_CONVENTIONS))
    if conv == "overlap":
        _require(path, protocol["lateral"], "lateral", ("negative_side",))
    for part in ("vut", "gvt"):
        _require(path, protocol[part], part, tuple(
            f"{name}_{'kg' if name == 'mass' else 'm'}" for name in Car.__dataclass_fields__))
    _require(path, protocol["assessment"], "assessment", ("points",))
    for name, sc in protocol["scenarios"].items():
        where = f"scenarios.{name}"
        _require(path, sc, where, ("description", "kind", "vut_speeds_kmh", "gvt_speeds_kmh",
                                   "measure", "band", "max_points", "accident_type"))
        if sc["kind"] not in KINDS:
            raise DefinitionError(str(path), f"{where}.kind", f"unknown kind {sc['kind']!r}",
                                  ", ".join(KINDS))
        if sc["band"] not in BANDS:
            raise DefinitionError(str(path), f"{where}.band", f"unknown band {sc['band']!r}",
                                  ", ".join(BANDS))
        _require(path, protocol["assessment"], "assessment", (BANDS[sc["band"]],))
        lateral = "impact_locations_pct" if conv == "impact_location" else "overlaps_pct"
        if sc["kind"] in ("rear", "head_on", "head_on_lane_change"):
            _require(path, sc, where, (lateral,))
        if sc["kind"] == "turn" and not ({"clothoid_angles_deg", "clothoid_duration_s"} & set(sc)):
            _require(path, sc, where, ("clothoid_angles_deg",))
        extra = {"turn": ("turn_radii_m",),
                 "crossing": ("gvt_impact_location_pct",),
                 "head_on_lane_change": ("lane_change_width_m", "lane_change_lengths_m",
                                         "lane_change_end_ttc_s")}.get(sc["kind"], ())
        _require(path, sc, where, extra)
        if 0 in sc["vut_speeds_kmh"]:
            _require(path, sc, where, ("start_from_stop_distance_m",
                                       "start_from_stop_accel_ms2"))


def read_protocol(path: str | os.PathLike[str] | None = None, *,
                  version: str = DEFAULT_VERSION) -> dict[str, Any]:
    """A protocol file as a dict (units as named in its fields: km/h, m, m/s2, %), checked.

    Parameters
    ----------
    path : path, optional
        The file; default the catalogue's file of ``version``.
    version : str
        ``"2026"`` (default) or ``"2023"``; ignored when ``path`` is given.

    Raises
    ------
    DataError
        The file is missing or not valid TOML.
    DefinitionError
        A table or field is missing (:func:`check_protocol`).
    """
    file = Path(path) if path is not None else protocol_path(version)
    try:
        with open(file, "rb") as f:
            protocol = tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"{file}: cannot read the Euro NCAP protocol ({err})")) from err
    check_protocol(protocol, file)
    return protocol


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
    """Lateral position of the GVT's centreline relative to the VUT's [m] (2023 overlap).

    ISO 8855 (+y left).

    Parameters
    ----------
    overlap : float
        Share of the VUT's width overlapping the GVT [-], signed (``-0.5`` for -50 %).
    vut_width, gvt_width : float
        Widths [m].
    negative_side : {"left", "right"}
        Side of the VUT on which a negative overlap puts the GVT (``[lateral] negative_side``).

    Returns
    -------
    float
        0 for 100 %; otherwise the offset that leaves ``|overlap| x vut_width``
        of the two widths overlapping.
    """
    if negative_side not in ("left", "right"):
        raise DataError(DataProblem("meta", "", None, None,
                                    f"[lateral] negative_side must be 'left' or 'right', got "
                                    f"{negative_side!r}"))
    share = abs(overlap)
    if share >= 1.0:
        return 0.0
    magnitude = max(0.0, 0.5 * (vut_width + gvt_width) - share * vut_width)
    left = (overlap < 0) == (negative_side == "left")
    return magnitude if left else -magnitude


def impact_location_offset(location: float, vut_width: float) -> float:
    """Lateral position [m] of the GVT's centreline for a 2026 impact location, ISO 8855.

    The impact location is where the GVT's centreline meets the VUT's front:
    0 at the VUT's right edge (``-vut_width / 2``), 0.5 its centre (full
    overlap), 1 its left edge.

    >>> impact_location_offset(0.5, 1.8), impact_location_offset(0.0, 1.8)
    (0.0, -0.9)
    """
    return (float(location) - 0.5) * vut_width


def _pairs(name: str, sc: dict[str, Any]) -> list[tuple[float, float]]:
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
    excluded = {(float(v), float(g)) for v, g in sc.get("exclude_pairs_kmh", [])}
    return [p for p in pairs if p not in excluded]


def ncap_test_matrix(protocol: dict[str, Any] | None = None) -> pd.DataFrame:
    """One row per test of the protocol, in case order (SI units).

    Returns
    -------
    pandas.DataFrame
        ``case_id`` (1...), the :data:`MATRIX_COLUMNS` but ``ncap_impact_time``
        (speeds [m/s], shares [-], deceleration [m/s^2], headway and radius
        [m]), ``kind``, ``accident_type``.
    """
    protocol = read_protocol() if protocol is None else protocol
    version = str(protocol["protocol"]["version"])
    by_location = protocol["lateral"]["convention"] == "impact_location"
    rows: list[dict[str, Any]] = []
    for name, sc in protocol["scenarios"].items():
        kind = sc["kind"]
        if kind not in KINDS:
            raise DataError(DataProblem("meta", "", None, None,
                                        f"scenario {name}: unknown kind {kind!r}; known: "
                                        f"{', '.join(KINDS)}"))
        vut = [float(v) for v in sc["vut_speeds_kmh"]]
        radii = sc.get("turn_radii_m")
        if radii is not None and len(radii) != len(vut):
            raise DataError(DataProblem("meta", "", None, None,
                                        f"scenario {name}: one turn radius per VUT speed"))
        if kind in ("rear", "head_on", "head_on_lane_change"):
            laterals = [(math.nan, float(x) / 100.0) for x in sc["impact_locations_pct"]] \
                if by_location else [(float(x) / 100.0, math.nan) for x in sc["overlaps_pct"]]
        else:
            laterals = [(math.nan, math.nan)]
        loc = float(sc.get("gvt_impact_location_pct", math.nan)) / 100.0
        sides = sc.get("gvt_from", ["right"]) if kind == "crossing" else [None]
        sides = [sides] if isinstance(sides, str) else sides
        for v, g in _pairs(name, sc):
            radius = float(radii[vut.index(v)]) if radii is not None else math.nan
            gaps = ([float(h) for h in sc["headways_m"]] if "headways_m" in sc else
                    [v / KMH_PER_MS * float(h) for h in sc["headway_times_s"]]
                    if "headway_times_s" in sc else [math.nan])
            for (overlap, lateral), dec, gap, side in itertools.product(
                    laterals, sc.get("gvt_decelerations_ms2", [math.nan]), gaps, sides):
                rows.append({
                    "ncap_protocol": version, "ncap_scenario": name,
                    "ncap_vut_speed": v / KMH_PER_MS, "ncap_gvt_speed": g / KMH_PER_MS,
                    "ncap_overlap": overlap, "ncap_lateral_location": lateral,
                    "ncap_gvt_deceleration": float(dec), "ncap_headway": float(gap),
                    "ncap_turn_radius": radius, "ncap_impact_location": loc,
                    "ncap_gvt_side": (math.nan if side is None
                                      else 1.0 if side == "right" else -1.0),
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


#: Arc-length step [m] of the numerically integrated turning path (:class:`TurnPath`).
PATH_STEP_M = 0.002


@dataclass(frozen=True)
class TurnPath:
    """A left turn through 90 deg: clothoid - arc of ``radius`` - clothoid, then straight.

    Curvature along the arc length ``s`` [m] (``s < 0``: the straight
    approach along +x): rises linearly from ``1 / start_radius`` to
    ``1 / radius`` over ``clothoid`` metres, stays there, falls linearly back
    to ``1 / start_radius`` over ``clothoid`` metres once the heading reaches
    ``pi/2`` less the second clothoid's angle; then straight along +y.  Each
    clothoid turns through ``(1/start_radius + 1/radius) clothoid / 2`` (the
    protocol's angle alpha), the arc through the rest of the 90 deg (beta).
    Heading ``psi(s)`` is the integral of the curvature (closed form); the
    position the integral of ``(cos psi, sin psi)`` (trapezoid rule on a
    :data:`PATH_STEP_M` grid, interpolated).

    Parameters
    ----------
    radius : float
        Radius of the constant-curvature part [m] (R2 of the protocol).
    clothoid : float
        Length of each clothoid [m].
    start_radius : float
        Radius at the clothoids' outer ends [m] (R1; ``inf``: curvature from 0).
    """

    radius: float
    clothoid: float
    start_radius: float = math.inf

    def __post_init__(self) -> None:
        if not (self.radius > 0 and self.start_radius >= self.radius and self.clothoid >= 0
                and self.arc >= -1e-12):
            raise DataError(DataProblem("meta", "", None, None,
                                        f"turn path: radius {self.radius} m, start radius "
                                        f"{self.start_radius} m and clothoid {self.clothoid} m "
                                        "do not make a 90 deg turn (the clothoids turn more "
                                        "than 90 deg)"))

    @classmethod
    def from_angle(cls, radius: float, clothoid_angle: float,
                   start_radius: float = math.inf) -> TurnPath:
        """The path whose clothoids each turn through ``clothoid_angle`` [rad].

        Clothoid length ``2 alpha / (1/R1 + 1/R2)`` (the angle of a linear curvature ramp).
        """
        k1, k2 = 1.0 / start_radius, 1.0 / radius
        return cls(radius, 2.0 * clothoid_angle / (k1 + k2), start_radius)

    @property
    def clothoid_angle(self) -> float:
        """Heading change [rad] over one clothoid (alpha)."""
        return 0.5 * (1.0 / self.start_radius + 1.0 / self.radius) * self.clothoid

    @property
    def arc(self) -> float:
        """Length of the constant-radius part [m]."""
        return (0.5 * math.pi - 2.0 * self.clothoid_angle) * self.radius

    @property
    def length(self) -> float:
        """Arc length of the turn, first clothoid to the end of the second [m]."""
        return 2.0 * self.clothoid + max(self.arc, 0.0)

    def curvature(self, s: np.ndarray) -> np.ndarray:
        """Curvature [1/m] at arc length ``s`` [m]."""
        s = np.asarray(s, dtype=float)
        k1, k2, c, a = 1.0 / self.start_radius, 1.0 / self.radius, self.clothoid, max(self.arc,
                                                                                     0.0)
        up = np.clip(s / c, 0.0, 1.0) if c > 0 else (s >= 0).astype(float)
        down = np.clip((s - c - a) / c, 0.0, 1.0) if c > 0 else (s > a).astype(float)
        return np.where((s < 0) | (s > self.length), 0.0, k1 + (k2 - k1) * (up - down))

    def heading(self, s: np.ndarray) -> np.ndarray:
        """Heading [rad] at arc length ``s`` [m] (0 along +x, pi/2 along +y)."""
        s = np.asarray(s, dtype=float)
        k1, k2, c, a = 1.0 / self.start_radius, 1.0 / self.radius, self.clothoid, max(self.arc,
                                                                                     0.0)
        u = np.clip(s, 0.0, self.length)
        first = np.minimum(u, c)
        psi = k1 * first + ((k2 - k1) * first**2 / (2 * c) if c > 0 else 0.0 * u)
        psi = psi + k2 * np.clip(u - c, 0.0, a)
        w = np.clip(u - c - a, 0.0, c)
        psi = psi + k2 * w - ((k2 - k1) * w**2 / (2 * c) if c > 0 else 0.0 * w)
        return psi

    def _grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = int(math.ceil(self.length / PATH_STEP_M))
        s = np.linspace(0.0, self.length, n + 1)
        psi = self.heading(s)
        ds = np.diff(s)
        x = np.concatenate([[0.0], np.cumsum(0.5 * ds * (np.cos(psi[1:]) + np.cos(psi[:-1])))])
        y = np.concatenate([[0.0], np.cumsum(0.5 * ds * (np.sin(psi[1:]) + np.sin(psi[:-1])))])
        return s, x, y

    def position(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CG position x, y [m] and heading [rad] at arc length ``s`` [m]."""
        s = np.asarray(s, dtype=float)
        grid, gx, gy = self._grid()
        inside = np.clip(s, 0.0, self.length)
        x = np.interp(inside, grid, gx)
        y = np.interp(inside, grid, gy)
        before = np.minimum(s, 0.0)
        after = np.maximum(s - self.length, 0.0)
        return x + before, y + after, self.heading(s)

    def front_crossing(self, cg_to_front: float, lane_offset: float) -> float:
        """Arc length [m] at which the front centre reaches ``y = lane_offset`` [m].

        Bisection on ``y(s) + cg_to_front sin(psi(s))``, which grows with ``s``.
        """
        def front_y(s: float) -> float:
            _, y, psi = self.position(np.array([s]))
            return float(y[0] + cg_to_front * math.sin(float(psi[0])))

        lo, hi = 0.0, self.length + lane_offset + 1.0
        if front_y(hi) < lane_offset:
            raise DataError(DataProblem("meta", "", None, None,
                                        f"turn path never reaches the lane at {lane_offset} m"))
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if front_y(mid) < lane_offset else (lo, mid)
        return 0.5 * (lo + hi)


def lane_change_ramp(half: float, width: float, peak: float) -> float:
    """Ramp time [s] of the trapezoidal lateral acceleration of a lane change.

    The lateral acceleration rises linearly to ``peak`` within the ramp time,
    holds, and falls back to 0 at ``half`` (half the manoeuvre's duration); the
    second half mirrors it with the opposite sign.  The lateral speed at
    ``half`` is ``peak (half - ramp)`` and, the profile being symmetric about
    ``half / 2``, the displacement of the whole manoeuvre is
    ``peak half (half - ramp)`` [m]; set equal to ``width``:
    ``ramp = half - width / (peak half)``.

    Raises
    ------
    DataError
        The width cannot be reached at that peak within the time
        (``ramp < 0``), or needs more than a triangular profile (``ramp > half / 2``).
    """
    ramp = half - width / (peak * half)
    if not -1e-12 <= ramp <= 0.5 * half + 1e-12:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"lane change of {width} m in {2 * half:.3f} s at peak "
                                    f"{peak} m/s2: not a trapezoid (ramp {ramp:.3f} s outside "
                                    f"[0, {half / 2:.3f}] s)"))
    return min(max(ramp, 0.0), 0.5 * half)


def lane_change_lateral(tau: np.ndarray, duration: float, width: float, peak: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lateral displacement [m], speed [m/s] and acceleration [m/s^2] of a lane change.

    ``tau`` [s] from the start of the manoeuvre (clipped to [0, duration]);
    acceleration: :func:`lane_change_ramp`'s trapezoid, then its mirror with the
    opposite sign; speed and displacement integrated in closed form on each
    linear piece.
    """
    half = 0.5 * duration
    ramp = lane_change_ramp(half, width, peak)
    # breakpoints and accelerations of the piecewise-linear profile
    knots = np.array([0.0, ramp, half - ramp, half, half + ramp, duration - ramp, duration])
    acc = np.array([0.0, peak, peak, 0.0, -peak, -peak, 0.0])
    # integrate piece by piece (exact for linear acceleration)
    vel_k = np.zeros_like(knots)
    pos_k = np.zeros_like(knots)
    for i in range(1, knots.size):
        h = knots[i] - knots[i - 1]
        vel_k[i] = vel_k[i - 1] + 0.5 * h * (acc[i - 1] + acc[i])
        pos_k[i] = pos_k[i - 1] + vel_k[i - 1] * h + h**2 * (2 * acc[i - 1] + acc[i]) / 6.0
    t = np.clip(np.asarray(tau, dtype=float), 0.0, duration)
    i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 2)
    h = t - knots[i]
    span = knots[i + 1] - knots[i]
    slope = np.divide(acc[i + 1] - acc[i], span, out=np.zeros_like(span), where=span > 0)
    a = acc[i] + slope * h
    v = vel_k[i] + acc[i] * h + 0.5 * slope * h**2
    y = pos_k[i] + vel_k[i] * h + 0.5 * acc[i] * h**2 + slope * h**3 / 6.0
    return y, v, a


def _accel(speed: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.gradient(speed, t) if t.size > 1 else np.zeros_like(t)


def _braking_gvt(t: np.ndarray, rear_at_brake: float, speed: float, decel: float,
                 t_brake: float, cg_to_rear: float, y: float, final: float = 0.0) -> Motion:
    """GVT at ``speed`` braking at ``decel`` from ``t_brake`` down to ``final`` [m/s] (CCRb)."""
    tau = np.clip(t - t_brake, None, (speed - final) / decel)
    s = np.where(tau < 0, speed * tau, speed * tau - 0.5 * decel * tau**2)
    s = s + final * np.maximum(t - t_brake - (speed - final) / decel, 0.0)
    v = np.where(tau < 0, speed, speed - decel * tau)
    braking = (t >= t_brake) & (v > final)
    return Motion(rear_at_brake + cg_to_rear + s, np.full_like(t, y), np.zeros_like(t),
                  np.maximum(v, final), np.where(braking, -decel, 0.0))


def ccrb_impact_after_braking(headway: float, speed: float, decel: float,
                              final: float = 0.0) -> float:
    """Time [s] from the GVT's brake onset to the undisturbed impact in CCRb.

    The VUT keeps ``speed``; the GVT, ``headway`` ahead at the same speed,
    brakes at ``decel`` down to ``final`` [m/s] and keeps that: the gap is
    ``headway - decel t^2 / 2`` while it brakes (until ``t_b = (speed -
    final) / decel``), then closes at ``speed - final``; with ``final = 0``
    the GVT stands and ``speed t = headway + speed^2 / (2 decel)``.
    """
    t_moving = math.sqrt(2.0 * headway / decel)
    t_b = (speed - final) / decel
    if t_moving <= t_b:
        return t_moving
    return t_b + (headway - 0.5 * decel * t_b**2) / (speed - final)


def turn_path(test: pd.Series, protocol: dict[str, Any]) -> TurnPath:
    """The VUT's CCFtap path of ``test``: R2 per VUT speed; clothoids by angle or duration.

    ``clothoid_angles_deg`` (the protocol's alpha per VUT speed, with
    ``clothoid_start_radius_m``, R1) if the scenario has them, else each
    clothoid driven in ``clothoid_duration_s``.
    """
    sc = protocol["scenarios"][test["ncap_scenario"]]
    radius = float(test["ncap_turn_radius"])
    if "clothoid_angles_deg" in sc:
        speeds = [float(v) for v in sc["vut_speeds_kmh"]]
        v = round(float(test["ncap_vut_speed"]) * KMH_PER_MS, 6)
        alpha = math.radians(float(sc["clothoid_angles_deg"][speeds.index(v)]))
        return TurnPath.from_angle(radius, alpha, float(sc.get("clothoid_start_radius_m",
                                                                 math.inf)))
    return TurnPath(radius, float(test["ncap_vut_speed"]) * float(sc["clothoid_duration_s"]))


def lane_change_length(test: pd.Series, protocol: dict[str, Any]) -> float:
    """CCFhol: longitudinal length [m] of the GVT's lane change at its test speed."""
    sc = protocol["scenarios"][test["ncap_scenario"]]
    lengths = {float(k): float(v) for k, v in sc["lane_change_lengths_m"].items()}
    g = round(float(test["ncap_gvt_speed"]) * KMH_PER_MS, 6)
    if g not in lengths:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"scenario {test['ncap_scenario']}: no lane-change length "
                                    f"for GVT {g:g} km/h; lane_change_lengths_m has "
                                    f"{', '.join(f'{k:g}' for k in lengths)} km/h"))
    return lengths[g]


def lateral_position(test: pd.Series, vut: Car, gvt: Car, protocol: dict[str, Any]) -> float:
    """Lateral position [m] of the GVT's centreline at impact (ISO 8855 +y left)."""
    if protocol["lateral"]["convention"] == "impact_location":
        return impact_location_offset(float(test["ncap_lateral_location"]), vut.width)
    return lateral_offset(float(test["ncap_overlap"]), vut.width, gvt.width,
                          protocol["lateral"]["negative_side"])


def ncap_test_motions(test: pd.Series, vut: Car, gvt: Car, protocol: dict[str, Any]
                      ) -> tuple[np.ndarray, float, Motion, Motion]:
    """Time axis [s], undisturbed impact time [s] and the records of VUT and GVT of one test."""
    general = protocol["protocol"]
    sc = protocol["scenarios"][test["ncap_scenario"]]
    dt, lead = float(general["time_step_s"]), float(general["lead_time_s"])
    after = float(general["after_impact_s"])
    lane = float(general["lane_width_m"])
    v, g, kind = float(test["ncap_vut_speed"]), float(test["ncap_gvt_speed"]), test["kind"]
    t_impact = lead
    if kind == "rear" and not math.isnan(test["ncap_gvt_deceleration"]):
        t_brake = float(sc["steady_before_braking_s"])
        final = float(sc.get("gvt_final_speed_kmh", 0.0)) / KMH_PER_MS
        t_impact = t_brake + ccrb_impact_after_braking(float(test["ncap_headway"]), g,
                                                       float(test["ncap_gvt_deceleration"]),
                                                       final)
    n = int(round((t_impact + after) / dt))
    t = np.round(np.arange(n + 1) * dt, 10)
    front_v = vut.cg_to_front
    if kind in ("rear", "head_on", "head_on_lane_change"):
        offset = lateral_position(test, vut, gvt, protocol)
    if kind == "rear":
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        if math.isnan(test["ncap_gvt_deceleration"]):
            m2 = _straight(t, gvt.cg_to_rear, offset, 0.0, g, t_impact)
        else:
            rear_at_brake = float(test["ncap_headway"])  # VUT front at x = 0 at the onset
            m1 = _straight(t, -front_v, 0.0, 0.0, v, t_brake)
            m2 = _braking_gvt(t, rear_at_brake, g, float(test["ncap_gvt_deceleration"]),
                              t_brake, gvt.cg_to_rear, offset, final)
    elif kind == "turn":
        path = turn_path(test, protocol)
        s_meet = path.front_crossing(front_v, lane)
        x, y, yaw = path.position(v * (t - t_impact) + s_meet)
        m1 = Motion(x, y, yaw, np.full_like(t, v), np.zeros_like(t))
        xm, ym, psim = path.position(np.array([s_meet]))
        sync_x = float(xm[0]) + front_v * math.cos(float(psim[0]))
        m2 = _straight(t, sync_x + gvt.cg_to_front, lane, math.pi, g, t_impact)
    elif kind == "crossing":
        if v > 0:
            m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        else:  # start from stop: standstill, then constant acceleration to the impact point
            d = float(sc["start_from_stop_distance_m"])
            a = float(sc["start_from_stop_accel_ms2"])
            t0 = t_impact - math.sqrt(2.0 * d / a)
            tau = np.maximum(t - t0, 0.0)
            m1 = Motion(-front_v - d + 0.5 * a * tau**2, np.zeros_like(t), np.zeros_like(t),
                        a * tau, np.where(t >= t0, a, 0.0))
        loc = float(test["ncap_impact_location"])
        sign = float(test["ncap_gvt_side"])  # +1 from the VUT's right, -1 from its left
        # the VUT's front centre meets the GVT's side loc x length behind its front
        cg_y = -sign * (gvt.cg_to_front - loc * gvt.length)
        m2 = _straight(t, 0.5 * gvt.width, cg_y, sign * 0.5 * math.pi, g, t_impact)
    elif kind == "head_on":
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        m2 = _straight(t, gvt.cg_to_front, offset, math.pi, g, t_impact)
    else:  # head_on_lane_change
        m1 = _straight(t, -front_v, 0.0, 0.0, v, t_impact)
        width = float(sc["lane_change_width_m"])
        duration = lane_change_length(test, protocol) / g
        end = t_impact - float(sc["lane_change_end_ttc_s"])
        lat, vy, _ = lane_change_lateral(t - (end - duration), duration, width,
                                         float(sc["lane_change_peak_lateral_accel_ms2"]))
        y = offset + width - lat  # from one lane to the VUT's left into the VUT's lane
        x = gvt.cg_to_front - g * (t - t_impact)
        speed = np.hypot(g, vy)
        m2 = Motion(x, y, np.arctan2(-vy, -g), speed, _accel(speed, t))
    return t, t_impact, m1, m2


def _frame(case_id: int, participant: int, t: np.ndarray, m: Motion) -> pd.DataFrame:
    return pd.DataFrame({"case_id": case_id, "participant": participant, "t": t, "x": m.x,
                         "y": m.y, "yaw": m.yaw, "speed": m.speed, "accel": m.accel})


def _describe(test: pd.Series) -> str:
    v = test["ncap_vut_speed"] * KMH_PER_MS
    parts = [f"Euro NCAP {test['ncap_protocol']} {test['ncap_scenario']}: "
             + (f"VUT {v:g} km/h" if v > 0 else "VUT start from stop"),
             f"GVT {test['ncap_gvt_speed'] * KMH_PER_MS:g} km/h"]
    if not math.isnan(test["ncap_overlap"]):
        parts.append(f"overlap {100 * test['ncap_overlap']:+g} %")
    if not math.isnan(test["ncap_lateral_location"]):
        parts.append(f"impact location {100 * test['ncap_lateral_location']:g} % "
                     "(0 right edge, 50 full overlap)")
    if not math.isnan(test["ncap_gvt_deceleration"]):
        parts.append(f"GVT braking {test['ncap_gvt_deceleration']:g} m/s^2 at headway "
                     f"{test['ncap_headway']:g} m")
    if not math.isnan(test["ncap_turn_radius"]):
        parts.append(f"turn radius {test['ncap_turn_radius']:g} m")
    if not math.isnan(test["ncap_impact_location"]):
        parts.append(f"impact at {100 * test['ncap_impact_location']:g} % of the GVT's length")
    if not math.isnan(test["ncap_gvt_side"]):
        parts.append("GVT from the " + ("right (nearside)" if test["ncap_gvt_side"] > 0
                                        else "left (farside)"))
    return ", ".join(parts)


def build_euro_ncap_database(protocol: dict[str, Any] | None = None) -> Database:
    """The whole test matrix of one protocol version as a database (SI units).

    Parameters
    ----------
    protocol : dict, optional
        :func:`read_protocol`'s result; default the 2026 protocol file.

    Returns
    -------
    Database
        One case per test (:func:`ncap_test_matrix`, with ``ncap_impact_time``),
        participant 1 the VUT, participant 2 the GVT, no reconstruction
        (``meta["has_reconstruction"] = False``); ``meta["name"]`` the
        version's ``--db`` name, ``meta["ncap_protocol"]`` its version.
    """
    protocol = read_protocol() if protocol is None else protocol
    matrix = ncap_test_matrix(protocol)
    vut, gvt = vehicles(protocol)
    friction = float(protocol["protocol"]["road_friction"])
    cases, parts, trajs = [], [], []
    for _, test in matrix.iterrows():
        cid = int(test["case_id"])
        t, t_impact, m1, m2 = ncap_test_motions(test, vut, gvt, protocol)
        trajs += [_frame(cid, 1, t, m1), _frame(cid, 2, t, m2)]
        parts += [vut.row(cid, 1), gvt.row(cid, 2)]
        cases.append({"case_id": cid, "accident_type": int(test["accident_type"]),
                      "road_friction": friction, "road_surface": "dry",
                      "road_curvature": 0.0, "weight": 1.0, "collision": True,
                      "description": _describe(test),
                      **{c: test[c] for c in MATRIX_COLUMNS if c != "ncap_impact_time"},
                      "ncap_impact_time": float(t_impact)})
    frames = {"cases": pd.DataFrame(cases), "participants": pd.DataFrame(parts),
              "trajectories": pd.concat(trajs, ignore_index=True)}
    tables = {name: normalise_table(frames.get(name, empty_table(name)), name)
              for name in TABLE_NAMES}
    info = protocol["protocol"]
    meta = default_meta(
        name=str(info["name"]), created_by="vfs.scenarios.euro_ncap",
        description=f"Euro NCAP Car-to-Car test matrix, protocol {info['version']} "
        f"({len(matrix)} tests: "
        + ", ".join(f"{k} {v}" for k, v in matrix["ncap_scenario"].value_counts(
            sort=False).items())
        + "); participant 1 the VUT, 2 the GVT; protocol: scenarios/euro-ncap-c2c/"
        f"{PROTOCOL_VERSIONS.get(str(info['version']), ('', 'protocol.toml'))[1]} "
        "(sources and assumptions there)")
    meta["has_reconstruction"] = False
    meta["equip"] = "1"  # the VUT carries the system; `vfs study` takes it as --equip default
    meta["test_protocol"] = str(info["test_protocol"])
    meta["ncap_protocol"] = str(info["version"])
    meta["columns"] = {"cases": MATRIX_COLUMN_UNITS}
    return Database(**tables, meta=meta)


def main(argv: list[str] | None = None) -> int:
    """Write every version's database into ``FOLDER/<name>`` (default the bundled folder)."""
    from vfs.database.io import save_database

    args = sys.argv[1:] if argv is None else argv
    root = Path(args[0] if args else os.path.join("scenarios", "databases"))
    for version, (name, _) in PROTOCOL_VERSIONS.items():
        try:
            database = build_euro_ncap_database(read_protocol(version=version))
        except VfsError as err:  # a protocol file missing a table: one line, no traceback
            print(f"error: {err}", file=sys.stderr)
            return 2
        save_database(database, root / name)
        print(f"wrote {root / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
