"""A small synthetic database for tests and documentation (numpy only).

Cases alternate between a head-on collision on a straight road (accident type
241) and a rear-end collision (type 601, longitudinal traffic).  Both vehicles
drive straight at constant speed, sampled every 10 ms for 5 s; the impact
happens at the last sample, t = 5 s, front bumper against front (head-on) or
rear bumper.  The reconstruction rows follow from the collinear central
impact with Newton restitution:

    u1' = (m1 u1 + m2 u2 - m2 e (u1 - u2)) / (m1 + m2)
    u2' = (m1 u1 + m2 u2 + m1 e (u1 - u2)) / (m1 + m2)
    E_loss = m1 m2 / (2 (m1 + m2)) (1 - e^2) (u1 - u2)^2

(e.g. Brach & Brach, Vehicle Accident Analysis and Reconstruction Methods).
The energy loss is split E1 / E2 = m2 / m1 (equal contact force, stiffness
proportional to mass; docs/references.md) and EES_i = sqrt(2 E_i / m_i)
(the Reconstruction chapter).  After the impact each vehicle slides straight to rest,
d = u'^2 / (2 mu g).  Nothing here is real accident data.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from vfs.database.database import Database, default_meta
from vfs.database.schema import TABLE_NAMES, empty_table, normalise_table
from vfs.units import KMH_PER_MS, G

#: Sampling step of the example trajectories [s].
EXAMPLE_TIME_STEP = 0.01
#: Duration of the example trajectories [s]; the impact is at the end.
EXAMPLE_DURATION = 5.0
HEAD_ON_TYPE = 241  # head-on collision on a straight road
REAR_END_TYPE = 601  # rear-end collision in longitudinal traffic (illustrative code)


def _vehicle(rng: np.random.Generator, case_id: int, participant: int) -> dict[str, object]:
    length = rng.uniform(4.0, 4.8)  # [m]
    width = rng.uniform(1.7, 1.9)  # [m]
    wheelbase = rng.uniform(2.5, 2.9)  # [m]
    mass = rng.uniform(1100.0, 1900.0)  # [kg]
    return {
        "case_id": case_id,
        "participant": participant,
        "mass": mass,
        # participant 1 with a "measured" inertia (box formula), participant 2 unknown
        "yaw_inertia": mass * (length**2 + width**2) / 12.0 if participant == 1 else np.nan,
        "length": length,
        "width": width,
        "wheelbase": wheelbase,
        "cg_to_front_axle": wheelbase * rng.uniform(0.40, 0.50),  # [m]
        "front_overhang": rng.uniform(0.80, 0.95),  # [m]; + wheelbase <= 3.85 < length
        "track_width": rng.uniform(1.45, 1.60),  # [m] < width
        "cg_height": rng.uniform(0.50, 0.60),  # [m]
        "vehicle_class": "car",
    }


def _surface(mu: float) -> str:
    return "dry" if mu >= 0.7 else "wet" if mu >= 0.4 else "snow"


def _angle_change(before: float, after: float) -> float:
    """Angle between collinear velocities u and u' [rad]; NaN if one is zero."""
    if before == 0.0 or after == 0.0:
        return float("nan")
    return 0.0 if np.sign(before) == np.sign(after) else math.pi


