"""Case features of the diagnosis and the law discovery (SI units).

:func:`case_features` is the one computation of the features of each case
from the reconstruction (used by :mod:`vfs.diagnosis.diagnose` and
:mod:`vfs.diagnosis.identify`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from vfs.diagnosis.calibrate import CalibrationData
from vfs.physics.geometry import swept_overlap, vehicle_outline


def case_features(data: CalibrationData) -> pd.DataFrame:
    """Features of each case from the reconstruction and the case data (SI units).

    Columns: case_id, impact_type (the reconstruction's), accident_type,
    road_surface, closing_speed [m/s] (|v1 - v2| at impact), overlap [-]
    (:func:`vfs.physics.geometry.swept_overlap` of the outlines at the recorded
    impact configuration along v1 - v2), mass_ratio m1 / m2 [-],
    impact_angle [rad] (angle between the headings, 0 = same direction,
    pi = head-on), impact_speed1/2 [m/s], road_friction, restitution,
    contact_friction (recorded).
    """
    rec = data.reconstruction
    b = data.batch

    def col(name: str) -> np.ndarray:
        return pd.to_numeric(rec[name], errors="coerce").to_numpy(float)

    x1, y1, yaw1, x2, y2, yaw2 = (col(c) for c in ("x1", "y1", "yaw1", "x2", "y2", "yaw2"))
    vx1, vy1, vx2, vy2 = (col(c) for c in ("vx1", "vy1", "vx2", "vy2"))
    o1 = vehicle_outline(b.vehicle1, x1, y1, yaw1)
    o2 = vehicle_outline(b.vehicle2, x2, y2, yaw2)
    rel = np.stack([vx1 - vx2, vy1 - vy2], axis=1)
    cases = data.db.cases.drop_duplicates("case_id").set_index("case_id").reindex(data.case_ids)
    out = pd.DataFrame({
        "case_id": data.case_ids,
        "impact_type": rec["impact_type"].astype(str).to_numpy(),
        "accident_type": cases["accident_type"].astype(str).to_numpy()
        if "accident_type" in cases.columns else "unknown",
        "road_surface": cases["road_surface"].astype(str).to_numpy()
        if "road_surface" in cases.columns else "unknown",
        "closing_speed": np.hypot(rel[:, 0], rel[:, 1]),
        "overlap": swept_overlap(o1, o2, rel),
        "mass_ratio": b.vehicle1.mass / b.vehicle2.mass,
        "impact_angle": np.abs((yaw2 - yaw1 + np.pi) % (2 * np.pi) - np.pi),
        "impact_speed1": np.hypot(vx1, vy1),
        "impact_speed2": np.hypot(vx2, vy2),
        "road_friction": b.road_friction,
        "restitution": col("restitution"),
        "contact_friction": col("contact_friction"),
    })
    return out


__all__ = ["case_features"]
