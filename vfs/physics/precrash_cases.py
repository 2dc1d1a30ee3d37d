"""The case instances of a pre-crash run: their data rows, clocks and outcomes.

:class:`PrecrashCases` is the part of :class:`vfs.physics.precrash.PrecrashRun`
that holds what each case instance ("row") has reached: contact, impact,
closest approach, braking (arrays over the n rows, vehicle 1 in column 0 of
the (n, 2) arrays), each row's clock (the step it started at), and the
post-processing of ended rows into a :class:`PrecrashResult`
(:meth:`PrecrashCases.finalize`, :meth:`PrecrashCases.result`).  The stepping
(integration, contact detection) is :class:`~vfs.physics.precrash.PrecrashRun`'s;
the contact kinematics and tests are in :mod:`vfs.physics.precrash_contact`.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from vfs.physics.geometry import (
    AREA_TOLERANCE,
    contact_geometry,
    outline_distance,
    vehicle_outline,
)
from vfs.physics.paths import PathArrays
from vfs.physics.precrash_contact import (
    largest_overlap,
    nan_state,
    outlines,
    overlap_area,
    put_rows,
    take_state,
)
from vfs.physics.precrash_result import KinematicState, PrecrashResult
from vfs.physics.vehicle import VehicleArrays


class PrecrashCases:
    """Data rows, clocks and outcomes of the n case instances of a pre-crash run.

    Parameters
    ----------
    vehicle1, vehicle2 : VehicleArrays
        The cases' vehicles (data rows).
    paths : PathArrays
        Their recorded paths (participant 1 of all cases, then participant 2).
    dt : float
        Time step [s].
    n : int
        Case instances (rows).
    case_of : ndarray of int, optional
        Data row of each instance (default: row i is case i).
    """

    rows: np.ndarray  # the running rows (kept by the run)
    running: np.ndarray  # (n,) bool

    def __init__(self, vehicle1: VehicleArrays, vehicle2: VehicleArrays, paths: PathArrays,
                 dt: float, n: int, case_of: np.ndarray | None) -> None:
        self.v1, self.v2, self.paths = vehicle1, vehicle2, paths
        self.case_of = case_of
        self.n = n
        self.dt = dt
        self.k = 0
        self.k0 = np.zeros(n, dtype=np.int64)
        self.collided = np.zeros(n, dtype=bool)
        self.contact_time = np.full(n, np.nan)
        self.min_distance = np.full(n, np.inf)
        self.time_closest = np.full(n, np.nan)
        self.brake_start = np.full((n, 2), np.nan)
        self.speed_reduction = np.zeros((n, 2))
        self.impact_state = nan_state(n)
        self.contact_state = nan_state(n)
        self.end_state = nan_state(n)
        self.contact_dv = np.zeros((n, 2))  # reductions at first contact
        self.contact_ds = np.zeros((n, 2))
        # per case, the integration state at impact time is interpolated between
        # the two steps around it; remember the reductions at both
        self.pending = np.zeros(n, dtype=bool)  # in contact, waiting for impact time
        self.impact_time = np.full(n, np.nan)
        self.best_time = np.full(n, np.nan)  # time of the smallest CG distance
        self.best_pose = np.full((3, n, 2), np.nan)  # x, y, yaw of both at that moment
        self.poi = np.full((n, 2), np.nan)
        self.cp_angle = np.full(n, np.nan)
        self.cp_rule = np.zeros(n, dtype=np.int64)
        self.area = np.zeros(n)
        self.final = np.zeros(n, dtype=bool)  # post-processed by finalize

    def _reset_outcomes(self, new: np.ndarray) -> None:
        """Fresh outcomes of rows ``new`` (started again)."""
        for arr, value in ((self.collided, False), (self.contact_time, np.nan),
                           (self.min_distance, np.inf), (self.time_closest, np.nan),
                           (self.brake_start, np.nan), (self.speed_reduction, 0.0),
                           (self.contact_dv, 0.0), (self.contact_ds, 0.0),
                           (self.pending, False), (self.impact_time, np.nan),
                           (self.best_time, np.nan), (self.poi, np.nan),
                           (self.cp_angle, np.nan), (self.cp_rule, 0), (self.area, 0.0),
                           (self.final, False)):
            arr[new] = value
        self.best_pose[:, new] = np.nan
        for st in (self.impact_state, self.contact_state, self.end_state):
            put_rows(st, new, nan_state(new.size))

    # ------------------------------------------------------------------ clocks

    def _d(self, rows: np.ndarray) -> np.ndarray:
        """Data rows (vehicles, paths) of case instances ``rows``."""
        return rows if self.case_of is None else self.case_of[rows]

    @property
    def time(self) -> float:
        """Time of the run's current step k dt [s] (a case's own time when all started at 0)."""
        return self.k * self.dt

    def local_time(self, rows: np.ndarray | None = None) -> np.ndarray:
        """Time since the start of their records [s] of cases ``rows`` (default: running)."""
        rows = self.rows if rows is None else rows
        return (self.k - self.k0[rows]) * self.dt

    @property
    def common_clock(self) -> bool:
        """All running cases started at the same step (their times are equal)."""
        k0 = self.k0[self.rows]
        return bool(k0.size == 0 or (k0 == k0[0]).all())

    def _observed_time(self, rows: np.ndarray) -> float | np.ndarray:
        k0 = self.k0[rows]
        if k0.size == 0 or (k0 == k0[0]).all():
            return (self.k - int(k0[0])) * self.dt if k0.size else self.time
        return (self.k - k0) * self.dt

    # ------------------------------------------------------------------ results

    def finalize(self, rows: npt.ArrayLike | None = None) -> None:
        """Post-process ended cases ``rows`` (default: all ended, not yet finalized).

        Outline distance of far passes, grazing contacts (impact moved to the
        largest overlap) and the contact geometry (POI, contact plane) at
        impact.
        """
        if rows is None:
            sel = np.flatnonzero(~self.final & ~self.running)
        else:
            sel = np.asarray(rows, np.int64).reshape(-1)
            sel = sel[~self.final[sel]]
        if sel.size == 0:
            return
        v1, v2, paths = self.v1, self.v2, self.paths
        # never within CLOSE_RANGE: outline distance at the moment of minimal CG distance
        far = np.isinf(self.min_distance[sel]) & ~np.isnan(self.best_time[sel])
        if far.any():
            r = sel[far]
            bp = self.best_pose[:, r]
            o1 = vehicle_outline(v1.take(self._d(r)), bp[0, :, 0], bp[1, :, 0], bp[2, :, 0])
            o2 = vehicle_outline(v2.take(self._d(r)), bp[0, :, 1], bp[1, :, 1], bp[2, :, 1])
            self.min_distance[r] = outline_distance(o1, o2)
            self.time_closest[r] = self.best_time[r]
        hit = self.collided[sel] & ~np.isnan(self.impact_state.x[sel, 0])
        self.collided[sel] = hit
        if hit.any():
            r = sel[hit]
            graze = overlap_area(v1, v2, self._d(r), take_state(self.impact_state, r)) \
                <= AREA_TOLERANCE
            if graze.any():
                # grazing contact: the outlines separated again within the
                # penetration time; take the impact at the largest overlap
                g_rows = r[graze]
                t_best, st_best = largest_overlap(paths, v1, v2, self._d(g_rows),
                                                   self.contact_time[g_rows],
                                                   self.impact_time[g_rows],
                                                   self.contact_dv[g_rows],
                                                   self.contact_ds[g_rows])
                self.impact_time[g_rows] = t_best
                put_rows(self.impact_state, g_rows, st_best)
            st = take_state(self.impact_state, r)
            o1, o2 = outlines(v1, v2, self._d(r), st)
            cg1 = np.stack([st.x[:, 0], st.y[:, 0]], axis=1)
            cg2 = np.stack([st.x[:, 1], st.y[:, 1]], axis=1)
            g = contact_geometry(o1, o2, cg1, cg2)
            self.poi[r], self.cp_angle[r], self.cp_rule[r], self.area[r] = \
                g.poi, g.cp_angle, g.rule, g.area
        self.final[sel] = True

    def result(self, rows: npt.ArrayLike | None = None) -> PrecrashResult:
        """The :class:`PrecrashResult` of all cases (default) or of the ended ``rows``.

        Finalizes what is not yet; a case still running has NaN results.
        """
        self.finalize(None if rows is None else rows)
        idx = slice(None) if rows is None else np.asarray(rows, np.int64).reshape(-1)
        hit = self.collided[idx]
        min_distance = self.min_distance[idx]
        take = lambda st: KinematicState(*(a[idx] for a in st))  # noqa: E731
        return PrecrashResult(
            collided=hit, contact_time=np.where(hit, self.contact_time[idx], np.nan),
            impact_time=np.where(hit, self.impact_time[idx], np.nan),
            impact_state=take(self.impact_state), contact_state=take(self.contact_state),
            poi=self.poi[idx], cp_angle=self.cp_angle[idx], cp_rule=self.cp_rule[idx],
            overlap_area=self.area[idx],
            min_distance=np.where(np.isinf(min_distance), np.nan, min_distance),
            time_closest=self.time_closest[idx], brake_start=self.brake_start[idx],
            speed_reduction=self.speed_reduction[idx], end_state=take(self.end_state),
            end_time=self.time,
        )


__all__ = ["PrecrashCases"]
