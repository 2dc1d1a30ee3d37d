"""Closed loop of the post-impact steer angle's reconstruction (issue 36, item 4).

Clean generated cases whose run-outs were steered by a known law (the run-out steer channel
``runout_steer``, 0.3 rad towards each car's impact side; brakes 0.8, the generator's),
reconstructed by :func:`vfs.uncertainty.reconstruct.reconstruct` from the rest positions and
headings with a flat prior over [-0.6, 0.6] rad per car, in two settings:

* ``known``: every other input fixed at the database's value, the speeds within 1 %;
* ``default``: the default uncertainties (speeds, friction, restitution, POI, plane,
  masses), the brakes known.

Writes ``reconstruct_steer.json`` and ``reconstruct_steer.md`` (per case and car: truth,
optimum, feasible range, 5-95 % band) to ``--out``; CPU times by ``time.process_time``.

Usage::

    PYTHONPATH=. python benchmarks/reconstruct_steer.py --out benchmarks/results/reconstruct_steer
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from pathlib import Path

import numpy as np

from vfs.effects.learned import impact_sides, law_effect_class
from vfs.scenarios.generator import generate_database
from vfs.uncertainty import CaseSet, Distribution
from vfs.uncertainty.config import INPUT_NAMES, default_config
from vfs.uncertainty.reconstruct import ObservationSettings, ReconstructSettings, reconstruct

FAST = ReconstructSettings(n_prior=3000, n_starts=4, n_local=1500, n_chains=120, n_steps=40,
                           burn_in=20, thin=4)
FLAT = Distribution("uniform", "absolute", low=-0.6, high=0.6)
OBS = ObservationSettings(rest_position_sd=0.2, rest_yaw_sd=math.radians(3))


def main() -> None:
    """Run both settings and write the records."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="reconstruct_steer_out")
    ap.add_argument("--cases", type=int, default=8)
    a = ap.parse_args()
    law = law_effect_class({"name": "truth_steer", "channel": "runout_steer",
                            "feature": "closing_speed", "form": "constant",
                            "coefficients": [0.3]})()
    db, _ = generate_database("clean", n_cases=a.cases + 2, seed=6, hidden=(law,))
    cases = CaseSet.from_database(db)
    truth = 0.3 * impact_sides(cases.config)
    brake = Distribution("fixed", "absolute", value=0.8)
    known = Distribution("fixed", "offset")
    near = Distribution("uniform", "factor", low=0.99, high=1.01)
    settings = {
        "known": (default_config().with_inputs(
            **{n: known for n in INPUT_NAMES if n not in ("steer1", "steer2", "wheel_brake1",
                                                           "wheel_brake2")},
            wheel_brake1=brake, wheel_brake2=brake, steer1=FLAT, steer2=FLAT),
            dataclasses.replace(FAST, speed1=near, speed2=near)),
        "default": (default_config().with_inputs(steer1=FLAT, steer2=FLAT, wheel_brake1=brake,
                                                 wheel_brake2=brake), FAST),
    }
    rows = []
    for name, (cfg, st) in settings.items():
        for j in range(a.cases):
            t0 = time.process_time()
            rec = reconstruct(cases, cases.case_id[j], config=cfg, observation=OBS,
                              settings=st, seed=j)
            cpu = time.process_time() - t0
            band = rec.band.set_index("quantity")
            for i in (1, 2):
                r = band.loc[f"steer{i}"]
                rows.append({"setting": name, "case": str(cases.case_id[j]), "vehicle": i,
                             "truth": float(truth[j, i - 1]),
                             "optimum": float(rec.optimum.inputs[f"steer{i}"]),
                             "min": float(r["min"]), "max": float(r["max"]),
                             "p5": float(r["p5"]), "p95": float(r["p95"]),
                             "n_feasible": int(rec.stats["n_feasible"]), "cpu_s": cpu})
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for name in settings:
        rs = [r for r in rows if r["setting"] == name]
        err = np.array([abs(r["optimum"] - r["truth"]) for r in rs])
        summary[name] = {
            "pairs": len(rs),
            "range_covers": int(sum(r["min"] <= r["truth"] <= r["max"] for r in rs)),
            "band_5_95_covers": int(sum(r["p5"] <= r["truth"] <= r["p95"] for r in rs)),
            "median_abs_error_rad": float(np.median(err)),
            "max_abs_error_rad": float(err.max()),
            "median_band_width_rad": float(np.median([r["p95"] - r["p5"] for r in rs])),
            "cpu_s_per_case": float(np.mean([r["cpu_s"] for r in rs[::2]])),
        }
    (out / "reconstruct_steer.json").write_text(json.dumps({"rows": rows, "summary": summary},
                                                           indent=1))
    lines = ["| setting | case | vehicle | truth [rad] | optimum [rad] | feasible range [rad] "
             "| 5-95 % band [rad] |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['setting']} | {r['case']} | {r['vehicle']} | {r['truth']:.3f} | "
              f"{r['optimum']:.3f} | {r['min']:.3f} - {r['max']:.3f} | "
              f"{r['p5']:.3f} - {r['p95']:.3f} |" for r in rows]
    lines.append("")
    for name, s in summary.items():
        lines.append(f"- {name}: feasible range holds the truth in {s['range_covers']} of "
                     f"{s['pairs']} (case, car) pairs, the 5-95 % band in "
                     f"{s['band_5_95_covers']}; median |optimum - truth| "
                     f"{s['median_abs_error_rad']:.3f} rad (max {s['max_abs_error_rad']:.3f}); "
                     f"median band width {s['median_band_width_rad']:.2f} rad; "
                     f"{s['cpu_s_per_case']:.1f} s CPU per case")
    (out / "reconstruct_steer.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
