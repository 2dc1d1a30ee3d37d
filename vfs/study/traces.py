"""Time traces of the pre-crash phase: speed, brake demand and poses at every step.

The simulation keeps no time series (a study stores one row per run).  For the
few cases someone wants to look into (the case pages of the reports),
:class:`TraceRecorder` wraps the run's brake controller (or stands in for
none): at every step it passes the observation on, returns the controller's
demand unchanged and keeps, for the chosen cases, the time, both vehicles'
poses and speeds, the delivered deceleration and the demand.  A run with the
recorder therefore gives exactly the results of the same run without it.

Example
-------
>>> from vfs.scenarios.examples import example_case_database
>>> from vfs.simulation import CaseBatch
>>> batch = CaseBatch.from_database(example_case_database())
>>> res, traces = simulate_with_traces(batch)
>>> trace = traces[0]
>>> bool(trace.t[0] == 0.0) and trace.speed.shape[1] == 2
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from vfs.simulation import CaseBatch, CaseResults, SimulationParams, simulate_cases

if TYPE_CHECKING:  # pragma: no cover
    from vfs.physics.precrash import BrakeController


@dataclass(frozen=True)
class RunTrace:
    """The pre-crash phase of one run, one entry per simulation step (SI units).

    Attributes
    ----------
    t : ndarray (K,)
        Time since the start of the records [s].
    x, y, yaw : ndarray (K, 2)
        CG poses of vehicles 1 and 2 [m, m, rad].
    speed : ndarray (K, 2)
        Speeds [m/s].
    deceleration : ndarray (K, 2)
        Brake deceleration the actuator delivers [m/s^2].
    demand : ndarray (K, 2)
        Deceleration the controller demands [m/s^2] (NaN without a controller:
        the record is replayed).
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray
    deceleration: np.ndarray
    demand: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


_FIELDS = ("x", "y", "yaw", "speed", "deceleration", "demand")


class TraceRecorder:
    """A brake controller that records the steps of chosen cases and otherwise passes through.

    Parameters
    ----------
    controller : BrakeController or None
        The controller whose demand is passed on; None replays the record (the
        demand stays None, as in a run without a controller).
    rows : array_like of int
        Positions in the batch of the cases to record.
    """

    def __init__(self, controller: Any | None, rows: npt.ArrayLike) -> None:
        self.controller = controller
        self.rows = np.unique(np.asarray(rows, np.int64).reshape(-1))
        self._log: list[tuple[np.ndarray, ...]] = []

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Reset the controller (same ``rng``) and forget earlier steps."""
        if self.controller is not None:
            self.controller.reset(n_cases, rng)
        self._log = []

    def demand(self, obs: Any) -> np.ndarray | None:
        """The controller's demand [m/s^2] (n, 2), or None without one; records the step."""
        out = None if self.controller is None else self.controller.demand(obs)
        sel = np.flatnonzero(np.isin(obs.rows, self.rows))
        if sel.size:
            t = np.broadcast_to(np.asarray(obs.t, float), obs.rows.shape)[sel]
            demand = (np.full((sel.size, 2), np.nan) if out is None
                      else np.asarray(out, float)[sel])
            self._log.append((obs.rows[sel], t, obs.x[sel], obs.y[sel], obs.yaw[sel],
                              obs.speed[sel], obs.deceleration[sel], demand))
        return out

    def events(self) -> dict[str, np.ndarray]:
        """The controller's events (``controller.events()``; none without one)."""
        events = getattr(self.controller, "events", None)
        return dict(events()) if callable(events) else {}

    def trace(self, row: int) -> RunTrace:
        """The recorded steps of the case at batch position ``row``."""
        parts = [entry for entry in self._log if (entry[0] == row).any()]
        if not parts:
            empty = np.zeros((0, 2))
            return RunTrace(np.zeros(0), *(empty for _ in _FIELDS))
        cols: list[list[np.ndarray]] = [[] for _ in range(7)]
        for entry in parts:
            k = int(np.flatnonzero(entry[0] == row)[0])
            for c in range(7):
                cols[c].append(entry[c + 1][k])
        t = np.asarray(cols[0], float)
        return RunTrace(t, *(np.asarray(c, float).reshape(-1, 2) for c in cols[1:]))


def simulate_with_traces(batch: CaseBatch, controller: Any | None = None,
                         params: SimulationParams | None = None,
                         rng: np.random.Generator | None = None,
                         rows: npt.ArrayLike | None = None
                         ) -> tuple[CaseResults, dict[int, RunTrace]]:
    """:func:`vfs.simulation.simulate_cases` with the traces of cases ``rows``.

    Parameters
    ----------
    batch, controller, params, rng
        As for :func:`~vfs.simulation.simulate_cases` (the results are the same).
    rows : array_like of int, optional
        Batch positions to record; default all.

    Returns
    -------
    results : CaseResults
    traces : dict of int to RunTrace
        By batch position.
    """
    wanted = np.arange(batch.size) if rows is None else np.asarray(rows, np.int64)
    recorder = TraceRecorder(controller, wanted)
    # a BrakeController whose demand may be None (= no controller), which the
    # simulation accepts: it keeps the actuator's output
    res = simulate_cases(batch, controller=cast("BrakeController", recorder), params=params,
                         rng=rng)
    return res, {int(r): recorder.trace(int(r)) for r in wanted}


__all__ = ["RunTrace", "TraceRecorder", "simulate_with_traces"]
