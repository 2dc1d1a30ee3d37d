"""The corruption and fault suite at full size: every bad input, and random signals.

Runs each generated bad input of :mod:`tests.study.faultsuite` with the process
engine and with the serial engine (``vfs study``) or as ``vfs impact``, and then
``--kills`` studies of the first 60 bundled cases (process engine, 2 workers)
that receive SIGINT (to the process group, as Ctrl-C), SIGTERM (to the study
process or to the group) or SIGKILL (to the study process) at a random moment
between 0.3 s and the uninterrupted study's wall time, every second one followed
by ``--resume``.  Writes the tables (inputs x outcome, faults x outcome) to
``--out`` (Markdown) and every run to the ``.jsonl`` beside it.

    nice -n 10 python benchmarks/fault_suite.py --kills 50
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.study.faultsuite import (  # noqa: E402
    FAULTS,
    bad_inputs,
    fault_run,
    judge,
    run_cli,
    study_argv,
)

CASES = 60


def main() -> int:
    """Run the suite and write its tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=50)
    parser.add_argument("--seed", type=int, default=41)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/fault_suite.md")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    records: list[dict] = []
    args.out.parent.mkdir(parents=True, exist_ok=True)
    log = open(args.out.with_suffix(".jsonl"), "w")  # noqa: SIM115 - one line per run, as it ends
    lines = [f"# Corruption and fault suite (`python {Path(__file__).relative_to(ROOT)} "
             f"--kills {args.kills} --seed {args.seed}`)", "",
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.node()}, "
             f"Python {platform.python_version()}; wall times on a shared, loaded machine.",
             "", "## Bad inputs", "", "| input | expected | outcome | exit | wall s | "
             "first line |", "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        inputs = bad_inputs(root / "process", "process") + [
            b for b in bad_inputs(root / "serial", "serial") if b.argv[0] == "study"]
        for bad in inputs:
            run = run_cli(list(bad.argv), cwd=ROOT, limit_s=bad.limit_s)
            outcome = judge(bad, run)
            first = next((line for line in run.stderr.splitlines()
                          if "error" in line or "warning" in line), "")
            records.append({"kind": "input", "name": bad.name, "expect": bad.expect,
                            "outcome": outcome, "code": run.code, "wall_s": run.wall_s,
                            "stderr": run.stderr[-2000:]})
            log.write(json.dumps(records[-1]) + "\n")
            log.flush()
            lines.append(f"| {bad.name} | {bad.expect} | {outcome} | {run.code} | "
                         f"{run.wall_s:.1f} | {first[:140].replace('|', '/')} |")
            print(records[-1]["outcome"], bad.name, flush=True)
        counts = Counter(r["outcome"] for r in records)
        lines += ["", "Outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
                  ""]
        # the uninterrupted study: how long a fault's window is
        ref = run_cli(study_argv(root / "reference", CASES), cwd=ROOT, limit_s=600)
        window = max(1.0, ref.wall_s)
        lines += ["## Faults", "", f"Study: `vfs {' '.join(study_argv(Path('OUT'), CASES))}`; "
                  f"uninterrupted: exit {ref.code}, {ref.wall_s:.1f} s wall; each fault at a "
                  f"random moment in [0.3, {window:.1f}] s after its handlers are in place "
                  "(the process catches SIGTERM: its first line of vfs code ran), every "
                  "second one then `--resume`.", "",
                  "| # | fault | at s | exit | manifest | resume | orphans | outcome |",
                  "|---|---|---|---|---|---|---|---|"]
        names = list(FAULTS)
        for k in range(args.kills):
            fault = names[k % len(names)]
            at = float(rng.uniform(0.3, window))
            res = fault_run(fault, at, root / "fault", cwd=ROOT, cases=CASES,
                            resume=k % 2 == 0)
            records.append({"kind": "fault", "fault": fault, "at_s": at, "code": res.run.code,
                            "status": res.status, "resumed": res.resumed,
                            "orphans": list(res.run.orphans), "outcome": res.outcome,
                            "traceback": res.run.traceback,
                            "stderr": res.run.stderr[-2000:]})
            log.write(json.dumps(records[-1]) + "\n")
            log.flush()
            lines.append(f"| {k + 1} | {fault} | {at:.2f} | {res.run.code} | "
                         f"{res.status or '(none)'} | {res.resumed[:60]} | "
                         f"{len(res.run.orphans)} | {res.outcome} |")
            print(k + 1, fault, f"{at:.2f}", res.outcome, res.run.code, res.status,
                  res.resumed[:80], flush=True)
    faults = [r for r in records if r["kind"] == "fault"]
    table = Counter((r["fault"], r["outcome"]) for r in faults)
    lines += ["", "| fault | " + " | ".join(sorted({o for _, o in table})) + " |",
              "|---|" + "---|" * len({o for _, o in table})]
    for fault in names:
        lines.append(f"| {fault} | " + " | ".join(str(table.get((fault, o), 0))
                                                  for o in sorted({o for _, o in table}))
                     + " |")
    inputs_c = Counter(r["outcome"] for r in records if r["kind"] == "input")
    lines += ["", f"Totals: inputs {dict(sorted(inputs_c.items()))}; faults "
              f"{dict(sorted(Counter(r['outcome'] for r in faults).items()))}; orphan "
              f"processes {sum(len(r['orphans']) for r in faults)} in {len(faults)} faults; "
              f"tracebacks {sum(r['traceback'] for r in faults)}.", ""]
    log.close()
    args.out.write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
