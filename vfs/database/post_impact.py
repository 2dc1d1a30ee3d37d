"""The post-impact inputs of a reconstruction table as :class:`PostImpactInputs`.

The optional reconstruction columns ``post_brake_<wheel>{i}``, ``post_driver_brake{i}``,
``post_drag_<wheel>{i}``, ``post_steer{i}`` and ``post_steer_onset{i}``
(:data:`vfs.database.schema.POST_IMPACT_COLUMNS`) become the arrays of
:class:`vfs.physics.post_impact.PostImpactInputs`; absent columns, NaN values and cases
without a reconstruction row are NaN there, the run-out's defaults.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.database.schema import POST_IMPACT_COLUMNS, POST_IMPACT_WHEELS
from vfs.physics.post_impact import PostImpactInputs


def has_post_impact_columns(reconstruction: pd.DataFrame | None) -> bool:
    """True if the table has any post-impact input column."""
    if reconstruction is None:
        return False
    names = {c.name for c in POST_IMPACT_COLUMNS}
    return bool(names & set(reconstruction.columns))


def post_impact_inputs(reconstruction: pd.DataFrame | None,
                       case_ids: npt.ArrayLike) -> PostImpactInputs | None:
    """The post-impact inputs of the given cases, or None when the table has none.

    Parameters
    ----------
    reconstruction : pandas.DataFrame or None
        Normalised reconstruction table in SI units (angles in rad).
    case_ids : array_like (N,)
        The cases, in the wanted order.

    Returns
    -------
    PostImpactInputs or None
        None when no post-impact column is present (every case runs with the defaults).
    """
    if reconstruction is None or not has_post_impact_columns(reconstruction):
        return None
    ids = np.asarray(case_ids)
    rec = reconstruction.drop_duplicates("case_id").set_index("case_id").reindex(ids)

    def column(name: str) -> np.ndarray:
        if name not in rec.columns:
            return np.full(ids.shape[0], np.nan)
        return rec[name].to_numpy(dtype=float, na_value=np.nan)

    def per_vehicle(stem: str) -> np.ndarray:
        return np.stack([column(f"{stem}{i}") for i in (1, 2)], axis=1)

    def per_wheel(stem: str) -> np.ndarray:
        return np.stack([np.stack([column(f"{stem}_{w}{i}") for w in POST_IMPACT_WHEELS],
                                  axis=1) for i in (1, 2)], axis=1)

    return PostImpactInputs(brake=per_wheel("post_brake"),
                            driver_brake=per_vehicle("post_driver_brake"),
                            drag=per_wheel("post_drag"), steer_angle=per_vehicle("post_steer"),
                            steer_onset=per_vehicle("post_steer_onset"))
