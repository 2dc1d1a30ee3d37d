"""The bundled crash-test database (``--db crash-tests``), built from the papers' numbers.

Five instrumented tests nobody here made:

* cases 1-3: AB1-AB3 of "The process of front-to-side collision of motor
  vehicles in terms of energy balance" (energy-balance paper): Honda Accord A
  (front) into the left side of Honda Accord B at a right angle;
* case 4: the Ford Mondeo / Opel Vectra test of "Analysis of uncertainty in
  vehicle collision calculation methods" (collision-uncertainty paper);
* case 5: the NHTSA Mercedes C300 full-overlap rigid-barrier test of
  "Modeling head-on collisions: the problem of identifying collision
  parameters" (head-on identification paper); the barrier is a fixed object.

Every number below names its source; every other number is an assumption,
marked ``ASSUMPTION``.  ``scenarios/databases/crash-tests/README.md`` lists them all.
Regenerate with ``python -m vfs.scenarios.crash_tests scenarios/databases/crash-tests``.

Measured outcomes go into the reconstruction table with ``outcome_source =
'measurement'``; outcomes the papers' text does not give are NaN (not
measured).  Measured quantities without a schema column are extra columns
``measured_*`` (SI); the papers' identified model parameters and computed values (the
Opel's CRASH3 EES) are ``paper_*`` columns, never outcomes.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from statistics import NormalDist
from typing import Any

import numpy as np
import pandas as pd

from vfs.database.database import Database, default_meta
from vfs.database.schema import (
    MEASURABLE_COLUMNS,
    OUTCOME_MEASUREMENT,
    TABLE_NAMES,
    empty_table,
    normalise_table,
)
from vfs.units import KMH_PER_MS

#: Time of first contact on the trajectory time axis [s] (ASSUMPTION: any value works).
CONTACT_TIME = 1.0
#: Trajectory sampling step [s] and length after first contact [s] (straight, constant
#: speed: ASSUMPTION, the tests are run on a straight approach; the record after
#: contact is the undisturbed continuation, only used to carry the replay into the
#: 30 ms penetration of the model).
TIME_STEP = 0.01
AFTER_CONTACT = 0.3

# --- energy-balance paper, Table 1 (section 2): AB1, AB2, AB3 -----------------------------
AB_MASS_A = (1569.0, 1532.0, 1545.0)  # m_A [kg]
AB_MASS_B = (1568.0, 1594.0, 1629.0)  # m_B [kg]
AB_INERTIA_A = (2722.0, 2636.0, 2661.0)  # I_A [kg m^2], from I = m L1 L2 (its eq. 1)
AB_INERTIA_B = (2710.0, 2777.0, 2827.0)  # I_B [kg m^2]
AB_L_AB = (1.25, 1.34, 1.33)  # car A's symmetry plane to car B's front axle [m]
AB_SPEED_A = (15.1, 12.7, 15.3)  # V_A [m/s]
# Section 2: "In the first two tests, vehicle B moved with a velocity half as high as
# that of vehicle A; during the third test, vehicle B was stationary."
AB_SPEED_B_FACTOR = (0.5, 0.5, 0.0)
# Section 4: separation when F_xA reaches zero: t_k = 0.12, 0.09, 0.11 s
AB_SEPARATION_TIME = (0.12, 0.09, 0.11)
# Table 2 (section 5) [kJ]: E_kAB(0), E_kAB(t_k), E_D, E_T, E_tAB, E_p (all at t = t_k)
AB_ENERGY_KJ = {
    "kinetic_energy_contact": (226.9, 160.5, 185.5),
    "kinetic_energy_separation": (128.0, 95.9, 92.4),
    "deformation_work": (68.9, 48.3, 67.4),
    "body_friction_work": (11.9, 5.5, 3.4),
    "tyre_road_work": (13.8, 7.4, 17.3),
    "other_loss": (4.4, 3.4, 4.9),
}
# Table 3 (section 5): V_A from its eq. (29) with dE = E_D + E_T + E_tAB + E_p and with E_D
AB_SPEED_A_EQ29_ALL = (15.9, 13.0, 15.4)
AB_SPEED_A_EQ29_ED = (13.4, 11.3, 13.2)
# ASSUMPTION (not in the paper): Honda Accord saloon 2000-2002 (European model),
# wheelbase 2.67 m, length 4.60 m, width 1.75 m, track 1.50 m, CG height 0.55 m,
# front overhang half of the overhangs.  The CG position follows from the paper's
# own inertia formula I = m L1 L2 with L1 + L2 = wheelbase (the root L1 < L2:
# front-engined car).
ACCORD = dict(length=4.60, width=1.75, wheelbase=2.67, track_width=1.50, cg_height=0.55)
#: Dry concrete (section 2: "on a dry concrete surface"); mu itself is an ASSUMPTION.
AB_ROAD_FRICTION = 0.8

# --- collision-uncertainty paper, Table 1 (section 2.1) ------------------------------
# Ford (1) Mondeo MK I, Opel (2) Vectra B: impact speed, curb weight, length, width,
# wheelbase, track width, CoG to front axle, CoG height.
MV_SPEED_KMH = (42.1, 38.0)  # Table 1 and Fig. 1; the abstract and section 6 say 42.1 and
MV_SPEED_KMH_ALTERNATIVE = (42.1, 30.0)  # 30.0 km/h: AMBIGUOUS, Table 1 chosen
MV_MASS = (1306.0, 1170.0)  # curb weight [kg] (the test mass is not given)
MV_LENGTH = (4.48, 4.48)
MV_WIDTH = (1.75, 1.70)
MV_WHEELBASE = (2.70, 2.60)
MV_TRACK = (1.50, 1.50)
MV_CG_TO_FRONT = (1.03, 1.09)
MV_CG_HEIGHT = (0.56, 0.50)
# Section 2.3: "For the second vehicle, the EBS was approximately 13.6 km/h" (EBS ~ EES
# here, as the paper states), "calculated according to the CRASH3 standard using the RWD
# software": a value COMPUTED from the crush profile with CRASH3 stiffness coefficients,
# not a measurement, so it goes into a ``paper_*`` column (`paper_ees2_crash3`), not into
# `ees2`.  The first vehicle's EES is only in its Fig. 3.
MV_EES2_KMH = 13.6
#: The paper gives no uncertainty.  CRASH3's published accuracy: "the 95 percent
#: confidence limits on individual calculations of delta-V range from 9 to 25 percent"
#: (Smith and Noga, "Accuracy and Sensitivity of CRASH", NHTSA DOT HS 806 152, 1982, 53
#: vehicles in 27 staged collisions).  Delta-v and EES both follow from the same crush
#: energy as its square root, so the same relative limits apply to the EES; we take the
#: upper 25 % as the 95 % limit (ASSUMPTION: the unfavourable end, since the Opel's
#: side and the RWD coefficients are not validated): sd = 0.25 / 1.96 of the value.
MV_EES2_CRASH3_REL_95 = 0.25
MV_EES2_SD_KMH = MV_EES2_KMH * MV_EES2_CRASH3_REL_95 / NormalDist().inv_cdf(0.975)
#: Section 4: the pre-impact velocities are orthogonal.  ASSUMPTION (its Fig. 2 is not in
#: the text): the Ford's front strikes the Opel's left side, the Ford's centreline
#: passing through the Opel's CG.
MV_ROAD_FRICTION = 0.7  # ASSUMPTION: dry road; the paper varies mu in 0.4-0.8

# --- head-on identification paper, section 3 and Table 1 ----------------------------
C300_SPEED_KMH = 56.3
C300 = dict(mass=1703.0, length=4.581, width=1.770, wheelbase=2.760,
            # "the front axle: 1.549 m and the rear axle: 1.552 m": track widths (they sum
            # to more than the wheelbase, so they cannot be CG-axle distances); front used
            track_width=1.549,
            # "the height above the ground: 0.552 m": read as CG height (AMBIGUOUS)
            cg_height=0.552,
            yaw_inertia=2771.0)  # "yaw: 2771 kgm3", unit typo for kg m^2
#: ASSUMPTION: CG midway between the axles (not given; I = m L1 L2 would put it at
#: 0.85 m behind the front axle, implausible, so the paper's inertia is not that formula).
C300_CG_TO_FRONT = C300["wheelbase"] / 2.0
C300_ROAD_FRICTION = 0.8  # its Table 1: slip friction coefficient 0.8 (default = identified)
C300_RESTITUTION = 0.19  # its Table 1, identified (default 0 -> 0.24)
C300_WHEEL_LOCK_TIME = 0.035  # its Table 1 / section 3: front wheels blocked at 35 ms
#: ASSUMPTION: the rigid barrier as a fixed object of 1.0 m x 3.0 m (its outline only
#: gives the contact face; mass and inertia columns are not used for a fixed object).
BARRIER = dict(mass=60000.0, length=1.0, width=3.0, wheelbase=0.5, cg_to_front_axle=0.25,
               front_overhang=0.25, track_width=0.3, cg_height=0.5)


def cg_to_front_from_inertia(mass: float, yaw_inertia: float, wheelbase: float) -> float:
    """L1 [m] from I = m L1 L2, L1 + L2 = wheelbase (energy-balance paper, eq. 1), L1 <= L2."""
    product = yaw_inertia / mass
    return 0.5 * (wheelbase - math.sqrt(wheelbase**2 - 4.0 * product))


def _participant(case_id: int, number: int, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = {"case_id": case_id, "participant": number,
                              "yaw_inertia": math.nan, "vehicle_class": "car",
                              "fixed_object": False}
    row.update(values)
    if "front_overhang" not in row:  # ASSUMPTION: front overhang = half of both overhangs
        row["front_overhang"] = 0.5 * (float(row["length"]) - float(row["wheelbase"]))
    return row


def _trajectory(case_id: int, number: int, x: float, y: float, yaw: float,
                speed: float) -> pd.DataFrame:
    """Straight constant-speed record through (x, y) at CONTACT_TIME [m, rad, m/s]."""
    t = np.round(np.arange(0.0, CONTACT_TIME + AFTER_CONTACT + 1e-9, TIME_STEP), 10)
    s = speed * (t - CONTACT_TIME)
    return pd.DataFrame({"case_id": case_id, "participant": number, "t": t,
                         "x": x + s * math.cos(yaw), "y": y + s * math.sin(yaw),
                         "yaw": yaw, "speed": speed, "accel": 0.0})


def _pose(x: float, y: float, yaw: float, speed: float) -> dict[str, float]:
    return {"x": x, "y": y, "yaw": yaw, "vx": speed * math.cos(yaw),
            "vy": speed * math.sin(yaw), "yaw_rate": 0.0}


def _reconstruction(case_id: int, p1: dict[str, float], p2: dict[str, float],
                    poi: tuple[float, float], cp_angle: float,
                    measured: dict[str, float]) -> dict[str, object]:
    row: dict[str, object] = {c: math.nan for c in MEASURABLE_COLUMNS}  # not measured
    row.update(case_id=case_id, t_impact=CONTACT_TIME)
    for i, pose in ((1, p1), (2, p2)):
        row.update({f"{k}{i}": v for k, v in pose.items()})
    row.update(poi_x=poi[0], poi_y=poi[1], cp_angle=cp_angle,
               restitution=math.nan, contact_friction=math.nan,  # not measured: defaults
               impact_type="", outcome_source=OUTCOME_MEASUREMENT)
    row.update(measured)
    return row


#: Unit and description of the columns beyond the schema (``meta.json`` key ``columns``;
#: the Parquet writer puts them into the field metadata).
EXTRA_COLUMNS: dict[str, dict[str, str]] = {
    "measured_kinetic_energy_contact": {
        "unit": "J", "description": "energy-balance paper, Table 2: E_kAB(0), kinetic energy "
        "of both cars at first contact (measured)"},
    "measured_kinetic_energy_separation": {
        "unit": "J", "description": "energy-balance paper, Table 2: E_kAB(t_k), kinetic "
        "energy of both cars at separation (measured)"},
    "measured_deformation_work": {
        "unit": "J", "description": "energy-balance paper, Table 2: E_D, deformation work"},
    "measured_body_friction_work": {
        "unit": "J", "description": "energy-balance paper, Table 2: E_T, friction work between "
        "the bodies"},
    "measured_tyre_road_work": {
        "unit": "J", "description": "energy-balance paper, Table 2: E_tAB, tyre-road friction "
        "work during the contact"},
    "measured_other_loss": {
        "unit": "J", "description": "energy-balance paper, Table 2: E_p, other losses"},
    "measured_separation_time": {
        "unit": "s", "description": "energy-balance paper, section 4: separation time t_k "
        "(F_xA reaches zero)"},
    "paper_speed_a_eq29_all": {
        "unit": "m/s", "description": "energy-balance paper, Table 3: V_A from its eq. (29) "
        "with all energy terms"},
    "paper_speed_a_eq29_deformation": {
        "unit": "m/s", "description": "energy-balance paper, Table 3: V_A from its eq. (29) "
        "with the deformation work only"},
    "paper_speed2_alternative": {
        "unit": "m/s", "description": "collision-uncertainty paper: the other speed of the "
        "Vectra its text gives (30.0 km/h; Table 1's 38.0 km/h is used)"},
    "paper_restitution": {
        "unit": "-", "description": "head-on identification paper, Table 1: identified "
        "restitution"},
    "paper_front_wheel_lock_time": {
        "unit": "s", "description": "head-on identification paper, Table 1: time at which "
        "the front wheels block"},
    "paper_ees2_crash3": {
        "unit": "m/s", "description": "collision-uncertainty paper, section 2.3: the Opel's "
        "EES computed with the CRASH3 method (13.6 km/h), not a measurement"},
    "paper_ees2_crash3_sd": {
        "unit": "m/s", "description": "standard deviation of paper_ees2_crash3: 25 % as a 95 % "
        "limit, from Smith and Noga's CRASH accuracy (see docs/references.md)"},
}


def build_crash_test_database() -> Database:
    """The five crash tests as a database (SI units; see the module docstring).

    Returns
    -------
    Database
        Cases 1-3 AB1-AB3, 4 Mondeo/Vectra, 5 C300 barrier; outcome_source =
        'measurement' for all.
    """
    cases, parts, trajs, recs = [], [], [], []
    for k in range(3):  # --- AB1-AB3 -------------------------------------------------
        cid = k + 1
        lf_a = cg_to_front_from_inertia(AB_MASS_A[k], AB_INERTIA_A[k], ACCORD["wheelbase"])
        lf_b = cg_to_front_from_inertia(AB_MASS_B[k], AB_INERTIA_B[k], ACCORD["wheelbase"])
        a = _participant(cid, 1, mass=AB_MASS_A[k], yaw_inertia=AB_INERTIA_A[k],
                         cg_to_front_axle=lf_a, **ACCORD)
        b = _participant(cid, 2, mass=AB_MASS_B[k], yaw_inertia=AB_INERTIA_B[k],
                         cg_to_front_axle=lf_b, **ACCORD)
        parts += [a, b]
        # Global frame of the paper (section 3): X along A's velocity, Y along B's.
        # B's CG at the origin at first contact, heading +Y; its left side faces -X.
        side_x = -0.5 * ACCORD["width"]
        y_a = lf_b - AB_L_AB[k]  # A's symmetry plane L_AB behind B's front axle
        x_a = side_x - (float(a["front_overhang"]) + lf_a)  # A's bumper touches B's side
        v_a, v_b = AB_SPEED_A[k], AB_SPEED_A[k] * AB_SPEED_B_FACTOR[k]
        pa, pb = _pose(x_a, y_a, 0.0, v_a), _pose(0.0, 0.0, math.pi / 2, v_b)
        trajs += [_trajectory(cid, 1, x_a, y_a, 0.0, v_a),
                  _trajectory(cid, 2, 0.0, 0.0, math.pi / 2, v_b)]
        measured = {f"measured_{name}": 1e3 * values[k]
                    for name, values in AB_ENERGY_KJ.items()}
        e0, e1 = AB_ENERGY_KJ["kinetic_energy_contact"][k], AB_ENERGY_KJ[
            "kinetic_energy_separation"][k]
        translational = 0.5 * (AB_MASS_A[k] * v_a**2 + AB_MASS_B[k] * v_b**2) / 1e3
        measured.update(
            # kinetic energy lost in the contact phase: E_kAB(0) - E_kAB(t_k) (Table 2);
            # it includes the wheels' rotation energy, which a rigid-body model lacks: its
            # share at contact (E_kAB(0) minus the translational energy of Table 1) is the sd
            energy_loss=1e3 * (e0 - e1), energy_loss_sd=1e3 * (e0 - translational),
            measured_separation_time=AB_SEPARATION_TIME[k],
            paper_speed_a_eq29_all=AB_SPEED_A_EQ29_ALL[k],
            paper_speed_a_eq29_deformation=AB_SPEED_A_EQ29_ED[k],
        )
        recs.append(_reconstruction(cid, pa, pb, (side_x, y_a), math.pi / 2, measured))
        cases.append({"case_id": cid, "accident_type": 321, "road_friction": AB_ROAD_FRICTION,
                      "road_surface": "dry", "road_curvature": 0.0, "collision": True,
                      "description": f"AB{cid}: Honda Accord front into the left side of a "
                      "Honda Accord at a right angle (energy-balance paper)"})

    cid = 4  # --- Ford Mondeo (1) / Opel Vectra (2) ---------------------------------
    ford = _participant(cid, 1, mass=MV_MASS[0], length=MV_LENGTH[0], width=MV_WIDTH[0],
                        wheelbase=MV_WHEELBASE[0], track_width=MV_TRACK[0],
                        cg_to_front_axle=MV_CG_TO_FRONT[0], cg_height=MV_CG_HEIGHT[0])
    opel = _participant(cid, 2, mass=MV_MASS[1], length=MV_LENGTH[1], width=MV_WIDTH[1],
                        wheelbase=MV_WHEELBASE[1], track_width=MV_TRACK[1],
                        cg_to_front_axle=MV_CG_TO_FRONT[1], cg_height=MV_CG_HEIGHT[1])
    parts += [ford, opel]
    side_x = -0.5 * MV_WIDTH[1]
    x_f = side_x - (float(ford["front_overhang"]) + MV_CG_TO_FRONT[0])
    v_f, v_o = (s / KMH_PER_MS for s in MV_SPEED_KMH)
    trajs += [_trajectory(cid, 1, x_f, 0.0, 0.0, v_f),
              _trajectory(cid, 2, 0.0, 0.0, math.pi / 2, v_o)]
    recs.append(_reconstruction(
        cid, _pose(x_f, 0.0, 0.0, v_f), _pose(0.0, 0.0, math.pi / 2, v_o), (side_x, 0.0),
        math.pi / 2,
        {"paper_ees2_crash3": MV_EES2_KMH / KMH_PER_MS,
         "paper_ees2_crash3_sd": MV_EES2_SD_KMH / KMH_PER_MS,
         "paper_speed2_alternative": MV_SPEED_KMH_ALTERNATIVE[1] / KMH_PER_MS}))
    cases.append({"case_id": cid, "accident_type": 321, "road_friction": MV_ROAD_FRICTION,
                  "road_surface": "dry", "road_curvature": 0.0, "collision": True,
                  "description": "Ford Mondeo (1) and Opel Vectra (2), orthogonal "
                  "velocities (collision-uncertainty paper); impact geometry assumed"})

    cid = 5  # --- Mercedes C300 into a rigid barrier -------------------------------
    car = _participant(cid, 1, cg_to_front_axle=C300_CG_TO_FRONT, **C300)
    wall = _participant(cid, 2, vehicle_class="barrier", fixed_object=True, **BARRIER)
    parts += [car, wall]
    v_c = C300_SPEED_KMH / KMH_PER_MS
    x_c = -(float(car["front_overhang"]) + C300_CG_TO_FRONT)  # bumper at x = 0
    x_w = 0.5 * BARRIER["length"]  # the wall's face at x = 0 (its rear faces the car)
    trajs += [_trajectory(cid, 1, x_c, 0.0, 0.0, v_c),
              _trajectory(cid, 2, x_w, 0.0, 0.0, 0.0)]
    recs.append(_reconstruction(
        cid, _pose(x_c, 0.0, 0.0, v_c), _pose(x_w, 0.0, 0.0, 0.0), (0.0, 0.0), math.pi / 2,
        {"paper_restitution": C300_RESTITUTION,
         "paper_front_wheel_lock_time": C300_WHEEL_LOCK_TIME}))
    cases.append({"case_id": cid, "accident_type": 799, "road_friction": C300_ROAD_FRICTION,
                  "road_surface": "dry", "road_curvature": 0.0, "collision": True,
                  "description": "NHTSA Mercedes C300 4Matic, full-overlap rigid barrier at "
                  "56.3 km/h (head-on identification paper); participant 2 is the barrier"})

    frames = {"cases": pd.DataFrame(cases), "participants": pd.DataFrame(parts),
              "trajectories": pd.concat(trajs, ignore_index=True),
              "reconstruction": pd.DataFrame(recs)}
    tables = {name: normalise_table(frames.get(name, empty_table(name)), name)
              for name in TABLE_NAMES}
    meta = default_meta(
        name="crash-tests", created_by="vfs.scenarios.crash_tests",
        description="Five instrumented crash tests from the papers (energy-balance paper "
        "AB1-AB3, collision-uncertainty paper Mondeo/Vectra, head-on identification paper "
        "C300 barrier); outcomes measured where the papers' text gives them; README.md "
        "lists every source and assumption")
    meta["columns"] = {"reconstruction": EXTRA_COLUMNS}
    return Database(**tables, meta=meta)


def main(argv: list[str] | None = None) -> int:
    """Write the database to the folder given as the only argument."""
    from vfs.database.io import save_database

    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0] if args else os.path.join("scenarios", "databases", "crash-tests"))
    save_database(build_crash_test_database(), folder)
    print(f"wrote {folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
