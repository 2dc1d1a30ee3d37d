"""Page faults of ``vfs study`` and glibc's allocator thresholds (issue 37, fixed costs): CPU
(user, system) and minor page faults of the benchmark's study in a fresh interpreter, with the
default allocator and with ``MALLOC_MMAP_THRESHOLD_`` / ``MALLOC_TRIM_THRESHOLD_`` raised, in
interleaved pairs.  Usage: ``python benchmarks/core_37_startup_malloc.py DB OUT.json [PAIRS]``
(from the repository root; DB: a generated database, ``vfs.bench.study.generated_database``).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The raised thresholds [B]: freed blocks up to these sizes stay in the heap for reuse.
RAISED = {"MALLOC_MMAP_THRESHOLD_": str(256 * 2**20), "MALLOC_TRIM_THRESHOLD_": str(2**30)}


def run(db: str, extra: dict[str, str]) -> dict[str, float]:
    """User and system CPU [s] and minor page faults of one study."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), **extra)
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-m", "vfs", "study", "--db", db, "--systems",
                        "three-stage,ideal", "--engine", "serial", "--out", f"{tmp}/s", "-q"],
                       cwd=ROOT, env=env, check=True, capture_output=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"user_s": after.ru_utime - before.ru_utime, "sys_s": after.ru_stime - before.ru_stime,
            "minor_faults": after.ru_minflt - before.ru_minflt}


def main() -> None:
    """Run the pairs and write the record."""
    db, out = sys.argv[1], sys.argv[2]
    pairs = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    rows = []
    for _ in range(pairs):
        rows.append({"default": run(db, {}), "raised": run(db, RAISED),
                     "load_average_1min": os.getloadavg()[0]})
    Path(out).write_text(json.dumps({"raised": RAISED, "pairs": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
