"""Small built-in examples: impact configurations of head-on and oblique collisions.

The table is built from first principles, not typed in: two cars approach on
given paths, the outlines are placed at a given penetration depth, and the
POI and contact plane follow from :func:`vfs.physics.geometry.contact_geometry`
(the Momentum Based Impact Model paper rules).  ``vfs/data/example_impacts.csv`` is this table;
a test checks that the file is what this function produces.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from vfs.database import Database
from vfs.database.source import data_path
from vfs.physics.geometry import contact_geometry, vehicle_outline
from vfs.physics.impact import ImpactParams
from vfs.physics.precrash import PrecrashParams
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import kmh_to_ms

EXAMPLE_IMPACTS = data_path("example_impacts.csv")

#: (case_id, description, speed1 [km/h], speed2 [km/h], lateral offset [m],
#:  angle of vehicle 2's path against head-on [deg], yaw rate 1 [rad/s])
_EXAMPLES = [
    (1, "head-on, full overlap", 60.0, 60.0, 0.0, 0.0, 0.0),
    (2, "head-on, 50 % overlap", 70.0, 50.0, 0.9, 0.0, 0.0),
    (3, "head-on, 25 % overlap", 80.0, 80.0, 1.35, 0.0, 0.0),
    (4, "oblique frontal, 20 deg", 60.0, 70.0, 0.5, 20.0, 0.0),
    (5, "head-on in a bend, yawing", 70.0, 60.0, 0.7, 10.0, 0.25),
    (6, "small overlap, high speed", 100.0, 90.0, 1.55, 5.0, 0.0),
]

SMALL_CAR = VehicleParams(mass=1100.0, length=3.9, width=1.7, wheelbase=2.45,
                          cg_to_front_axle=1.0, front_overhang=0.8, track_width=1.45,
                          cg_height=0.52, name="small car")
LARGE_CAR = VehicleParams(mass=1750.0, length=4.8, width=1.85, wheelbase=2.85,
                          cg_to_front_axle=1.3, front_overhang=0.95, track_width=1.6,
                          cg_height=0.56, name="large car")


def example_impact_table(params: ImpactParams | None = None) -> pd.DataFrame:
    """Impact configurations (SI) for the examples above, ready for ``vfs impact``."""
    params = ImpactParams() if params is None else params
    penetration_time = PrecrashParams().penetration_time  # [s]
    rows = []
    v1p, v2p = stack_vehicles([LARGE_CAR]), stack_vehicles([SMALL_CAR])
    for case_id, _, kmh1, kmh2, offset, angle_deg, yaw_rate1 in _EXAMPLES:
        speed1, speed2 = float(kmh_to_ms(kmh1)), float(kmh_to_ms(kmh2))
        yaw2 = np.pi + np.radians(angle_deg)
        # closing along x: place the fronts so that they overlap by the
        # distance the closing speed covers in the penetration time
        depth = (speed1 + speed2 * np.cos(np.radians(angle_deg))) * penetration_time
        x2 = LARGE_CAR.cg_to_front + SMALL_CAR.cg_to_front * np.cos(np.radians(angle_deg)) - depth
        y2 = offset
        o1 = vehicle_outline(v1p, [0.0], [0.0], [0.0])
        o2 = vehicle_outline(v2p, [x2], [y2], [yaw2])
        g = contact_geometry(o1, o2, [[0.0, 0.0]], [[x2, y2]])
        rows.append({
            "case_id": case_id,
            "m1": LARGE_CAR.mass, "izz1": LARGE_CAR.izz, "x1": 0.0, "y1": 0.0, "yaw1": 0.0,
            "vx1": speed1, "vy1": 0.0, "yaw_rate1": yaw_rate1,
            "m2": SMALL_CAR.mass, "izz2": SMALL_CAR.izz, "x2": x2, "y2": y2, "yaw2": yaw2,
            "vx2": speed2 * np.cos(yaw2), "vy2": speed2 * np.sin(yaw2), "yaw_rate2": 0.0,
            "poi_x": g.poi[0, 0], "poi_y": g.poi[0, 1], "cp_angle": g.cp_angle[0],
            "restitution": params.restitution, "contact_friction": params.contact_friction,
        })
    return pd.DataFrame(rows)


def write_example_impacts(path: Path = EXAMPLE_IMPACTS) -> None:
    """Regenerate the bundled example table."""
    example_impact_table().to_csv(path, index=False, float_format="%.12g")


if __name__ == "__main__":  # pragma: no cover
    write_example_impacts()


def example_case_database() -> Database:
    """The built-in example case for ``vfs run-case``: a head-on with partial overlap.

    Vehicle 1 (large car, 60 km/h) drives through a gentle left bend (radius
    250 m, so it arrives with a real yaw rate) and meets vehicle 2 (small
    car, 50 km/h, straight) with about 0.9 m lateral offset.  The records are
    PreCrash-Matrix-like: 10 ms samples from 5 s before first contact to
    0.5 s after it.  The database carries no reconstruction
    (``has_reconstruction = False``).
    """
    from vfs.database import Database, default_meta
    from vfs.database.schema import empty_table

    dt, t_contact, radius = 0.01, 5.0, 250.0
    t = np.arange(0.0, t_contact + 0.5 + 1e-9, dt)
    v1, v2 = float(kmh_to_ms(60.0)), float(kmh_to_ms(50.0))
    # vehicle 1: arc through the origin, heading 0 at t_contact
    arc = v1 * (t - t_contact) / radius
    x1, y1 = radius * np.sin(arc), radius * (1.0 - np.cos(arc))
    # vehicle 2: straight, heading pi, front touching vehicle 1's front at t_contact
    offset = 0.9
    x2c = LARGE_CAR.cg_to_front + SMALL_CAR.cg_to_front
    x2 = x2c - v2 * (t - t_contact)
    trajectories = pd.concat([
        pd.DataFrame({"case_id": 1, "participant": 1, "t": t, "x": x1, "y": y1, "yaw": arc,
                      "speed": v1, "accel": 0.0}),
        pd.DataFrame({"case_id": 1, "participant": 2, "t": t, "x": x2,
                      "y": np.full(t.size, offset), "yaw": np.pi, "speed": v2, "accel": 0.0}),
    ], ignore_index=True)
    participants = pd.DataFrame([
        {"case_id": 1, "participant": i, "mass": car.mass, "yaw_inertia": np.nan,
         "length": car.length, "width": car.width, "wheelbase": car.wheelbase,
         "cg_to_front_axle": car.cg_to_front_axle, "front_overhang": car.front_overhang,
         "track_width": car.track_width, "cg_height": car.cg_height, "vehicle_class": "car"}
        for i, car in ((1, LARGE_CAR), (2, SMALL_CAR))
    ])
    cases = pd.DataFrame([{
        "case_id": 1, "accident_type": 242, "road_friction": 0.8, "road_surface": "dry",
        "road_curvature": 1.0 / radius, "weight": 1.0, "collision": True,
        "description": "built-in example: head-on with partial overlap in a bend",
    }])
    meta = default_meta("example", "vfs.scenarios.examples", "built-in example case")
    meta["has_reconstruction"] = False
    return Database(cases=cases, participants=participants, trajectories=trajectories,
                    reconstruction=empty_table("reconstruction"),
                    meta=meta).normalised()
