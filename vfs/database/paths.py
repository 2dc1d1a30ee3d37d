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
    tr = trajectories[trajectories["participant"] == participant]
    order = pd.Index(case_ids)
    group = order.get_indexer(tr["case_id"].to_numpy())
    keep = group >= 0
    tr = tr[keep]
    group = group[keep]
    missing = np.setdiff1d(np.arange(len(case_ids)), group)
    if missing.size:
        raise DataError([DataProblem("trajectories", "", None, case_ids[i],
                                     f"participant {participant} has no trajectory")
                         for i in missing[:20]])
    sort = np.lexsort((tr["t"].to_numpy(), group))
    tr = tr.iloc[sort]
    accel = tr["accel"].to_numpy(float) if "accel" in tr.columns else None
    return pack_paths(tr["t"], tr["x"], tr["y"], tr["yaw"], tr["speed"], group[sort], accel)
