"""The rule "no output worse than the default model" where the diagnosis has no channel for the
hidden run-out mechanism (issue 36): the battery's ``brake_both_severity`` database (a brake
law of crash severity on both cars; seed and size of the battery's run-out part), diagnosed
with the eleven channels of the last round only (no ``runout_brake``, no ``corner_brake``).
Prints the verdict and writes it, with the rejected candidates and their reasons, as JSON.

Usage::

    PYTHONPATH=. python benchmarks/runout_mimic_check.py --out FILE [--cases 240]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from battery_laws import hidden_effect, law_by_name  # noqa: E402
from diagnosis_battery import diagnose_options  # noqa: E402

#: The channels of the last round (before the run-out channels of issue 36).
OLD_CHANNELS = ("restitution", "contact_friction", "poi_along", "poi_across", "cp_angle",
                "penetration_time", "ees_stiffness_ratio", "yaw_inertia_factor",
                "tyre_impulse", "runout_brake1", "runout_brake2")


def main() -> None:
    """Run the check (module docstring)."""
    from vfs.diagnosis.diagnose import diagnose, summary_dict
    from vfs.scenarios.generator import generate_database

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", type=int, default=240)
    ap.add_argument("--law", default="brake_both_severity")
    ap.add_argument("--seed", type=int, default=600)
    a = ap.parse_args()
    db, _ = generate_database("default", n_cases=a.cases, seed=a.seed,
                              hidden=[hidden_effect(law_by_name(a.law))])
    opts = {**diagnose_options(True), "laws": ",".join(OLD_CHANNELS)}
    t0, c0 = time.perf_counter(), time.process_time()
    s = summary_dict(diagnose(db, **opts))
    rec = {"law": a.law, "seed": a.seed, "cases": s["n_cases"], "channels": OLD_CHANNELS,
           "verdict": s["verdict"], "claims": [c["name"] for c in s["claims"]],
           "rejected": s["rejected"], "steps": s["steps"],
           "wall_s": round(time.perf_counter() - t0, 1),
           "cpu_s": round(time.process_time() - c0, 1)}
    Path(a.out).write_text(json.dumps(rec, indent=1, default=float))
    print("\n".join(s["verdict"]))


if __name__ == "__main__":
    main()
