"""The planar momentum (impulse) impact model of Kudlich and Slibar, as in PC-Crash.

Two rigid bodies exchange an impulse S at the point of impact (POI).  The
impulse is split into a compression part S_C and a restitution part
S_R = eps S_C, S = (1 + eps) S_C (the Momentum Based Impact Model paper,
eqs. 3-5; the Reconstruction chapter, "Collision model").  Two impact types
(the Reconstruction chapter; the Momentum Based Impact Model paper, sections
3.1.2-3.1.3):

* **full impact**: at the end of compression the POI velocities of the two
  bodies are equal in both directions; valid while the impulse lies inside
  the friction cone, |T| <= mu N (the Momentum Based Impact Model paper, eq. 6: rho = arctan mu);
* **sliding impact**: otherwise the bodies slide along the contact plane:
  |T| = mu N, with the tangential impulse taking the sign of the full-impact
  solution, and only the normal POI velocities are equal at the end of
  compression.

In both, eps multiplies both components (PC-Crash convention,
docs/references.md), so in a sliding impact T/N = mu holds for the total
impulse too.  Momentum balance (the Collision Calculation Uncertainty paper, eqs. 6-9) and
angular momentum balance about each CG (its eqs. 10-11) close the system.  That paper's levers
n_ic, t_ic are the coordinates of the contact point relative to the centre of gravity of each
body, i.e. they point from the CG to the POI, as r_i = POI - CG_i below (the signs of its eqs.
10-11 follow its own axis orientation, its Fig. 9).

Conventions (docs/physics.md has the figure):

* global frame, SI units; yaw and yaw rate counter-clockwise positive;
* ``cp_angle`` is the direction of the contact-plane tangent; its
  orientation (phi or phi + pi) does not matter;
* the unit normal n is perpendicular to the plane and points from vehicle 2
  towards vehicle 1 (n . (CG1 - CG2) > 0); the tangent t is n turned
  clockwise by 90 deg, so (t, n) is right-handed;
* S is the impulse acting on vehicle 1 (vehicle 2 receives -S);
  ``impulse_n`` = S . n >= 0 for a real impact, ``impulse_t`` = S . t;
* the relative POI velocity u = v1_P - v2_P; the bodies approach when
  u . n < 0.  A configuration with u . n >= 0 is separating: "no impact",
  not solved (all outputs equal the inputs, impulse 0).

The compliance matrix K maps an impulse on vehicle 1 to the change of u,
du = K S, with K = (1/m1 + 1/m2) 1 + r1p r1p^T / I1 + r2p r2p^T / I2 and
r_ip = r_i turned by +90 deg (r_i = POI - CG_i).  In (t, n) components
K_tt = 1/m1 + 1/m2 + r1n^2/I1 + r2n^2/I2, K_nn = 1/m1 + 1/m2 + r1t^2/I1 +
r2t^2/I2, K_tn = -(r1t r1n / I1 + r2t r2n / I2) (Brach; docs/references.md gives
the same entries up to the sign of the off-diagonal term, which depends on
the tangent's orientation).

Fixed objects (barrier, wall, pole) are the limit 1/m = 0, 1/I = 0: pass
``m = izz = inf`` (:data:`FIXED_OBJECT_MASS`) for one participant.  IEEE
arithmetic gives 1/inf = 0 exactly, so every formula above is already that
limit: K loses the fixed body's terms, its velocities do not change, and the
whole energy loss is the free vehicle's deformation energy.  Momentum of the
free vehicle is not conserved (the object takes the impulse), but its angular
momentum about the (fixed) POI is: L_P = I1 w1 - m1 r1 x v1 (r1 = POI - CG1)
changes by I1 dw1 - r1 x m1 dv1 = r1 x S - r1 x S = 0.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError
from vfs.settings import declared, setting, validate
from vfs.units import wrap_angle

#: Impact type codes of :attr:`ImpactResult.impact_type`.
IMPACT_NONE, IMPACT_FULL, IMPACT_SLIDING = 0, 1, 2
IMPACT_TYPE_NAMES: dict[int, str] = {IMPACT_NONE: "none", IMPACT_FULL: "full",
                                     IMPACT_SLIDING: "sliding"}
_NAME_OF_CODE = np.array([IMPACT_TYPE_NAMES[k] for k in range(len(IMPACT_TYPE_NAMES))])


#: Conventions for the restitution (:attr:`ImpactParams.restitution_mode`): ``"impulse"``
#: restitutes both impulse components (PC-Crash, Kudlich-Slibar), ``"normal"`` only the
#: normal relative velocity (Brach; tangential impulse up to the critical impulse ratio).
class RestitutionMode(StrEnum):
    """Conventions for the restitution (:attr:`ImpactParams.restitution_mode`)."""

    IMPULSE = "impulse"
    NORMAL = "normal"


RESTITUTION_MODES: tuple[str, ...] = tuple(m.value for m in RestitutionMode)


def impact_type_names(codes: npt.ArrayLike) -> np.ndarray:
    """Impact type codes (0, 1, 2) as the strings of :data:`IMPACT_TYPE_NAMES`."""
    return _NAME_OF_CODE[np.asarray(codes)]


@dataclass(frozen=True)
class ImpactParams:
    """Impact-model parameters with their documented defaults.

    Attributes
    ----------
    restitution : float
        Impulse ratio eps = S_R / S_C, in [0, 1].  Default 0.1, the value
        the Momentum Based Impact Model paper uses for car accidents
        ("applicable for a wide range of closing speeds"); the Reconstruction
        chapter gives 0.1-0.3 for real crashes.
    contact_friction : float
        Friction coefficient between the bodies at the POI (tan rho of the friction cone,
        the Collision Calculation Uncertainty paper), >= 0.  Default 0.6; there is no firm
        source for a universal value (openPASS hard-codes 0.3), so studies should vary it
        (see `vfs uncertainty`).
    restitution_mode : {"impulse", "normal"}
        How eps enters (:data:`RESTITUTION_MODES`).  ``"impulse"`` (default): the
        Kudlich-Slibar/PC-Crash convention, S = (1 + eps) S_C for both impulse
        components.  ``"normal"``: Brach's convention, restitution of the normal
        relative velocity only, u_n' = -eps u_n, and a tangential impulse that
        stops the sliding at the POI (u_t' = 0) unless that needs more than the
        friction cone allows (then |S_t| = mu S_n).

    The time the outlines move on after first contact before the impact is
    solved is :attr:`vfs.physics.precrash.PrecrashParams.penetration_time`.
    """

    restitution: float = setting(0.1, "ratio", "impulse ratio eps = S_R / S_C",
                                 lo=0.0, hi=1.0)
    contact_friction: float = setting(0.6, "ratio", "friction coefficient between the bodies "
                                      "at the POI (tan rho of the friction cone)",
                                      lo=0.0, hi=10.0)
    restitution_mode: str = setting("impulse", "text", "how eps enters: impulse "
                                    "(Kudlich-Slibar, PC-Crash) or normal (Brach)",
                                    choices=RestitutionMode)

    @property
    def penetration_time(self) -> float:
        """Deprecated: the default of ``PrecrashParams.penetration_time`` [s].

        The impact model never used a penetration time; the pre-crash stage
        (:class:`vfs.physics.precrash.PrecrashParams`) owns it.
        """
        warnings.warn("ImpactParams.penetration_time is deprecated: use "
                      "vfs.physics.precrash.PrecrashParams().penetration_time",
                      DeprecationWarning, stacklevel=2)
        from vfs.physics.precrash import PrecrashParams  # lazy: no import-time coupling

        return PrecrashParams().penetration_time

    def __post_init__(self) -> None:
        validate(self)


#: Table column of each per-vehicle field of :class:`ImpactResult` (``{i}`` = 1, 2): the
#: names of the files and reports (:meth:`ImpactResult.columns`).
RESULT_COLUMNS: dict[str, str] = {
    "vx_post": "vx{i}_post", "vy_post": "vy{i}_post", "yaw_rate_post": "yaw_rate{i}_post",
    "delta_vx": "delta_vx{i}", "delta_vy": "delta_vy{i}", "delta_v": "delta_v{i}",
    "ees": "ees{i}", "velocity_angle_change": "velocity_angle_change{i}", "pdof": "pdof{i}",
    "pdof_clock": "pdof_clock{i}",
}


def add_vehicle_aliases(cls: type, fields: tuple[str, ...]) -> None:
    """Give record ``cls`` the deprecated read-only aliases ``<field><i>`` (i = 1, 2; the
    table names of :data:`RESULT_COLUMNS` for the fields listed there) of its per-vehicle
    ``fields`` (:func:`deprecated_vehicle_field`).
    """
    for field in fields:
        for j in (0, 1):
            setattr(cls, RESULT_COLUMNS.get(field, field + "{i}").format(i=j + 1),
                    deprecated_vehicle_field(field, j))


def deprecated_vehicle_field(field: str, j: int) -> property:
    """Read-only alias, named with the vehicle number, of ``field[:, j]`` of a record with a
    vehicle axis (vehicle 1 at j = 0), kept for plugins written against the former
    one-array-per-vehicle records; reading it warns (``DeprecationWarning``).
    """
    old = RESULT_COLUMNS.get(field, field + "{i}").format(i=j + 1)

    def get(self: tuple) -> np.ndarray:
        warnings.warn(f"{type(self).__name__}.{old} is deprecated: use {field}[:, {j}] "
                      "(vehicle axis 1, vehicle 1 at index 0)", DeprecationWarning,
                      stacklevel=2)
        return getattr(self, field)[:, j]

    get.__doc__ = f"Deprecated alias of ``{field}[:, {j}]``."
    get.vehicle_alias = (field, j)  # type: ignore[attr-defined]
    return property(get)


class ImpactResult(NamedTuple):
    """Result of :func:`solve_impact` for N configurations.

    Fields of the impact as a whole are arrays (N,); fields of each vehicle are
    arrays (N, 2) whose axis 1 is the vehicle (vehicle 1 at index 0), as in
    :class:`vfs.physics.precrash_result.KinematicState`.  :meth:`columns` gives the
    table columns (``delta_v1``, ``ees2``, ...).

    Attributes
    ----------
    impact_type : ndarray of int (N,)
        0 none (separating), 1 full, 2 sliding (:data:`IMPACT_TYPE_NAMES`).
    normal_x, normal_y : ndarray (N,)
        Unit normal n of the contact plane, from vehicle 2 towards vehicle 1.
    closing_speed : ndarray (N,)
        Normal approach speed at the POI, -u.n [m/s] (> 0 for an impact).
    sliding_speed : ndarray (N,)
        Tangential relative POI speed before the impact, u.t [m/s].
    impulse_t, impulse_n : ndarray (N,)
        Total impulse on vehicle 1 in contact-plane components [N s]
        (T and N; vehicle 2 receives the opposite).
    impulse_x, impulse_y : ndarray (N,)
        Total impulse on vehicle 1, global components [N s].
    vx_post, vy_post : ndarray (N, 2)
        Post-impact CG velocities [m/s].
    yaw_rate_post : ndarray (N, 2)
        Post-impact yaw rates [rad/s].
    delta_vx, delta_vy : ndarray (N, 2)
        Velocity change of each CG [m/s].
    delta_v : ndarray (N, 2)
        Magnitude of the CG velocity change [m/s].
    energy_loss : ndarray (N,)
        Kinetic energy lost, translational plus rotational [J] (>= 0).
    ees : ndarray (N, 2)
        Energy equivalent speed [m/s]: E_i = m_i EES_i^2 / 2 (the Reconstruction chapter) with
        the loss split by :func:`energy_split`.
    velocity_angle_change : ndarray (N, 2)
        Angle between the CG velocity vectors before and after [rad], in
        [0, pi]; NaN when either speed is below 1 mm/s.
    pdof : ndarray (N, 2)
        Principal direction of force [rad] in the vehicle's frame: the
        direction the impulse comes from, 0 = straight from ahead (frontal),
        positive clockwise seen from above (pi/2 = from the right), in
        (-pi, pi].
    pdof_clock : ndarray of int (N, 2)
        PDOF as a clock direction 1-12 (12 = frontal, 3 = right side).

    Notes
    -----
    The names with the vehicle number of the former one-array-per-vehicle record
    (``vx1_post``, ``delta_v2``, ``ees1``, ``pdof_clock2``, ...) remain as read-only
    attributes for plugins written against it; they are deprecated (a
    ``DeprecationWarning``) and vfs itself does not use them.
    """

    impact_type: np.ndarray
    normal_x: np.ndarray
    normal_y: np.ndarray
    closing_speed: np.ndarray
    sliding_speed: np.ndarray
    impulse_t: np.ndarray
    impulse_n: np.ndarray
    impulse_x: np.ndarray
    impulse_y: np.ndarray
    vx_post: np.ndarray
    vy_post: np.ndarray
    yaw_rate_post: np.ndarray
    delta_vx: np.ndarray
    delta_vy: np.ndarray
    delta_v: np.ndarray
    energy_loss: np.ndarray
    ees: np.ndarray
    velocity_angle_change: np.ndarray
    pdof: np.ndarray
    pdof_clock: np.ndarray

    @property
    def impact_type_name(self) -> np.ndarray:
        """Impact type as strings 'none', 'full', 'sliding'."""
        return impact_type_names(self.impact_type)

    @property
    def size(self) -> int:
        """Number of impacts N."""
        return int(self.impact_type.shape[0])

    def columns(self) -> dict[str, np.ndarray]:
        """The fields as table columns (N,): the per-vehicle fields as two columns named
        by :data:`RESULT_COLUMNS` (``delta_v1``, ``delta_v2``, ...), vehicle 1's first.
        """
        out: dict[str, np.ndarray] = {}
        for name, values in zip(self._fields, self, strict=True):
            if name in RESULT_COLUMNS:
                for i in (1, 2):
                    out[RESULT_COLUMNS[name].format(i=i)] = values[:, i - 1]
            else:
                out[name] = values
        return out



#: Per-vehicle fields of :class:`ImpactConfig` ((N, 2) arrays, vehicle axis 1).
CONFIG_VEHICLE_FIELDS: tuple[str, ...] = ("m", "izz", "x", "y", "yaw", "vx", "vy", "yaw_rate")

#: Fields of :class:`ImpactConfig` that describe the impact as a whole ((N,) arrays).
CONFIG_IMPACT_FIELDS: tuple[str, ...] = ("poi_x", "poi_y", "cp_angle", "restitution",
                                         "contact_friction")

#: Table columns of an impact configuration, in the order of the files (impact tables, the
#: reconstruction table): vehicle 1's columns ``m1`` ... ``yaw_rate1``, vehicle 2's, then the
#: impact's (:meth:`ImpactConfig.from_columns`, :meth:`ImpactConfig.columns`).
CONFIG_COLUMNS: tuple[str, ...] = (
    *(f"{f}{i}" for i in (1, 2) for f in CONFIG_VEHICLE_FIELDS), *CONFIG_IMPACT_FIELDS)


def _vehicle_pairs(values: npt.ArrayLike) -> np.ndarray:
    """A per-vehicle input as (n, 2) float: a scalar (both vehicles), a pair (2,) (one
    impact) or an (N, 2) array.
    """
    a = np.asarray(values, dtype=float)
    if a.ndim == 0 or a.shape == (2,):
        return np.atleast_2d(a)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ParameterError(f"a per-vehicle field must be a scalar, a pair or (N, 2), not "
                             f"shape {a.shape}")
    return a


class ImpactConfig(NamedTuple):
    """N impact configurations.

    Fields of each vehicle are arrays (N, 2) whose axis 1 is the vehicle (vehicle 1 at
    index 0), as in :class:`vfs.physics.precrash_result.KinematicState`; fields of the
    impact as a whole are arrays (N,).  Tables name the columns ``m1``, ``izz2``, ...
    (:data:`CONFIG_COLUMNS`, :meth:`from_columns`, :meth:`columns`).

    Attributes
    ----------
    m : ndarray (N, 2)
        Masses [kg].
    izz : ndarray (N, 2)
        Yaw inertias about the CG [kg m^2].
    x, y : ndarray (N, 2)
        CG positions [m].
    yaw : ndarray (N, 2)
        Headings [rad].
    vx, vy : ndarray (N, 2)
        CG velocities [m/s], global frame.
    yaw_rate : ndarray (N, 2)
        Yaw rates [rad/s] (real pre-crash values, not zero).
    poi_x, poi_y : ndarray (N,)
        Point of impact [m].
    cp_angle : ndarray (N,)
        Contact-plane tangent direction [rad] (orientation irrelevant).
    restitution : ndarray (N,)
        Impulse ratio eps [-], in [0, 1].
    contact_friction : ndarray (N,)
        Inter-vehicle friction mu [-], >= 0.

    Notes
    -----
    The names with the vehicle number of the former one-array-per-vehicle record (``m1``,
    ``izz2``, ``vx1``, ``yaw_rate2``, ...) remain as read-only attributes for plugins
    written against it; they are deprecated (a ``DeprecationWarning``) and vfs itself
    does not use them.
    """

    m: np.ndarray
    izz: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    yaw_rate: np.ndarray
    poi_x: np.ndarray
    poi_y: np.ndarray
    cp_angle: np.ndarray
    restitution: np.ndarray
    contact_friction: np.ndarray

    @classmethod
    def from_arrays(cls, **fields: npt.ArrayLike) -> ImpactConfig:
        """Build from keyword arrays: per-vehicle fields a scalar (both vehicles), a pair
        (one impact) or (N, 2); impact fields a scalar or (N,).  Broadcast to N impacts,
        float copies.
        """
        unknown = sorted(set(fields) - set(cls._fields))
        if unknown:
            raise ParameterError(f"unknown impact configuration fields: {unknown} (per-vehicle "
                                 "table columns such as m1: ImpactConfig.from_columns)")
        missing = [f for f in cls._fields if f not in fields]
        if missing:
            raise ParameterError(f"missing impact configuration fields: {missing}")
        pairs = [_vehicle_pairs(fields[f]) for f in CONFIG_VEHICLE_FIELDS]
        single = [np.atleast_1d(np.asarray(fields[f], dtype=float))
                  for f in CONFIG_IMPACT_FIELDS]
        n = np.broadcast_shapes(*(a.shape[:1] for a in pairs), *(a.shape for a in single))
        return cls(*(np.array(np.broadcast_to(a, (*n, 2)), dtype=float) for a in pairs),
                   *(np.array(np.broadcast_to(a, n), dtype=float) for a in single))

    @classmethod
    def from_columns(cls, **columns: npt.ArrayLike) -> ImpactConfig:
        """Build from table columns (:data:`CONFIG_COLUMNS`: ``m1``, ..., ``yaw_rate2``,
        ``poi_x``, ...), broadcast to a common 1-D shape: the file edge of the vehicle axis.
        """
        missing = [f for f in CONFIG_COLUMNS if f not in columns]
        if missing:
            raise ParameterError(f"missing impact configuration fields: {missing}")
        arrays = dict(zip(CONFIG_COLUMNS, np.broadcast_arrays(
            *(np.atleast_1d(np.asarray(columns[f], dtype=float)) for f in CONFIG_COLUMNS)),
            strict=True))
        return cls(*(np.stack([arrays[f"{f}1"], arrays[f"{f}2"]], axis=1)
                     for f in CONFIG_VEHICLE_FIELDS),
                   *(np.array(arrays[f], dtype=float) for f in CONFIG_IMPACT_FIELDS))

    def columns(self) -> dict[str, np.ndarray]:
        """The fields as table columns (N,) named by :data:`CONFIG_COLUMNS`."""
        out = {f"{f}{i}": getattr(self, f)[:, i - 1]
               for i in (1, 2) for f in CONFIG_VEHICLE_FIELDS}
        out.update({f: getattr(self, f) for f in CONFIG_IMPACT_FIELDS})
        return out

    def swapped(self) -> ImpactConfig:
        """The same configurations with vehicles 1 and 2 exchanged."""
        return self._replace(**{f: getattr(self, f)[:, ::-1] for f in CONFIG_VEHICLE_FIELDS})

    @property
    def size(self) -> int:
        """Number of configurations N."""
        return int(self.poi_x.shape[0])


add_vehicle_aliases(ImpactConfig, CONFIG_VEHICLE_FIELDS)
add_vehicle_aliases(ImpactResult, tuple(RESULT_COLUMNS))


# ----------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------

#: Mass and yaw inertia of a rigid fixed object (barrier, wall, pole): the limit 1/m = 0.
FIXED_OBJECT_MASS = np.inf


def inverse_mass(values: npt.ArrayLike) -> np.ndarray:
    """1 / mass [1/kg] (or 1 / inertia [1/(kg m^2)]); exactly 0 for a fixed object (inf)."""
    return 1.0 / np.asarray(values, float)  # IEEE: 1 / inf == 0.0 exactly


def fixed_object(mass: npt.ArrayLike, yaw_inertia: npt.ArrayLike) -> np.ndarray:
    """True where a participant is a rigid fixed object (mass and yaw inertia infinite)."""
    return np.isposinf(np.asarray(mass, float)) & np.isposinf(np.asarray(yaw_inertia, float))


#: Allowed ranges of the configuration fields (closed intervals).
#: Allowed ranges of the configuration fields (SI).  Beyond the physical ones (masses > 0,
#: restitution in [0, 1], friction >= 0) the bounds keep every product in the formulas far
#: from overflow (a speed of 1e300 m/s would give delta-v = inf and EES = NaN) while
#: admitting every road vehicle: masses up to 200 t, yaw inertias up to 1e7 kg m^2, speeds
#: up to 150 m/s (540 km/h), yaw rates up to 50 rad/s, positions within 1,000 km of the
#: origin, angles within +-1,000 rad, contact friction up to 10.
CONFIG_RANGES: dict[str, tuple[float, float]] = {
    "m1": (np.nextafter(0.0, 1.0), 2.0e5), "m2": (np.nextafter(0.0, 1.0), 2.0e5),
    "izz1": (np.nextafter(0.0, 1.0), 1.0e7), "izz2": (np.nextafter(0.0, 1.0), 1.0e7),
    "x1": (-1e6, 1e6), "y1": (-1e6, 1e6), "x2": (-1e6, 1e6), "y2": (-1e6, 1e6),
    "poi_x": (-1e6, 1e6), "poi_y": (-1e6, 1e6),
    "yaw1": (-1e3, 1e3), "yaw2": (-1e3, 1e3), "cp_angle": (-1e3, 1e3),
    "vx1": (-150.0, 150.0), "vy1": (-150.0, 150.0), "vx2": (-150.0, 150.0),
    "vy2": (-150.0, 150.0),
    "yaw_rate1": (-50.0, 50.0), "yaw_rate2": (-50.0, 50.0),
    **{name: (s.lo, s.hi) for name, s in declared(ImpactParams).items()
       if name in ("restitution", "contact_friction")},
}


def config_problems(config: ImpactConfig) -> dict[str, np.ndarray]:
    """Rows with invalid values, by field: NaN/inf anywhere, masses and inertias
    <= 0, restitution outside [0, 1], contact friction < 0.

    Returns
    -------
    dict
        table column (:data:`CONFIG_COLUMNS`, e.g. ``m2``) -> boolean array (N,)
        marking the bad rows (only columns with at least one bad row are listed).
    """
    bad: dict[str, np.ndarray] = {}
    fixed = fixed_object(config.m, config.izz)
    fixed1, fixed2 = fixed[:, 0], fixed[:, 1]
    columns = config.columns()
    for name in CONFIG_COLUMNS:
        v = columns[name]
        mask = ~np.isfinite(v)
        lo, hi = CONFIG_RANGES.get(name, (-np.inf, np.inf))
        with np.errstate(invalid="ignore"):
            mask |= (v < lo) | (v > hi)
        if name[:-1] in ("m", "izz"):  # a fixed object: both infinite, the other body free
            mask &= ~((fixed1 & ~fixed2) if name.endswith("1") else (fixed2 & ~fixed1))
        if mask.any():
            bad[name] = mask
    return bad


def describe_range(name: str) -> str:
    """Human-readable allowed range of a configuration field."""
    lo, hi = CONFIG_RANGES.get(name, (-np.inf, np.inf))
    if name in ("m1", "m2", "izz1", "izz2"):
        return (f"finite, > 0 and <= {hi:g} (or mass and inertia both inf: a fixed object, "
                "not both)")
    if np.isinf(lo) and np.isinf(hi):
        return "finite"
    return f"finite, in [{lo:g}, {hi:g}]"


# ----------------------------------------------------------------------------
# Energy split for EES
# ----------------------------------------------------------------------------


def energy_split(
    energy_loss: npt.ArrayLike, m1: npt.ArrayLike, m2: npt.ArrayLike,
    stiffness_ratio: npt.ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Split the energy loss [J] between the two vehicles.

    Both vehicles carry the same contact force; with linear stiffnesses k_i
    the deformation energies are F^2 / (2 k_i), so E1 / E2 = k2 / k1.

    * default (``stiffness_ratio`` None or NaN): stiffness proportional to
      mass, E1 / E2 = m2 / m1 (docs/references.md);
    * ``stiffness_ratio`` = k1 / k2 given: E1 / E2 = k2 / k1.

    Returns
    -------
    e1, e2 : ndarray
        Deformation energy of vehicle 1 and 2 [J].
    """
    e = np.asarray(energy_loss, float)
    m1 = np.asarray(m1, float)
    m2 = np.asarray(m2, float)
    with np.errstate(invalid="ignore"):
        share1 = m2 / (m1 + m2)  # E1 / (E1 + E2) with k_i ~ m_i
    # a fixed object (inf) does not deform: the free vehicle takes all (limit 1/m = 0)
    share1 = np.where(np.isposinf(m2), 1.0, np.where(np.isposinf(m1), 0.0, share1))
    if stiffness_ratio is not None:
        k = np.asarray(stiffness_ratio, float)
        with np.errstate(invalid="ignore", divide="ignore"):
            share_k = 1.0 / (1.0 + k)  # E1 / (E1 + E2) = k2 / (k1 + k2)
        share1 = np.where(np.isnan(k), share1, share_k)
    return e * share1, e * (1.0 - share1)


def deformation_energy(mass: npt.ArrayLike, ees: npt.ArrayLike) -> np.ndarray:
    """Deformation energy [J] of a vehicle of ``mass`` [kg] with an EES [m/s]:
    E = m EES^2 / 2 (the Reconstruction chapter).
    """
    return 0.5 * np.asarray(mass) * np.asarray(ees) ** 2


def velocity_change(dvx: npt.ArrayLike, dvy: npt.ArrayLike) -> np.ndarray:
    """Delta-v [m/s]: magnitude |v' - v| of a CG velocity change (dvx, dvy) [m/s]."""
    dvx, dvy = np.asarray(dvx), np.asarray(dvy)
    return np.sqrt(dvx**2 + dvy**2)


def ees_from_energy(energy: npt.ArrayLike, mass: npt.ArrayLike) -> np.ndarray:
    """EES [m/s] from a deformation energy [J]: E = m EES^2 / 2 (the Reconstruction chapter)."""
    return np.sqrt(2.0 * np.maximum(np.asarray(energy, float), 0.0) / np.asarray(mass, float))


# ----------------------------------------------------------------------------
# The solver
# ----------------------------------------------------------------------------


def _pair(one: np.ndarray, two: np.ndarray) -> np.ndarray:
    """(N, 2) array of a per-vehicle value: vehicle 1 in column 0."""
    return np.stack([one, two], axis=1)


def _pdof(ix: np.ndarray, iy: np.ndarray, yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PDOF [rad] and clock direction of an impulse (ix, iy) on a vehicle with heading yaw."""
    # direction the force comes from (-impulse), relative to the heading,
    # measured clockwise: pdof = -(atan2(-iy, -ix) - yaw)
    pdof = wrap_angle(yaw - np.arctan2(-iy, -ix))
    clock = np.mod(np.rint(pdof * (6.0 / np.pi)).astype(np.int64), 12)
    clock = np.where(clock == 0, 12, clock)
    return pdof, clock


def angle_between(ax: np.ndarray, ay: np.ndarray, bx: np.ndarray,
                   by: np.ndarray) -> np.ndarray:
    """Unsigned angle [rad] between vectors a and b; NaN if either is shorter than 1 mm/s."""
    short = (ax * ax + ay * ay < 1e-6) | (bx * bx + by * by < 1e-6)
    ang = np.arctan2(np.abs(ax * by - ay * bx), ax * bx + ay * by)
    return np.where(short, np.nan, ang)


#: Configurations solved per block.  Bounds the temporaries' memory (about 60 live
#: arrays of CHUNK floats, ~30 MB); smaller blocks were slower, not faster: the ~100
#: numpy calls per block and the final concatenation of ~30 result fields cost more than
#: the cache misses they save (bench impact, 1e5 impacts: 4,096 -> 3.5 M/s, 65,536 ->
#: 4.3 M/s).  Elementwise arithmetic only, so the results do not depend on it.
CHUNK = 65_536


class ContactFrame(NamedTuple):
    """Contact-plane frame of N configurations and the relative POI velocity in it.

    nx, ny: unit normal from vehicle 2 towards vehicle 1; tx, ty: tangent (n
    turned clockwise by 90 deg); u_t, u_n: components of u = v1_P - v2_P
    [m/s] (u_n < 0: approaching; the closing speed is -u_n).
    """

    nx: np.ndarray
    ny: np.ndarray
    tx: np.ndarray
    ty: np.ndarray
    u_t: np.ndarray
    u_n: np.ndarray


def contact_frame(config: ImpactConfig) -> ContactFrame:
    """Contact frame and relative POI velocity before the impact (module conventions)."""
    c = config
    x1, x2, y1, y2 = c.x[:, 0], c.x[:, 1], c.y[:, 0], c.y[:, 1]
    w1, w2 = c.yaw_rate[:, 0], c.yaw_rate[:, 1]
    nx0, ny0 = -np.sin(c.cp_angle), np.cos(c.cp_angle)
    r1x, r1y = c.poi_x - x1, c.poi_y - y1
    r2x, r2y = c.poi_x - x2, c.poi_y - y2
    # POI velocities, v + omega x r
    u_x = (c.vx[:, 0] - w1 * r1y) - (c.vx[:, 1] - w2 * r2y)
    u_y = (c.vy[:, 0] + w1 * r1x) - (c.vy[:, 1] + w2 * r2x)
    side = nx0 * (x1 - x2) + ny0 * (y1 - y2)
    scale = np.sqrt((x1 - x2) ** 2 + (y1 - y2) ** 2)
    # CGs on the plane line: orient n against the relative POI velocity instead
    degenerate = np.abs(side) <= 1e-9 * np.maximum(scale, 1.0)
    sign = np.where(degenerate, np.where(nx0 * u_x + ny0 * u_y <= 0.0, 1.0, -1.0),
                    np.where(side > 0.0, 1.0, -1.0))
    nx, ny = sign * nx0, sign * ny0
    tx, ty = ny, -nx
    return ContactFrame(nx, ny, tx, ty, u_x * tx + u_y * ty, u_x * nx + u_y * ny)


def poi_relative_velocity(config: ImpactConfig, vx1: np.ndarray, vy1: np.ndarray,
                          w1: np.ndarray, vx2: np.ndarray, vy2: np.ndarray,
                          w2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative POI velocity u = v1_P - v2_P [m/s] (x, y) for given body velocities
    (e.g. the post-impact ones) at the configuration's poses and POI.
    """
    c = config
    r1x, r1y = c.poi_x - c.x[:, 0], c.poi_y - c.y[:, 0]
    r2x, r2y = c.poi_x - c.x[:, 1], c.poi_y - c.y[:, 1]
    return ((vx1 - w1 * r1y) - (vx2 - w2 * r2y), (vy1 + w1 * r1x) - (vy2 + w2 * r2x))


def with_outcome(config: ImpactConfig, result: ImpactResult, *, vx: np.ndarray,
                 vy: np.ndarray, yaw_rate: np.ndarray,
                 energy: np.ndarray | None = None) -> ImpactResult:
    """Result with changed post-impact velocities ``vx``, ``vy`` [m/s] and ``yaw_rate``
    [rad/s] and, optionally, deformation energies ``energy`` [J], each (N, 2) (vehicle
    axis 1); delta-v, EES and the change of velocity angle follow.  The impulse, impact
    type, energy loss and PDOF describe the impulse exchange and stay as they are.
    """
    vx0, vy0 = config.vx, config.vy
    dvx, dvy = vx - vx0, vy - vy0
    keep = result._asdict()
    keep.update(vx_post=vx, vy_post=vy, yaw_rate_post=yaw_rate, delta_vx=dvx, delta_vy=dvy,
                delta_v=velocity_change(dvx, dvy),
                velocity_angle_change=angle_between(vx0, vy0, vx, vy))
    if energy is not None:
        none = (result.impact_type == IMPACT_NONE)[:, None]
        keep["ees"] = np.where(none, result.ees, ees_from_energy(energy, config.m))
    return ImpactResult(**keep)


def deformation_energies(config: ImpactConfig,
                         result: ImpactResult) -> tuple[np.ndarray, np.ndarray]:
    """Deformation energies e1, e2 [J] behind the EES of a result: E = m EES^2 / 2."""
    with np.errstate(invalid="ignore"):  # a fixed object (m = inf) has EES 0 and E 0
        e1 = deformation_energy(config.m[:, 0], result.ees[:, 0])
        e2 = deformation_energy(config.m[:, 1], result.ees[:, 1])
    return (np.where(np.isposinf(config.m[:, 0]), 0.0, e1),
            np.where(np.isposinf(config.m[:, 1]), 0.0, e2))


def solve_impact(config: ImpactConfig,
                 stiffness_ratio: npt.ArrayLike | None = None, *,
                 restitution_mode: str = "impulse") -> ImpactResult:
    """Solve N planar impacts with the Kudlich-Slibar impulse model.

    Parameters
    ----------
    config : ImpactConfig
        Configurations (N,), SI units; values must be valid (see
        :func:`config_problems`; the CLI and the simulators check them).
    stiffness_ratio : array_like, optional
        k1 / k2 for the EES energy split (:func:`energy_split`); NaN or None
        selects the mass rule.
    restitution_mode : {"impulse", "normal"}
        ``"impulse"`` (default, PC-Crash): S = (1 + eps) S_C for both components.
        ``"normal"`` (Brach): u_n' = -eps u_n and, within the friction cone,
        u_t' = 0 (the critical impulse ratio); beyond it |S_t| = mu S_n.

    Returns
    -------
    ImpactResult
    """
    if restitution_mode not in RESTITUTION_MODES:
        raise ParameterError(f"restitution_mode={restitution_mode!r}; use one of "
                             f"{RESTITUTION_MODES}")
    n = config.size
    ratio = None if stiffness_ratio is None else np.broadcast_to(
        np.asarray(stiffness_ratio, float), (n,))
    normal = restitution_mode == "normal"
    from vfs.physics import core  # the switch of the compiled kernels

    if core.enabled():  # the compiled kernel; the numpy blocks below are its reference
        from vfs.physics.core_impact import solve_compiled

        return ImpactResult(**solve_compiled(config, ratio, normal))
    if n <= CHUNK:
        return _solve_block(config, ratio, normal)
    parts = [
        _solve_block(ImpactConfig(*(a[lo:lo + CHUNK] for a in config)),
                     None if ratio is None else ratio[lo:lo + CHUNK], normal)
        for lo in range(0, n, CHUNK)
    ]
    return ImpactResult(*(np.concatenate(f) for f in zip(*parts, strict=True)))


def _solve_block(config: ImpactConfig,
                 stiffness_ratio: npt.ArrayLike | None = None,
                 normal_only: bool = False) -> ImpactResult:
    """Solve one block of impacts (see :func:`solve_impact`)."""
    c = config
    m1, m2, i1, i2 = c.m[:, 0], c.m[:, 1], c.izz[:, 0], c.izz[:, 1]
    vx1, vx2, vy1, vy2 = c.vx[:, 0], c.vx[:, 1], c.vy[:, 0], c.vy[:, 1]
    eps, mu = c.restitution, c.contact_friction
    f = contact_frame(c)
    nx, ny, tx, ty, u_t, u_n = f.nx, f.ny, f.tx, f.ty, f.u_t, f.u_n
    r1x, r1y = c.poi_x - c.x[:, 0], c.poi_y - c.y[:, 0]
    r2x, r2y = c.poi_x - c.x[:, 1], c.poi_y - c.y[:, 1]
    approaching = u_n < 0.0

    r1t, r1n = r1x * tx + r1y * ty, r1x * nx + r1y * ny
    r2t, r2n = r2x * tx + r2y * ty, r2x * nx + r2y * ny
    inv_m = 1.0 / m1 + 1.0 / m2
    k_tt = inv_m + r1n**2 / i1 + r2n**2 / i2
    k_nn = inv_m + r1t**2 / i1 + r2t**2 / i2
    k_tn = -(r1t * r1n / i1 + r2t * r2n / i2)
    det = k_tt * k_nn - k_tn**2  # > 0: K is positive definite

    # full impact: u + K S_c = 0 at the end of compression (the Reconstruction chapter, eq. 24).
    # Normal-only restitution (Brach): the whole impulse solves u_t' = 0,
    # u_n' = -eps u_n, i.e. K S = (-u_t, -(1 + eps) u_n); it is found here as
    # the "compression" impulse of the target (u_t, (1 + eps) u_n) with gain 1.
    un_eff = (1.0 + eps) * u_n if normal_only else u_n
    sc_t = -(k_nn * u_t - k_tn * un_eff) / det
    sc_n = -(-k_tn * u_t + k_tt * un_eff) / det
    full = np.abs(sc_t) <= mu * sc_n
    # sliding impact: |T| = mu N with the sign of the full-impact T; only the
    # normal relative velocity vanishes at the end of compression
    s = np.where(sc_t >= 0.0, 1.0, -1.0)
    denom = k_nn + s * mu * k_tn
    jam = ~full & (denom <= 1e-12 * k_nn)  # no sliding solution; not seen in practice
    full |= jam
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = np.where(full, 0.0, -un_eff / np.where(jam, 1.0, denom))
    comp_t = np.where(full, sc_t, s * mu * lam)
    comp_n = np.where(full, sc_n, lam)
    # total impulse S = (1 + eps) S_C (the Momentum Based Impact Model paper, eq. 5; the
    # Reconstruction chapter, eqs. 25-26); in
    # the normal-only mode the restitution is already in the target velocity
    gain = np.where(approaching, 1.0 if normal_only else 1.0 + eps, 0.0)
    s_t, s_n = gain * comp_t, gain * comp_n
    impulse_x = s_t * tx + s_n * nx
    impulse_y = s_t * ty + s_n * ny

    # momentum and angular momentum balances (the Collision Calculation Uncertainty paper, eqs.
    # 6-11)
    vx1p = vx1 + impulse_x / m1
    vy1p = vy1 + impulse_y / m1
    vx2p = vx2 - impulse_x / m2
    vy2p = vy2 - impulse_y / m2
    w1p = c.yaw_rate[:, 0] + (r1x * impulse_y - r1y * impulse_x) / i1
    w2p = c.yaw_rate[:, 1] - (r2x * impulse_y - r2y * impulse_x) / i2

    # energy loss from the impulse alone, E = -(S.u + S^T K S / 2), which is
    # the difference of the kinetic energies without their cancellation
    k_s_t = k_tt * s_t + k_tn * s_n
    k_s_n = k_tn * s_t + k_nn * s_n
    loss = -(s_t * u_t + s_n * u_n + 0.5 * (s_t * k_s_t + s_n * k_s_n))
    # Newton's kinematic restitution with friction can create energy where the normal and
    # tangential directions are coupled (k_tn != 0; Kane's paradox, also discussed by
    # Brach): there the normal-only mode falls back to the Poisson split (S = (1 + eps)
    # S_C, the default mode), which never gains energy
    created = normal_only & approaching & (
        loss < -1e-12 * (np.abs(s_t * u_t) + np.abs(s_n * u_n)))
    loss = np.maximum(loss, 0.0)  # rounding only; the model never gains energy
    e1, e2 = energy_split(loss, m1, m2, stiffness_ratio)
    dvx1, dvy1 = vx1p - vx1, vy1p - vy1
    dvx2, dvy2 = vx2p - vx2, vy2p - vy2
    pdof1, clock1 = _pdof(impulse_x, impulse_y, c.yaw[:, 0])
    pdof2, clock2 = _pdof(-impulse_x, -impulse_y, c.yaw[:, 1])
    none = ~approaching
    nan = np.full(m1.shape, np.nan)
    result = ImpactResult(
        impact_type=np.where(none, IMPACT_NONE, np.where(full, IMPACT_FULL, IMPACT_SLIDING)),
        normal_x=nx, normal_y=ny,
        closing_speed=-u_n, sliding_speed=u_t,
        impulse_t=s_t, impulse_n=s_n, impulse_x=impulse_x, impulse_y=impulse_y,
        vx_post=_pair(vx1p, vx2p), vy_post=_pair(vy1p, vy2p), yaw_rate_post=_pair(w1p, w2p),
        delta_vx=_pair(dvx1, dvx2), delta_vy=_pair(dvy1, dvy2),
        delta_v=_pair(velocity_change(dvx1, dvy1), velocity_change(dvx2, dvy2)),
        energy_loss=loss, ees=_pair(ees_from_energy(e1, m1), ees_from_energy(e2, m2)),
        velocity_angle_change=_pair(angle_between(vx1, vy1, vx1p, vy1p),
                                    angle_between(vx2, vy2, vx2p, vy2p)),
        pdof=_pair(np.where(none, nan, pdof1), np.where(none, nan, pdof2)),
        pdof_clock=_pair(np.where(none, 0, clock1), np.where(none, 0, clock2)),
    )
    if np.any(created):
        fallback = _solve_block(config, stiffness_ratio, False)
        result = ImpactResult(*(np.where(created.reshape((-1,) + (1,) * (a.ndim - 1)), b, a)
                                for a, b in zip(result, fallback, strict=True)))
    return result
