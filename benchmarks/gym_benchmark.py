r"""The gym benchmark: policies on the test split plus generated passes, with their score.

Evaluates, as one study (``vfs.gym.evaluate.evaluate_policy``), on the test split of the
bundled database (crashes and near misses) together with
``vfs.gym.benchmark.PASSING_CASES`` generated passes without a conflict
(``vfs.gym.benchmark.with_passes``, seed ``PASSING_SEED``):

- the reference PPO policy (``--reference``, trained by ``examples/train_ppo.py``),
- a quick PPO (``--quick``: the recipe stopped after 18 CPU seconds, which brakes early),
- the built-in AEB systems ``three-stage``, ``openpass-like`` and ``ideal``,
- ``never-brake`` and ``always-brake``.

It writes the record ``benchmarks/results/gym-benchmark.md`` and ``.json``: the leaderboard
(avoided crashes, unnecessary braking, comfort, score; ``vfs.gym.benchmark``), how each
PPO policy was trained (command, seed, steps, CPU time, from its ``model.vfs.json``) and the
CPU time of the evaluation.  docs/gym.md quotes it (tests/test_docs_figures.py).

Usage::

    nice -n 10 python benchmarks/gym_benchmark.py --reference results/ppo-ref/model \\
        --quick results/ppo-quick/model
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vfs.database import open_database  # noqa: E402
from vfs.gym.benchmark import (  # noqa: E402
    PASSING_CASES,
    PASSING_SEED,
    score_formula,
    with_passes,
)
from vfs.gym.env import split_case_ids  # noqa: E402
from vfs.gym.evaluate import evaluate_policy, leaderboard, leaderboard_markdown  # noqa: E402
from vfs.gym.policies import SB3_SETTINGS_SUFFIX, load_policy  # noqa: E402

BUILT_INS = ("aeb:three-stage", "aeb:openpass-like", "aeb:ideal", "never-brake",
             "always-brake")


def _sb3(path: str, name: str) -> tuple[object, dict]:
    policy = load_policy(f"sb3:{path}")
    policy.name = name  # type: ignore[attr-defined]
    settings = json.loads(Path(path + SB3_SETTINGS_SUFFIX).read_text())
    return policy, {"name": name, "model": path, **settings}


def main() -> None:
    """Evaluate the policies and write the record."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", required=True, help="the reference model (PATH of PATH.zip)")
    ap.add_argument("--quick", required=True, help="the quick PPO model (PATH of PATH.zip)")
    ap.add_argument("--out", default="results/gym-benchmark", help="evaluation folder")
    ap.add_argument("--record", default=str(ROOT / "benchmarks" / "results" / "gym-benchmark"),
                    help="record path without suffix (.md and .json are written)")
    args = ap.parse_args()

    started = time.process_time()
    base = open_database("default")
    test = base.subset(split_case_ids(base.case_ids, "test"))
    db = with_passes(test)
    ref, ref_info = _sb3(args.reference, "ppo-reference")
    quick, quick_info = _sb3(args.quick, "ppo-quick")
    evaluate_policy([ref, quick, *BUILT_INS], db, args.out, split="all", engine="serial",
                    overwrite=True)
    table = leaderboard(args.out)
    cpu = time.process_time() - started
    board = leaderboard_markdown(table)
    n_crash = int(table["near_misses"].iloc[0])
    lines = [
        "# Gym benchmark (benchmarks/gym_benchmark.py)",
        "",
        f"Cases: the test split of the bundled database ({test.n_cases} cases) and "
        f"{PASSING_CASES} generated passes without a conflict (preset `passing`, seed "
        f"{PASSING_SEED}); {n_crash} cases without a crash in the baseline. Policies on "
        "vehicle 1; intervals 95 % (Wilson for the share avoided, bootstrap for the others).",
        "",
        board,
        "## Training of the PPO policies",
        "",
        "| policy | command | seed | steps | CPU time [s] | wall time [s] | cases |",
        "|---|---|---|---|---|---|---|",
    ]
    for info in (ref_info, quick_info):
        t = info["trained"]
        lines.append(f"| {info['name']} | `{t.get('command', 'examples/train_ppo.py')}` | "
                     f"{t['seed']} | {t['steps']:,} | {t['cpu_seconds']:.1f} | "
                     f"{t['wall_seconds']:.1f} | {t['cases']} |")
    lines += ["", f"Evaluation: {cpu:.0f} CPU s (`time.process_time`) on "
              f"{platform.machine()} with {os.cpu_count()} cores shared with other jobs.", ""]
    Path(args.record + ".md").write_text("\n".join(lines), encoding="utf-8")
    record = {"score": score_formula(), "cases": int(db.n_cases),
              "no_crash_cases": n_crash, "evaluation_cpu_seconds": round(cpu, 1),
              "policies": json.loads(table.to_json(orient="records")),
              "training": [ref_info, quick_info]}
    Path(args.record + ".json").write_text(json.dumps(record, indent=1) + "\n",
                                           encoding="utf-8")
    print(board)


if __name__ == "__main__":
    main()