def make_example_database(n_cases: int = 4, seed: int = 0) -> Database:
    """Build a small valid database of straight-line head-on and rear-end collisions.

    Parameters
    ----------
    n_cases : int
        Number of cases (even case index: head-on, odd: rear-end).
    seed : int
        Seed of the ``numpy.random.Generator`` drawing speeds and vehicles.

    Returns
    -------
    Database
        Normalised database with ``n_cases`` colliding cases, 501 trajectory
        samples per participant (10 ms over 5 s) and one reconstruction row
        per case (with ``delta_v1_sd`` and ``delta_v2_sd`` uncertainty columns).

    Examples
    --------
    >>> db = make_example_database(2)
    >>> db.n_cases, len(db.trajectories)
    (2, 2004)
    """
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, EXAMPLE_DURATION, round(EXAMPLE_DURATION / EXAMPLE_TIME_STEP) + 1)
    t_impact = EXAMPLE_DURATION
    cases, participants, trajectories, reconstruction = [], [], [], []
    for k in range(n_cases):
        case_id = 1001 + k
        head_on = k % 2 == 0
        v1_, v2_ = _vehicle(rng, case_id, 1), _vehicle(rng, case_id, 2)
        participants += [v1_, v2_]
        m1, m2 = float(v1_["mass"]), float(v2_["mass"])  # type: ignore[arg-type]
        cg_front1 = float(v1_["front_overhang"]) + float(v1_["cg_to_front_axle"])  # type: ignore[arg-type]
        cg_front2 = float(v2_["front_overhang"]) + float(v2_["cg_to_front_axle"])  # type: ignore[arg-type]
        cg_rear2 = float(v2_["length"]) - cg_front2  # type: ignore[arg-type]
        mu = float(np.round(rng.uniform(0.3, 1.0), 2))
        origin = rng.uniform(-100.0, 100.0, size=2)  # point of impact [m]
        lateral_offset = rng.uniform(-0.4, 0.4)  # [m], vehicle 2 relative to vehicle 1
        if head_on:
            speed1 = rng.uniform(40.0, 70.0) / KMH_PER_MS  # [m/s]
            speed2 = rng.uniform(30.0, 60.0) / KMH_PER_MS
            u1, u2 = speed1, -speed2  # signed velocities along the global x axis
            yaw1, yaw2 = 0.0, np.pi
            x1_imp, x2_imp = -cg_front1, cg_front2  # front bumpers meet at the POI
            pdof1, pdof2 = 0.0, 0.0
        else:
            speed1 = rng.uniform(50.0, 80.0) / KMH_PER_MS
            speed2 = speed1 * rng.uniform(0.2, 0.6)
            u1, u2 = speed1, speed2
            yaw1, yaw2 = 0.0, 0.0
            x1_imp, x2_imp = -cg_front1, cg_rear2  # front of 1 against rear of 2
            pdof1, pdof2 = 0.0, math.pi
        y1_imp, y2_imp = 0.0, lateral_offset
        cases.append({
            "case_id": case_id,
            "accident_type": HEAD_ON_TYPE if head_on else REAR_END_TYPE,
            "road_friction": mu,
            "road_surface": _surface(mu),
            "road_curvature": 0.0,
            "weight": float(np.round(rng.uniform(0.5, 2.0), 3)),
            "collision": True,
            "description": "synthetic head-on collision" if head_on
            else "synthetic rear-end collision",
        })
        for number, u, x_imp, y_imp, yaw in ((1, u1, x1_imp, y1_imp, yaw1),
                                             (2, u2, x2_imp, y2_imp, yaw2)):
            trajectories.append(pd.DataFrame({
                "case_id": case_id,
                "participant": number,
                "t": t,
                "x": origin[0] + x_imp - u * (t_impact - t),  # constant velocity u along x
                "y": origin[1] + y_imp,
                "yaw": yaw,
                "speed": abs(u),
                "accel": 0.0 if number == 1 else np.nan,
            }))
        e = float(rng.uniform(0.1, 0.3))  # restitution
        m = m1 + m2
        u1_post = (m1 * u1 + m2 * u2 - m2 * e * (u1 - u2)) / m
        u2_post = (m1 * u1 + m2 * u2 + m1 * e * (u1 - u2)) / m
        energy_loss = 0.5 * m1 * m2 / m * (1.0 - e**2) * (u1 - u2) ** 2  # [J]
        e1, e2 = energy_loss * m2 / m, energy_loss * m1 / m  # E1/E2 = m2/m1
        delta_v1, delta_v2 = abs(u1_post - u1), abs(u2_post - u2)
        row: dict[str, object] = {"case_id": case_id, "t_impact": t_impact}
        for number, u, x_imp, y_imp, yaw in ((1, u1, x1_imp, y1_imp, yaw1),
                                             (2, u2, x2_imp, y2_imp, yaw2)):
            row |= {
                f"x{number}": origin[0] + x_imp, f"y{number}": origin[1] + y_imp,
                f"yaw{number}": yaw, f"vx{number}": u, f"vy{number}": 0.0,
                f"yaw_rate{number}": 0.0,
            }
        row |= {
            "poi_x": origin[0], "poi_y": origin[1] + 0.5 * lateral_offset,
            "cp_angle": 0.5 * np.pi,  # contact plane perpendicular to the x axis
            "restitution": e, "contact_friction": float(rng.uniform(0.4, 0.7)),
            "impact_type": "full",
            "vx1_post": u1_post, "vy1_post": 0.0, "yaw_rate1_post": 0.0,
            "vx2_post": u2_post, "vy2_post": 0.0, "yaw_rate2_post": 0.0,
            "delta_v1": delta_v1, "delta_v2": delta_v2,
            "ees1": np.sqrt(2.0 * e1 / m1), "ees2": np.sqrt(2.0 * e2 / m2),
            "energy_loss": energy_loss,
            "pdof1": pdof1, "pdof2": pdof2,
            "velocity_angle_change1": _angle_change(u1, u1_post),
            "velocity_angle_change2": _angle_change(u2, u2_post),
        }
        for number, u_post, x_imp, y_imp, yaw in ((1, u1_post, x1_imp, y1_imp, yaw1),
                                                  (2, u2_post, x2_imp, y2_imp, yaw2)):
            slide = u_post**2 / (2.0 * mu * G)  # straight slide to rest [m]
            row |= {
                f"rest_x{number}": origin[0] + x_imp + np.sign(u_post) * slide,
                f"rest_y{number}": origin[1] + y_imp,
                f"rest_yaw{number}": yaw,
            }
        row |= {"delta_v1_sd": 0.1 * delta_v1, "delta_v2_sd": 0.1 * delta_v2}
        reconstruction.append(row)
    frames = {
        "cases": pd.DataFrame(cases),
        "participants": pd.DataFrame(participants),
        "trajectories": pd.concat(trajectories, ignore_index=True) if trajectories else None,
        "reconstruction": pd.DataFrame(reconstruction),
    }
    tables = {
        name: normalise_table(frames[name], name) if frames[name] is not None
        and len(frames[name]) else empty_table(name)
        for name in TABLE_NAMES
    }
    meta = default_meta(
        name="example", created_by="vfs.scenarios.example_database.make_example_database",
        description=f"{n_cases} synthetic straight-line collisions (seed {seed}); "
        "for tests and documentation only",
    )
    return Database(**tables, meta=meta)
