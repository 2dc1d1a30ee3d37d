"""Write ``results/reference/euro-ncap-side-by-side/``: the record docs/euro-ncap.md quotes.

Runs, with the current code, the built-in systems on both Euro NCAP matrices (2026, the
default ``--db euro-ncap-c2c``, and 2023, ``--db euro-ncap-c2c-2023``) and on the bundled
accident database, then ``vfs report side-by-side`` for each version, and keeps the small
text outputs: ``side_by_side_<version>.csv`` / ``.md`` (the side-by-side tables) and
``.png`` (test score against accident benefit),
``scores_<version>.csv`` (points per scenario and system), ``tests_<version>.csv`` (the
result sheet: measure, colour, points per test and system), ``report.md`` (the 2026 study's
effectiveness report with its Euro NCAP section and result sheets; figures left out, their
captions kept), ``per_type.csv`` (share of the accident study's baseline crashes avoided per
accident type), ``printed.txt`` (the commands and what they printed, times and paths left
out, as results/README.md asks) and ``timing.txt`` (each command's wall time: the study
workers are not children this script can time for CPU).  Nothing there is edited by hand::

    python benchmarks/euro_ncap_side_by_side.py [WORK_FOLDER]   # a few minutes on 2 cores
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "reference" / "euro-ncap-side-by-side"
SYSTEMS = "three-stage,ideal,openpass-like,ideal-ctra"
VERSIONS = {"2026": "euro-ncap-c2c", "2023": "euro-ncap-c2c-2023"}
#: Accident types of the per-type table (vfs.accident_types): rear-end, left turn across
#: the oncoming path, straight crossing, head-on variants.
TYPES = (601, 211, 321, 241, 242, 243, 264)


def _run(args: list[str], work: Path, log: list[str], times: list[str]) -> None:
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "vfs", *args], cwd=ROOT, check=True,
                          capture_output=True, text=True)
    wall = time.perf_counter() - started
    command = "$ vfs " + " ".join(args).replace(f"{work}/", "results/")
    log.append(command)
    log += [ln for ln in done.stdout.splitlines()
            if str(work) not in ln and " s (" not in ln and "->" not in ln]
    times.append(f"{command}\n  wall time {wall:.1f} s"
                 + "".join(f"\n  {ln.strip()}" for ln in done.stdout.splitlines()
                           if "simulated in" in ln))


def per_type(study: Path) -> pd.DataFrame:
    """Share of the baseline crashes avoided per system and accident type."""
    runs = pd.read_parquet(study / "runs.parquet")
    runs = runs[runs["error"].fillna("").astype(str) == ""]
    base = runs[runs["system"] == "baseline"].set_index("case_id")
    crashed = base.index[base["collided"].fillna(False).astype(bool)]
    rows = []
    for system, own in runs[runs["system"] != "baseline"].groupby("system", sort=False):
        own = own.set_index("case_id").loc[crashed]
        row: dict[str, object] = {"system": system}
        for kind in TYPES:
            mine = own[own["accident_type"] == kind]
            row[f"n_{kind}"] = len(mine)
            row[f"avoided_{kind}"] = (float((~mine["collided"].astype(bool)).mean())
                                      if len(mine) else float("nan"))
        rows.append(row)
    return pd.DataFrame(rows)


def main(argv: list[str]) -> int:
    """Run the studies into ``argv[0]`` (default a temporary folder) and write the record."""
    work = Path(argv[0]) if argv else Path(tempfile.mkdtemp(prefix="ncap-sbs-"))
    work.mkdir(parents=True, exist_ok=True)
    OUT.mkdir(parents=True, exist_ok=True)
    log: list[str] = []
    times: list[str] = ["# wall times on the shared 2-core development machine, other jobs "
                        "running (load not controlled)"]
    accidents = work / "study-default"
    _run(["study", "--db", "default", "--systems", SYSTEMS, "--out", str(accidents),
          "--overwrite"], work, log, times)
    per_type(accidents).to_csv(OUT / "per_type.csv", index=False, float_format="%.4f")
    for version, db in VERSIONS.items():
        study = work / f"study-{db}"
        _run(["study", "--db", db, "--systems", SYSTEMS, "--out", str(study), "--overwrite"],
             work, log, times)
        _run(["report", "effectiveness", str(study), "--no-case-pages"], work, log, times)
        sbs = work / f"sbs-{version}"
        _run(["report", "side-by-side", "--ncap", str(study), "--accidents", str(accidents),
              "--out", str(sbs)], work, log, times)
        shutil.copy(sbs / "side_by_side.csv", OUT / f"side_by_side_{version}.csv")
        shutil.copy(sbs / "side_by_side.md", OUT / f"side_by_side_{version}.md")
        shutil.copy(sbs / "side_by_side.png", OUT / f"side_by_side_{version}.png")
        if version == "2026":  # the figure of docs/euro-ncap.md
            shutil.copy(sbs / "side_by_side.png", ROOT / "docs" / "figures"
                        / "euro_ncap_side_by_side.png")
        shutil.copy(study / "report" / "euro_ncap_scores.csv", OUT / f"scores_{version}.csv")
        shutil.copy(study / "report" / "euro_ncap_tests.csv", OUT / f"tests_{version}.csv")
        if version == "2026":
            text = (study / "report" / "report.md").read_text(encoding="utf-8")
            text = text.replace(str(study), "results/study-euro-ncap-c2c")
            text = text.replace(f"file://{ROOT}/", "../../../").replace(f"{ROOT}/", "")
            text = re.sub(r"!\[([^\]]*)\]\([^)]*\)", r"(figure: \1)", text)
            (OUT / "report.md").write_text(text, encoding="utf-8")
    (OUT / "printed.txt").write_text("\n".join(log) + "\n", encoding="utf-8")
    (OUT / "timing.txt").write_text("\n".join(times) + "\n", encoding="utf-8")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
