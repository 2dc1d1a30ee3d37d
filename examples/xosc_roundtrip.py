"""Export every case of a database to OpenSCENARIO/OpenDRIVE, validate, import back, compare.

The measurement behind the figures of docs/interop.md:

    python examples/xosc_roundtrip.py --db default --out results/xosc_roundtrip
    python examples/xosc_roundtrip.py --db default --out results/xosc_roundtrip --aeb 100

Prints a JSON summary: export and validation time, schema errors, road modes per accident
type, fit errors, the round trip's largest position / heading / speed differences, and the
re-simulation of the imported database against the original.  With ``--aeb N`` it also runs a
study of the first N cases with ``three-stage`` and exports every treated motion
(study replay checks).  Needs the extra: pip install -e ".[xosc]".
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from vfs.database import open_database
from vfs.interop import export_case, import_xosc, schema_errors, study_motion
from vfs.interop.opendrive import road_curvature_at
from vfs.simulation import CaseBatch, results_table, simulate_cases
from vfs.study import run_study


def roundtrip(db_name: str, out: Path) -> dict:
    db = open_database(db_name)
    cases = db.cases.set_index("case_id")
    rows, files = [], []
    start = time.perf_counter()
    for cid in db.case_ids:
        t = time.perf_counter()
        r = export_case(db, cid, out / "files")
        files.append(r.xosc)
        end = db.trajectory(cid, 1).iloc[-1]
        curvature = road_curvature_at(r.roads.roads, float(end["x"]), float(end["y"]))
        rows.append({"case_id": cid, "accident_type": int(cases.loc[cid, "accident_type"]),
                     "curvature_error": abs(curvature / cases.loc[cid, "road_curvature"] - 1)
                     if cases.loc[cid, "road_curvature"] != 0 else np.nan,
                     "mode": r.roads.mode,
                     "roads": len(r.roads.roads), "fit_error_m": r.roads.fit_error,
                     "geometries": len(r.roads.roads[0].reference.segments),
                     "export_s": time.perf_counter() - t})
    export_s = time.perf_counter() - start
    start = time.perf_counter()
    invalid = [str(f) for x in files for f in (x, x.with_suffix(".xodr")) if schema_errors(f)]
    validate_s = time.perf_counter() - start
    back = import_xosc(files)
    dpos = dyaw = dspeed = 0.0
    for cid in db.case_ids:
        for p in (1, 2):
            a, b = db.trajectory(cid, p), back.trajectory(cid, p)
            dpos = max(dpos, float(np.max(np.hypot(a.x - b.x, a.y - b.y))))
            dyaw = max(dyaw, float(np.max(np.abs(a.yaw - b.yaw))))
            dspeed = max(dspeed, float(np.max(np.abs(a.speed - b.speed))))
    batch_a = CaseBatch.from_database(db, impact_parameters="default")
    batch_b = CaseBatch.from_database(back, impact_parameters="default")
    ra = results_table(batch_a, simulate_cases(batch_a))
    rb = results_table(batch_b, simulate_cases(batch_b))
    both = (ra.collided & rb.collided).to_numpy(bool)
    dv_imp = np.abs(ra.impact_speed1 - rb.impact_speed1).to_numpy()[both]
    dv = np.abs(ra.delta_v1 - rb.delta_v1).to_numpy()[both]
    table = pd.DataFrame(rows)
    path = table[table["mode"] == "path"]
    return {
        "cases": len(files), "export_s": export_s, "validate_s": validate_s,
        "schema_errors": invalid,
        "roads": {f"{a} {m} {n}": int(k) for (a, m, n), k in
                  table.groupby(["accident_type", "mode", "roads"]).size().items()},
        "fit_error_m": path["fit_error_m"].describe().to_dict(),
        "curvature_error_at_collision": path["curvature_error"].describe().to_dict(),
        "geometries_path": path["geometries"].describe().to_dict(),
        "max_position_difference_m": dpos, "max_heading_difference_rad": dyaw,
        "max_speed_difference_m_s": dspeed,
        "same_collision": int((ra.collided == rb.collided).sum()),
        "impact_speed1_difference_m_s": [float(np.median(dv_imp)), float(dv_imp.max())],
        "delta_v1_difference_m_s": [float(np.median(dv)), float(dv.max())],
    }


def aeb(db_name: str, out: Path, n: int) -> dict:
    db = open_database(db_name)
    study = out / "study"
    run_study(db_name, "three-stage", study, engine="serial", where=f"case_id <= {n}",
              overwrite=True, progress=False)
    matches = valid = 0
    for cid in db.case_ids[db.case_ids <= n]:
        motion = study_motion(study, db_name, cid, "three-stage")
        result = export_case(db, cid, out / "aeb", motion=motion)
        matches += "matches" in motion.notes[-1]
        valid += not schema_errors(result.xosc)
    return {"aeb_cases": int((db.case_ids <= n).sum()), "replay_matches": matches,
            "aeb_files_valid": valid}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default="default")
    parser.add_argument("--out", type=Path, default=Path("results/xosc_roundtrip"))
    parser.add_argument("--aeb", type=int, default=0, metavar="N",
                        help="also export the three-stage motion of the first N cases")
    args = parser.parse_args()
    summary = roundtrip(args.db, args.out)
    if args.aeb:
        summary.update(aeb(args.db, args.out, args.aeb))
    print(json.dumps(summary, indent=1, default=str))


if __name__ == "__main__":
    main()
