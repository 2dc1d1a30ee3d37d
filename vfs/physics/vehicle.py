"""Vehicle parameters.

A vehicle is described by a small frozen dataclass (:class:`VehicleParams`) for
one vehicle and by :class:`VehicleArrays` (a NamedTuple of arrays) for many
vehicles at once; the physics kernels take the arrays.

Vehicle frame: origin at the centre of gravity (CG), x forward, y to the left,
yaw counter-clockwise positive (ISO 8855 seen from above).  The outline is a
rectangle: the front bumper lies ``front_overhang + cg_to_front_axle`` ahead of
the CG, the rear bumper ``length`` behind the front bumper, the sides
``width / 2`` to either side of the longitudinal axis.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError

# ----------------------------------------------------------------------------
# Yaw inertia estimates when the real value is unknown
# ----------------------------------------------------------------------------


def yaw_inertia_axle_product(
    mass: npt.ArrayLike, cg_to_front_axle: npt.ArrayLike, cg_to_rear_axle: npt.ArrayLike,
    length: npt.ArrayLike, width: npt.ArrayLike, wheelbase: npt.ArrayLike,
) -> np.ndarray:
    """Yaw inertia I = m * L1 * L2 [kg m^2] (the Front-to-Side Energy Balance paper).

    L1, L2 [m] are the distances from the CG to the front and rear axle.  This
    is the default of vfs: it depends only on data every database has and gives
    2,000-3,500 kg m^2 for mid-size cars, in line with measured values.
    """
    return np.asarray(mass, float) * np.asarray(cg_to_front_axle, float) * np.asarray(
        cg_to_rear_axle, float
    )


def yaw_inertia_box(
    mass: npt.ArrayLike, cg_to_front_axle: npt.ArrayLike, cg_to_rear_axle: npt.ArrayLike,
    length: npt.ArrayLike, width: npt.ArrayLike, wheelbase: npt.ArrayLike,
) -> np.ndarray:
    """Yaw inertia of a homogeneous box, I = m (l^2 + w^2) / 12 [kg m^2] (openPASS default)."""
    m, ln, w = (np.asarray(a, float) for a in (mass, length, width))
    return m * (ln**2 + w**2) / 12.0


def yaw_inertia_zeidler(
    mass: npt.ArrayLike, cg_to_front_axle: npt.ArrayLike, cg_to_rear_axle: npt.ArrayLike,
    length: npt.ArrayLike, width: npt.ArrayLike, wheelbase: npt.ArrayLike,
) -> np.ndarray:
    """Yaw inertia I = 0.1269 m R L [kg m^2] (R wheelbase, L length; after Zeidler, EES tools)."""
    return 0.1269 * np.asarray(mass, float) * np.asarray(wheelbase, float) * np.asarray(
        length, float
    )


YawInertiaFormula = Callable[..., np.ndarray]

#: Registry of yaw-inertia formulas, by name.  ``"axle_product"`` is the default.
YAW_INERTIA_FORMULAS: dict[str, YawInertiaFormula] = {
    "axle_product": yaw_inertia_axle_product,
    "box": yaw_inertia_box,
    "zeidler": yaw_inertia_zeidler,
}
DEFAULT_YAW_INERTIA_FORMULA = "axle_product"


# ----------------------------------------------------------------------------
# Parameters of one vehicle
# ----------------------------------------------------------------------------

#: Allowed ranges [min, max] of the vehicle parameters, in SI units.  They
#: cover passenger cars, vans and light trucks; heavier vehicles need their own
#: validation, which is why the limits live in one place.
PARAMETER_RANGES: dict[str, tuple[float, float]] = {
    "mass": (50.0, 60_000.0),  # [kg]
    "yaw_inertia": (1.0, 1.0e6),  # [kg m^2]
    "length": (1.0, 20.0),  # [m]
    "width": (0.5, 3.0),  # [m]
    "wheelbase": (0.5, 12.0),  # [m]
    "cg_to_front_axle": (0.05, 11.95),  # [m]
    "front_overhang": (0.0, 3.0),  # [m]
    "track_width": (0.3, 3.0),  # [m]
    "cg_height": (0.1, 3.0),  # [m]
}


@dataclass(frozen=True)
class VehicleParams:
    """Parameters of one vehicle (SI units).

    Attributes
    ----------
    mass : float
        Mass [kg].
    length : float
        Overall length of the outline rectangle [m].
    width : float
        Overall width of the outline rectangle [m].
    wheelbase : float
        Distance between front and rear axle [m].
    cg_to_front_axle : float
        Longitudinal distance from the CG to the front axle, L1 [m].
    front_overhang : float
        Distance from the front axle to the front bumper [m]; places the outline
        relative to the CG.
    track_width : float
        Distance between left and right wheels [m].
    cg_height : float
        Height of the CG above the ground [m] (load transfer).
    yaw_inertia : float | None
        Yaw moment of inertia about the CG [kg m^2]; ``None`` means unknown, in
        which case :attr:`izz` uses :data:`DEFAULT_YAW_INERTIA_FORMULA`
        (I = m L1 L2, the Front-to-Side Energy Balance paper).
    name : str
        Free label (make/model), not used by the physics.
    """

    mass: float = 1500.0
    length: float = 4.5
    width: float = 1.8
    wheelbase: float = 2.7
    cg_to_front_axle: float = 1.2
    front_overhang: float = 0.9
    track_width: float = 1.55
    cg_height: float = 0.55
    yaw_inertia: float | None = None
    name: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        problems = validate_vehicle_values(asdict(self))
        if problems:
            raise ParameterError("invalid VehicleParams: " + "; ".join(problems))

    @property
    def cg_to_rear_axle(self) -> float:
        """Longitudinal distance from the CG to the rear axle, L2 [m]."""
        return self.wheelbase - self.cg_to_front_axle

    @property
    def cg_to_front(self) -> float:
        """Distance from the CG to the front bumper [m]."""
        return self.front_overhang + self.cg_to_front_axle

    @property
    def cg_to_rear(self) -> float:
        """Distance from the CG to the rear bumper [m]."""
        return self.length - self.cg_to_front

    @property
    def izz(self) -> float:
        """Yaw inertia [kg m^2]: the given value, else the default formula."""
        if self.yaw_inertia is not None:
            return float(self.yaw_inertia)
        return float(
            YAW_INERTIA_FORMULAS[DEFAULT_YAW_INERTIA_FORMULA](
                self.mass, self.cg_to_front_axle, self.cg_to_rear_axle,
                self.length, self.width, self.wheelbase,
            )
        )


def validate_vehicle_values(values: dict[str, object]) -> list[str]:
    """Check one vehicle's parameter values; return human-readable problems.

    Checks ranges (:data:`PARAMETER_RANGES`) and the consistency of the layout:
    front overhang + wheelbase must fit in the length, the CG must lie between
    the axles and the track inside the width.
    """
    problems: list[str] = []
    for key, (lo, hi) in PARAMETER_RANGES.items():
        v = values.get(key)
        if v is None and key == "yaw_inertia":
            continue
        try:
            fv = float(v)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            problems.append(f"{key}={v!r} is not a number (allowed [{lo:g}, {hi:g}])")
            continue
        if not math.isfinite(fv) or not lo <= fv <= hi:
            problems.append(f"{key}={fv:g} outside the allowed range [{lo:g}, {hi:g}]")
    if problems:
        return problems
    length = float(values["length"])  # type: ignore[arg-type]
    width = float(values["width"])  # type: ignore[arg-type]
    wheelbase = float(values["wheelbase"])  # type: ignore[arg-type]
    lf = float(values["cg_to_front_axle"])  # type: ignore[arg-type]
    fo = float(values["front_overhang"])  # type: ignore[arg-type]
    track = float(values["track_width"])  # type: ignore[arg-type]
    if not lf < wheelbase:
        problems.append(
            f"cg_to_front_axle={lf:g} must be smaller than wheelbase={wheelbase:g} "
            "(the CG lies between the axles)"
        )
    if fo + wheelbase > length + 1e-9:
        problems.append(
            f"front_overhang + wheelbase = {fo + wheelbase:g} exceeds length={length:g}"
        )
    if track > width + 1e-9:
        problems.append(f"track_width={track:g} exceeds width={width:g}")
    return problems


# ----------------------------------------------------------------------------
# Many vehicles as arrays
# ----------------------------------------------------------------------------


class VehicleArrays(NamedTuple):
    """Parameters of N vehicles as arrays of shape (N,), SI units.

    Field meanings and units are those of :class:`VehicleParams`;
    ``yaw_inertia`` is always filled (default formula where unknown).
    """

    mass: np.ndarray  # [kg]
    yaw_inertia: np.ndarray  # [kg m^2]
    length: np.ndarray  # [m]
    width: np.ndarray  # [m]
    wheelbase: np.ndarray  # [m]
    cg_to_front_axle: np.ndarray  # [m]
    front_overhang: np.ndarray  # [m]
    track_width: np.ndarray  # [m]
    cg_height: np.ndarray  # [m]

    @property
    def cg_to_rear_axle(self) -> np.ndarray:
        """CG to rear axle, L2 [m]."""
        return self.wheelbase - self.cg_to_front_axle

    @property
    def cg_to_front(self) -> np.ndarray:
        """CG to front bumper [m]."""
        return self.front_overhang + self.cg_to_front_axle

    @property
    def cg_to_rear(self) -> np.ndarray:
        """CG to rear bumper [m]."""
        return self.length - self.cg_to_front

    @property
    def corner_radius(self) -> np.ndarray:
        """Distance [m] from the CG to the farthest outline corner (:func:`corner_radius`)."""
        return corner_radius(self.cg_to_front, self.cg_to_rear, self.width)

    @property
    def size(self) -> int:
        """Number of vehicles N."""
        return int(self.mass.shape[0])

    def take(self, index: npt.ArrayLike) -> VehicleArrays:
        """Select vehicles by integer index or boolean mask."""
        return VehicleArrays(*(np.asarray(a)[index] for a in self))


def corner_radius(cg_to_front: npt.ArrayLike, cg_to_rear: npt.ArrayLike,
                  width: npt.ArrayLike) -> np.ndarray:
    """Distance [m] from the CG to the farthest corner of the outline rectangle.

    sqrt(max(l_f, l_r)^2 + (w / 2)^2) with l_f, l_r the distances [m] from the CG to
    the front and rear bumper and w the width [m] (:func:`numpy.hypot`).  Every
    point of the outline lies within this radius of the CG (the "half diagonal"
    of broad phases and stop criteria; half the diagonal when the CG sits in the
    outline centre).  For a rectangle given by its half length h and the offset
    c of its centre ahead of the CG, l_f = h + c and l_r = h - c.
    """
    return np.hypot(np.maximum(cg_to_front, cg_to_rear), 0.5 * np.asarray(width))


def stack_vehicles(vehicles: Sequence[VehicleParams]) -> VehicleArrays:
    """Stack a sequence of :class:`VehicleParams` into :class:`VehicleArrays`."""
    return VehicleArrays(
        mass=np.array([v.mass for v in vehicles], float),
        yaw_inertia=np.array([v.izz for v in vehicles], float),
        length=np.array([v.length for v in vehicles], float),
        width=np.array([v.width for v in vehicles], float),
        wheelbase=np.array([v.wheelbase for v in vehicles], float),
        cg_to_front_axle=np.array([v.cg_to_front_axle for v in vehicles], float),
        front_overhang=np.array([v.front_overhang for v in vehicles], float),
        track_width=np.array([v.track_width for v in vehicles], float),
        cg_height=np.array([v.cg_height for v in vehicles], float),
    )


def vehicle_arrays(
    mass: npt.ArrayLike, length: npt.ArrayLike, width: npt.ArrayLike,
    wheelbase: npt.ArrayLike, cg_to_front_axle: npt.ArrayLike,
    front_overhang: npt.ArrayLike, track_width: npt.ArrayLike, cg_height: npt.ArrayLike,
    yaw_inertia: npt.ArrayLike | None = None,
    yaw_inertia_formula: str = DEFAULT_YAW_INERTIA_FORMULA,
) -> VehicleArrays:
    """Build :class:`VehicleArrays` from column arrays (broadcast to a common shape).

    Where ``yaw_inertia`` is ``None`` or NaN, ``yaw_inertia_formula`` (a key of
    :data:`YAW_INERTIA_FORMULAS`) fills it in.
    """
    if yaw_inertia_formula not in YAW_INERTIA_FORMULAS:
        raise ParameterError(
            f"unknown yaw inertia formula {yaw_inertia_formula!r}; "
            f"known: {sorted(YAW_INERTIA_FORMULAS)}"
        )
    cols = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(a, float)) for a in (
            mass, length, width, wheelbase, cg_to_front_axle, front_overhang,
            track_width, cg_height,
        ))
    )
    m, ln, w, wb, lf, fo, tw, h = (np.array(c, float) for c in cols)
    estimate = YAW_INERTIA_FORMULAS[yaw_inertia_formula](m, lf, wb - lf, ln, w, wb)
    if yaw_inertia is None:
        izz = estimate
    else:
        izz = np.broadcast_to(np.asarray(yaw_inertia, float), m.shape).copy()
        izz = np.where(np.isnan(izz), estimate, izz)
    return VehicleArrays(m, izz, ln, w, wb, lf, fo, tw, h)
