"""Each built-in effect hidden alone: the library effect's reduction against the learned laws'.

Generates a 300-case database (seed 21, default noise) per built-in effect, runs
``vfs.diagnosis.diagnose.diagnose`` with every library candidate and every channel
identified (``laws="all"``), and prints one JSON line per effect: the hidden effect's rank
and CV reduction, every learned law with its status (claimed / not confirmed / not
significant) and outcome CV reduction, the verdict and the CPU time [s].  The table of
docs/diagnosis.md, "Beyond the library", comes from it.

Usage::

    PYTHONPATH=. python benchmarks/diagnose_builtin_effects.py [EFFECT,EFFECT,...]
"""

from __future__ import annotations

import json
import sys
import time

from vfs.diagnosis.diagnose import diagnose
from vfs.effects.library import BUILTIN_EFFECTS
from vfs.scenarios.generator import generate_database


def main() -> None:
    """Run the comparison for the effects named on the command line (default all)."""
    names = sys.argv[1].split(",") if len(sys.argv) > 1 else list(BUILTIN_EFFECTS)
    for name in names:
        db, _ = generate_database("default", n_cases=300, seed=21, hidden=(name,))
        t0 = time.process_time()
        diag = diagnose(db, folds=3, grid_points=5, zoom_rounds=2, n_boot=500, worst=0,
                        laws="all")
        cpu = time.process_time() - t0
        c = next(c for c in diag.candidates if c.name == name)
        print(json.dumps({
            "hidden": name, "rank": diag.ranking.index(name) + 1,
            "library": [c.overall.estimate, c.overall.low, c.overall.high, bool(c.significant)],
            "laws": [{"channel": f.channel, "feature": f.learned.law["feature"],
                      "formula": f.learned.law["formula"], "status": f.status,
                      "outcome": [f.outcome.estimate, f.outcome.low, f.outcome.high]}
                     for f in diag.laws],
            "verdict": diag.verdict, "cpu_s": round(cpu, 1)}), flush=True)


if __name__ == "__main__":
    main()
