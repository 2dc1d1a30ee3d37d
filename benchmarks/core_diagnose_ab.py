"""The quick diagnosis (``vfs bench diagnose --quick`` settings) on 60 generated cases, in one
process, alternating the compiled core and the numpy reference (``VFS_COMPILED``): CPU time
of each run, so that both see the same load (issue 37; docs/performance.md).

    python benchmarks/core_diagnose_ab.py > benchmarks/results/core_37_diagnose_ab.txt
"""

from __future__ import annotations

import os
import time

from vfs.bench.study import run_diagnose
from vfs.scenarios.generator import generate_database


def main() -> None:
    """Print one line per run: VFS_COMPILED, CPU seconds, 1-minute load average."""
    db, _ = generate_database("default", n_cases=60, seed=11)
    print("VFS_COMPILED cpu_s load_average_1min")
    for flag in ("1", "0", "1", "0"):
        os.environ["VFS_COMPILED"] = flag
        c0 = time.process_time()
        run_diagnose(db, True)
        print(flag, round(time.process_time() - c0, 2), round(os.getloadavg()[0], 1),
              flush=True)


if __name__ == "__main__":
    main()
