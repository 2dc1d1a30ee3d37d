"""The reconstructed cases of a database, ready for sampling, and their recorded outcomes.

A case starts from the reconstruction's impact configuration (the expert's
poses, velocities, POI and contact plane, as stored in the database;
docs/data-format.md).  :func:`estimate_penetration` finds how long the
outlines have overlapped at the recorded pose (the time since first contact),
so that the sampled penetration time can move the pose consistently.
:func:`recorded_outcomes` reads the reconstruction's values of the outcomes
through the vfs outcome vocabulary (:func:`vfs.outcomes.from_reconstruction`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.errors import DataError, DataProblem
from vfs.outcomes import from_reconstruction
from vfs.physics.geometry import AREA_TOLERANCE, contact_geometry, overlap, vehicle_outline
from vfs.physics.impact import ImpactConfig, ImpactParams
from vfs.physics.precrash import PrecrashParams
from vfs.physics.vehicle import VehicleArrays
from vfs.simulation import impact_parameters_or_default
from vfs.uncertainty.config import INPUT_NAMES
from vfs.uncertainty.outcomes import OUTCOME_NAMES, OUTCOMES

#: Penetration time assumed where it cannot be estimated [s] (the Momentum Based Impact Model
# paper; the
#: simulation's default, :attr:`vfs.physics.precrash.PrecrashParams.penetration_time`).
DEFAULT_PENETRATION = PrecrashParams().penetration_time
#: Largest penetration time the estimate searches [s].
MAX_PENETRATION = 0.25


class CaseSet(NamedTuple):
    """The reconstructed cases of a database, ready for sampling.

    Attributes
    ----------
    case_id : ndarray (N,)
    vehicle1, vehicle2 : VehicleArrays
    config : ImpactConfig
        Nominal impact configuration of the reconstruction (N,), SI.
    road_friction : ndarray (N,)
        Nominal tyre-road friction [-].
    road_surface : ndarray of str (N,)
    accident_type : ndarray of int (N,)
    penetration : ndarray (N,)
        Penetration time of the recorded pose [s] (:func:`estimate_penetration`;
        :data:`DEFAULT_PENETRATION` where it could not be estimated).
    penetration_estimated : ndarray of bool (N,)
    geo_poi : ndarray (N, 2)
        Geometric POI at the recorded pose [m] (NaN without overlap).
    geo_cp : ndarray (N,)
        Geometric contact-plane angle at the recorded pose [rad].
    sd : mapping of str to ndarray (N,)
        Standard deviation of each input from the database's ``_sd`` columns
        (SI; NaN where the case has none).
    reconstruction : pandas.DataFrame
        The reconstruction rows in case order (observed outcomes, SI units: angles in rad).
    """

    case_id: np.ndarray
    vehicle1: VehicleArrays
    vehicle2: VehicleArrays
    config: ImpactConfig
    road_friction: np.ndarray
    road_surface: np.ndarray
    accident_type: np.ndarray
    penetration: np.ndarray
    penetration_estimated: np.ndarray
    geo_poi: np.ndarray
    geo_cp: np.ndarray
    sd: Mapping[str, np.ndarray]
    reconstruction: pd.DataFrame

    @property
    def size(self) -> int:
        """Number of cases N."""
        return int(self.case_id.shape[0])

    def take(self, index: npt.ArrayLike | slice) -> CaseSet:
        """Cases by position (integer index or mask)."""
        idx = np.arange(self.size)[index]
        return CaseSet(
            self.case_id[idx], self.vehicle1.take(idx), self.vehicle2.take(idx),
            ImpactConfig(*(a[idx] for a in self.config)), self.road_friction[idx],
            self.road_surface[idx], self.accident_type[idx], self.penetration[idx],
            self.penetration_estimated[idx], self.geo_poi[idx], self.geo_cp[idx],
            MappingProxyType({k: v[idx] for k, v in self.sd.items()}),
            self.reconstruction.iloc[idx].reset_index(drop=True))

    def index_of(self, case_ids: Sequence[object]) -> np.ndarray:
        """Positions of the given case ids (DataError naming unknown ones)."""
        text = {str(c): k for k, c in enumerate(self.case_id.tolist())}
        missing = [c for c in case_ids if str(c) not in text]
        if missing:
            raise DataError([DataProblem("reconstruction", "case_id", None, c,
                                         "no reconstructed (colliding) case with this id")
                             for c in missing])
        return np.array([text[str(c)] for c in case_ids], dtype=int)

    @classmethod
    def from_database(cls, db: Any, case_ids: Sequence[object] | None = None) -> CaseSet:
        """The cases of a :class:`vfs.database.Database` that have a reconstruction.

        Parameters
        ----------
        db : Database
        case_ids : sequence, optional
            Cases in the wanted order (default: every reconstructed case in
            database order).

        Raises
        ------
        DataError
            If the database has no reconstruction rows or a case id has none.
        """
        rec = db.reconstruction
        if rec is None or rec.empty:
            raise DataError(DataProblem("reconstruction", "", None, None,
                                        "the database has no reconstruction rows (the "
                                        "uncertainty analysis starts from the impact "
                                        "configuration)"))
        rec = rec.drop_duplicates("case_id")
        have = set(rec["case_id"].tolist())
        if case_ids is None:
            ids = np.array([c for c in db.case_ids if c in have])
        else:
            text = {str(c): c for c in rec["case_id"].tolist()}
            missing = [c for c in case_ids if str(c) not in text]
            if missing:
                raise DataError([DataProblem("reconstruction", "case_id", None, c,
                                             "no reconstruction for this case (unknown case or "
                                             "a near miss)") for c in missing])
            ids = np.array([text[str(c)] for c in case_ids])
        if ids.size == 0:
            raise DataError(DataProblem("reconstruction", "case_id", None, None,
                                        "no case with a reconstruction selected"))
        sub = db.subset(ids)
        v1, v2 = sub.vehicles()
        order = pd.Index(sub.case_ids).get_indexer(ids)
        v1, v2 = v1.take(order), v2.take(order)
        r = rec.set_index("case_id").loc[ids]
        cases = sub.cases.set_index("case_id").loc[ids]

        def col(name: str) -> np.ndarray:
            return r[name].to_numpy(float)

        eps, mu = impact_parameters_or_default(col("restitution"), col("contact_friction"),
                                               ImpactParams())
        config = ImpactConfig.from_columns(
            m1=v1.mass, izz1=v1.yaw_inertia, m2=v2.mass, izz2=v2.yaw_inertia,
            **{k: col(k) for k in ("x1", "y1", "yaw1", "vx1", "vy1", "yaw_rate1", "x2", "y2",
                                   "yaw2", "vx2", "vy2", "yaw_rate2", "poi_x", "poi_y",
                                   "cp_angle")},
            restitution=eps, contact_friction=mu)
        pen, ok = estimate_penetration(v1, v2, config)
        o1 = vehicle_outline(v1, config.x[:, 0], config.y[:, 0], config.yaw[:, 0])
        o2 = vehicle_outline(v2, config.x[:, 1], config.y[:, 1], config.yaw[:, 1])
        geo = contact_geometry(o1, o2, np.stack([config.x[:, 0], config.y[:, 0]], 1),
                               np.stack([config.x[:, 1], config.y[:, 1]], 1))
        sd = _database_sd(r, config)
        return cls(ids, v1, v2, config, cases["road_friction"].to_numpy(float),
                   cases["road_surface"].astype(str).to_numpy(),
                   cases["accident_type"].to_numpy(), pen, ok, geo.poi, geo.cp_angle,
                   MappingProxyType(sd), r.reset_index())


def _database_sd(r: pd.DataFrame, c: ImpactConfig) -> dict[str, np.ndarray]:
    """Standard deviations of the inputs from the reconstruction's ``_sd`` columns (SI)."""
    n = c.size

    def sd(name: str) -> np.ndarray:
        key = f"{name}_sd"
        return r[key].to_numpy(float) if key in r.columns else np.full(n, np.nan)

    out = {name: np.full(n, np.nan) for name in INPUT_NAMES}
    out["restitution"] = sd("restitution")
    out["contact_friction"] = sd("contact_friction")
    out["cp_angle"] = sd("cp_angle")
    out["penetration_time"] = sd("t_impact")
    sx, sy = sd("poi_x"), sd("poi_y")
    ct, st = np.cos(c.cp_angle), np.sin(c.cp_angle)
    out["poi_shift_t"] = np.hypot(sx * ct, sy * st)
    out["poi_shift_n"] = np.hypot(sx * st, sy * ct)
    for i in (1, 2):
        vx, vy = c.vx[:, i - 1], c.vy[:, i - 1]
        speed = np.hypot(vx, vy)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[f"speed{i}"] = np.where(speed > 1e-6,
                                        np.hypot(vx * sd(f"vx{i}"), vy * sd(f"vy{i}")) / speed,
                                        np.hypot(sd(f"vx{i}"), sd(f"vy{i}")))
    return out


