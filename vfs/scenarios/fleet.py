"""Passenger-car fleet of the synthetic scenes: segments, shares and parameter ranges (SI)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from vfs.errors import ParameterError
from vfs.scenarios.validation import check_count, check_range, check_rng

__all__ = ["FLEET", "FLEET_COLUMNS", "FleetClass", "sample_fleet", "sample_fleet_arrays"]


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
            check_range(f"fleet class {self.name!r} {name}", getattr(self, name), lo=0.0)
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


def sample_fleet_arrays(n: int, rng: np.random.Generator,
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
    n = check_count(n)
    check_rng(rng)
    cols, _ = sample_fleet_arrays(n, rng)
    frame = pd.DataFrame(cols)
    frame["vehicle_class"] = "car"
    return frame[list(FLEET_COLUMNS)]
