"""Recorded pre-crash paths of a database's cases, packed for the physics.

The trajectories table (docs/data-format.md) becomes the padded path arrays of
:mod:`vfs.physics.paths`; positions in m, yaw in rad, speed in m/s, time in s.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.errors import DataError, DataProblem
from vfs.physics.paths import PathArrays, pack_paths

__all__ = ["paths_from_trajectories"]


def paths_from_trajectories(trajectories: pd.DataFrame, case_ids: npt.ArrayLike,
                            participant: int) -> PathArrays:
    """Pack one participant's trajectories of the given cases (in that order).

    ``trajectories`` has the database columns case_id, participant, t, x, y,
    yaw, speed and optionally accel (docs/data-format.md).
    """
    case_ids = np.asarray(case_ids)
    # row positions and columns as arrays: no frame is copied (nor its attrs)
    rows = np.flatnonzero(np.asarray(trajectories["participant"] == participant, dtype=bool))
    order = pd.Index(case_ids)
    group = order.get_indexer(trajectories["case_id"].to_numpy()[rows])
    keep = group >= 0
    rows = rows[keep]
    group = group[keep]
    missing = np.setdiff1d(np.arange(len(case_ids)), group)
    if missing.size:
        raise DataError([DataProblem("trajectories", "", None, case_ids[i],
                                     f"participant {participant} has no trajectory")
                         for i in missing[:20]])
    sort = np.lexsort((trajectories["t"].to_numpy()[rows], group))
    rows = rows[sort]

    def column(name: str) -> np.ndarray:
        return np.asarray(trajectories[name], float)[rows]

    accel = column("accel") if "accel" in trajectories.columns else None
    return pack_paths(column("t"), column("x"), column("y"), column("yaw"), column("speed"),
                      group[sort], accel)