def _shifted_outlines(v1: VehicleArrays, v2: VehicleArrays, c: ImpactConfig,
                      tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outlines with both vehicles moved kinematically by ``tau`` [s] (negative: back)."""
    t = np.asarray(tau)[..., None]
    x, y, yaw = c.x + t * c.vx, c.y + t * c.vy, c.yaw + t * c.yaw_rate
    o1 = vehicle_outline(v1, x[:, 0], y[:, 0], yaw[:, 0])
    o2 = vehicle_outline(v2, x[:, 1], y[:, 1], yaw[:, 1])
    return o1, o2


def estimate_penetration(v1: VehicleArrays, v2: VehicleArrays, config: ImpactConfig,
                         iterations: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Penetration time of recorded impact poses [s], by moving the vehicles back.

    Both vehicles move back along their CG velocities and yaw rates (straight
    kinematic motion, the same approximation the sampling uses to vary the
    penetration) until the overlap area falls to
    :data:`vfs.physics.geometry.AREA_TOLERANCE`; bisection on [0, MAX_PENETRATION]
    to 0.25 s / 2^24 = 15 ns.

    Returns
    -------
    penetration : ndarray (N,)
        Time since the first contact [s]; :data:`DEFAULT_PENETRATION` where the
        recorded outlines do not overlap or still overlap after
        :data:`MAX_PENETRATION`.
    estimated : ndarray of bool (N,)
        False where the default was used.
    """
    n = config.size
    lo = np.zeros(n)
    hi = np.full(n, MAX_PENETRATION)
    area0 = overlap(*_shifted_outlines(v1, v2, config, lo)).area
    area_max = overlap(*_shifted_outlines(v1, v2, config, -hi)).area
    ok = (area0 > AREA_TOLERANCE) & (area_max <= AREA_TOLERANCE)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        inside = overlap(*_shifted_outlines(v1, v2, config, -mid)).area > AREA_TOLERANCE
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return np.where(ok, hi, DEFAULT_PENETRATION), ok


def recorded_outcomes(cases: CaseSet) -> dict[str, np.ndarray]:
    """The reconstruction's values of the outcomes (SI; NaN where not recorded).

    Derived as the vfs outcome vocabulary derives them
    (:func:`vfs.outcomes.from_reconstruction`), e.g. the run-out distance as
    the straight distance from the CG at impact to the CG at rest.
    """
    n = cases.size
    found = from_reconstruction(cases.reconstruction, sorted({o.vocabulary for o in OUTCOMES}))
    out: dict[str, np.ndarray] = {}
    for o in OUTCOMES:
        values = found.get(o.vocabulary)
        out[o.name] = np.full(n, np.nan) if values is None else \
            np.ascontiguousarray(values[:, max(o.vehicle, 1) - 1], dtype=float)
    return {name: out[name] for name in OUTCOME_NAMES}


__all__ = [
    "DEFAULT_PENETRATION", "MAX_PENETRATION", "CaseSet", "estimate_penetration",
    "recorded_outcomes",
]
