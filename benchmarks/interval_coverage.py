"""Coverage of the per-case identification intervals of ``vfs identify``.

For each channel a database is generated with the channel hidden at a constant
value (so the true value of every case is known), the channel is identified
per case, and the share of identifiable cases whose interval holds the truth is
counted, for

* ``before``: the identification as it was (one parabolic step after the
  grid, the recorded output scales: ``POLISH_ROUNDS = 0``, ``noise="recorded"``);
* ``after``: the identification as it is (the default): bracket-halving rounds
  around the minimum, the estimated noise scale of each output, and the profile
  interval chi^2 <= min + k^2 with the channel's consistency factor k (cross-fitted
  over the features; until 67fc7c5 one feature's odd-numbered differences, and
  the chi^2 + 1 interval widened k times).

A one-sigma interval should cover 68.3 %; the binomial standard error of a
share p of k cases is sqrt(p (1 - p) / k).  Replicate batteries: ``--seed 131``,
``231``, ... (each channel gets ``seed + its index``; docs/diagnosis.md,
"Interval coverage", has five).  Prints a markdown table (also
written to OUT/coverage.md) and one JSON line per channel to OUT/coverage.jsonl.

Usage::

    PYTHONPATH=. python benchmarks/interval_coverage.py [--cases 120] [--out coverage_out]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from vfs.diagnosis import identify as ident
from vfs.diagnosis.calibrate import CalibrationData
from vfs.effects.learned import law_effect_class
from vfs.scenarios.generator import generate_database

#: Channel -> constant hidden value (inside the range, off the model's value).
VALUES = {"restitution": 0.15, "contact_friction": 0.3, "poi_along": 0.3, "poi_across": 0.1,
          "cp_angle": 0.15, "penetration_time": 0.05, "ees_stiffness_ratio": 2.0,
          "yaw_inertia_factor": 0.7, "tyre_impulse": 1.0, "runout_brake1": 0.4,
          "runout_brake2": 0.55}


def coverage(channel: str, value: float, cases: int, seed: int, before: bool
             ) -> tuple[int, int]:
    """(covered, identifiable) for one channel hidden at ``value``."""
    cls = law_effect_class({"name": "hidden_constant", "channel": channel,
                            "feature": "closing_speed", "form": "constant",
                            "coefficients": [value]})
    db, _ = generate_database("default", n_cases=cases, seed=seed, hidden=(cls(),))
    data = CalibrationData.from_database(db)
    rounds = ident.POLISH_ROUNDS
    try:
        if before:
            ident.POLISH_ROUNDS = 0
        t = ident.identify(data, [channel], grid_points=21,
                           noise="recorded" if before else "estimated")
    finally:
        ident.POLISH_ROUNDS = rounds
    ok = t[t["identifiable"]]
    return int(((ok["low"] <= value) & (value <= ok["high"])).sum()), len(ok)


def main() -> None:
    """Measure and print the coverage table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=120)
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--channels", default=",".join(VALUES))
    ap.add_argument("--out", default="coverage_out")
    ap.add_argument("--modes", default="before,after", help="before, after or both")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = ["| channel | hidden value | identifiable | coverage before | coverage after |",
            "|---|---|---|---|---|"]
    tot = {"before": [0, 0], "after": [0, 0]}
    for i, ch in enumerate(a.channels.split(",")):
        rec: dict[str, object] = {"channel": ch, "value": VALUES[ch], "cases": a.cases}
        for mode in ("before", "after"):
            if mode not in a.modes.split(","):
                rec[mode] = [0, 0]
                continue
            t0 = time.perf_counter()
            c, k = coverage(ch, VALUES[ch], a.cases, a.seed + i, mode == "before")
            rec[mode] = [c, k]
            rec[f"{mode}_s"] = round(time.perf_counter() - t0, 1)
            tot[mode][0] += c
            tot[mode][1] += k
        with (out / "coverage.jsonl").open("a") as f:
            f.write(json.dumps(rec) + "\n")
        cb, kb = rec["before"]  # type: ignore[misc]
        ca, ka = rec["after"]  # type: ignore[misc]
        rows.append(f"| {ch} | {VALUES[ch]:g} | {ka} | {100 * cb / max(kb, 1):.0f} % "
                    f"| {100 * ca / max(ka, 1):.0f} % |")
        print(rows[-1], flush=True)
    for mode in ("before", "after"):
        c, k = tot[mode]
        se = math.sqrt(0.683 * 0.317 / max(k, 1))
        rows.append(f"| all ({mode}) | | {k} | {100 * c / max(k, 1):.1f} % | "
                    f"(nominal 68.3 % +- {100 * se:.1f} %) |")
    text = "\n".join(rows) + "\n"
    (out / "coverage.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
