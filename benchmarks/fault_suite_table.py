"""The tables of a fault-suite record (``benchmarks/fault_suite.py``'s ``.jsonl``), as Markdown.

Inputs x outcome (CLEAR / OK / WARN / SILENT / TRACEBACK / HANG), faults x outcome,
and every fault with its moment, exit code, manifest status and resume; for a
record whose run was stopped early too (it holds the runs that ended).

    python benchmarks/fault_suite_table.py benchmarks/results/fault_suite.jsonl
"""

from __future__ import annotations

import json
import sys
from collections import Counter
from pathlib import Path

INPUT_OUTCOMES = ("CLEAR", "OK", "WARN", "SILENT", "TRACEBACK", "HANG")
FAULT_OUTCOMES = ("CLEAN", "TRACEBACK", "HANG", "ORPHAN", "NO-RESUME-HINT", "RESUME-FAILED")


def tables(records: list[dict]) -> str:
    """The Markdown tables of ``records``."""
    inputs = [r for r in records if r["kind"] == "input"]
    faults = [r for r in records if r["kind"] == "fault"]
    out = ["## Bad inputs x outcome", "",
           "| input | expected | " + " | ".join(INPUT_OUTCOMES) + " | exit | first line |",
           "|---|---|" + "---|" * len(INPUT_OUTCOMES) + "---|---|"]
    for r in inputs:
        first = next((line for line in r["stderr"].splitlines()
                      if "error" in line or "warning" in line), "")
        marks = ["1" if r["outcome"] == o else "" for o in INPUT_OUTCOMES]
        out.append(f"| {r['name']} | {r['expect']} | " + " | ".join(marks)
                   + f" | {r['code']} | {first[:110].replace('|', '/')} |")
    total = Counter(r["outcome"] for r in inputs)
    out.append("| **total** | | " + " | ".join(str(total.get(o, 0)) for o in INPUT_OUTCOMES)
               + " | | |")
    wrong = [r["name"] for r in inputs if r["outcome"] != r["expect"]]
    out += ["", f"{len(inputs)} runs; outcome other than expected: {wrong or 'none'}.", "",
            "## Faults x outcome", "",
            "| fault | runs | " + " | ".join(FAULT_OUTCOMES) + " | exit codes | resumed |",
            "|---|---|" + "---|" * len(FAULT_OUTCOMES) + "---|---|"]
    for fault in sorted({r["fault"] for r in faults}):
        rows = [r for r in faults if r["fault"] == fault]
        c = Counter(r["outcome"] for r in rows)
        codes = Counter(str(r["code"]) for r in rows)
        resumed = Counter(r["resumed"] if r["resumed"] in ("complete", "not run") else "failed"
                          for r in rows)
        out.append(f"| {fault} | {len(rows)} | " + " | ".join(str(c.get(o, 0))
                                                             for o in FAULT_OUTCOMES)
                   + f" | {dict(sorted(codes.items()))} | {dict(sorted(resumed.items()))} |")
    c = Counter(r["outcome"] for r in faults)
    out.append(f"| **total** | {len(faults)} | " + " | ".join(str(c.get(o, 0))
                                                            for o in FAULT_OUTCOMES) + " | | |")
    out += ["", f"Orphan processes (alive 5 s after the study ended, same process group): "
            f"{sum(len(r['orphans']) for r in faults)}; tracebacks: "
            f"{sum(bool(r['traceback']) for r in faults)}; hangs: "
            f"{sum(r['code'] is None for r in faults)}.", "",
            "| # | fault | at s (after start-up) | exit | manifest | resume | outcome |",
            "|---|---|---|---|---|---|---|"]
    for k, r in enumerate(faults, 1):
        out.append(f"| {k} | {r['fault']} | {r['at_s']:.2f} | {r['code']} | "
                   f"{r['status'] or '(none)'} | {r['resumed'][:50]} | {r['outcome']} |")
    return "\n".join(out) + "\n"


def main() -> int:
    """Print the tables of the record named on the command line."""
    path = Path(sys.argv[1] if len(sys.argv) > 1 else "benchmarks/results/fault_suite.jsonl")
    records = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    print(tables(records), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
