"""Rewrite ``results/reference/``: the small reference outputs the READMEs quote.

Runs the commands of the README's quick start (and the comparison) on the bundled database
with the current code, into a temporary folder, and keeps the small, text-form outputs in
``results/reference/<job>/`` (tables as CSV, the report's Markdown, the printed summary).
Nothing there is edited by hand: run this after a change that moves the numbers and commit
the difference with the change (the figures are left out; their captions stay)::

    python benchmarks/update_reference.py            # all jobs (a few minutes on 2 cores)
    python benchmarks/update_reference.py study      # one job
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "results" / "reference"

#: job -> (the command's arguments after ``vfs``, with {out} for its output folder; the files
#: of the output folder to keep).  Later commands of a job run on the same folder.
JOBS: dict[str, tuple[list[list[str]], list[str]]] = {
    "study-default": (
        [["study", "--db", "default", "--systems", "three-stage,ideal", "--out", "{out}",
          "--overwrite"],
         ["report", "effectiveness", "{out}", "--no-case-pages"]],
        ["report/report.md"],
    ),
    "compare-default": (
        [["compare", "--db", "default", "--out", "{out}", "--no-case-pages", "--sketches", "0"]],
        ["report.md", "table1.csv", "contingency.csv"],
    ),
}


def run_job(name: str, scratch: Path) -> list[Path]:
    """Run one job in ``scratch`` and copy its kept files into ``results/reference/<name>``."""
    commands, keep = JOBS[name]
    out = scratch / name
    target = REFERENCE / name
    printed = []
    for command in commands:
        args = [a.replace("{out}", str(out)) for a in command]
        done = subprocess.run([sys.executable, "-m", "vfs", *args], cwd=scratch,
                              capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise SystemExit(f"vfs {' '.join(args)} failed:\n{done.stderr[-3000:]}")
        # the printed summary without the machine-dependent lines (times, paths)
        printed += [f"$ vfs {' '.join(command)}".replace("{out}", f"results/{name}")]
        printed += [ln for ln in done.stdout.splitlines()
                    if str(scratch) not in ln and " s (" not in ln and "->" not in ln]
    if target.exists():
        shutil.rmtree(target)
    target.mkdir(parents=True)
    written = []
    for rel in keep:
        dest = target / Path(rel).name
        text = (out / rel).read_text(encoding="utf-8").replace(str(out), f"results/{name}")
        # paths of this checkout become repository-relative (links from the kept file)
        text = text.replace(f"file://{ROOT}/", "../../../").replace(f"{ROOT}/", "")
        if dest.suffix == ".md":  # the figures stay behind: keep their captions as text
            text = re.sub(r"!\[([^\]]*)\]\([^)]*\)", r"(figure: \1)", text)
        dest.write_text(text, encoding="utf-8")
        written.append(dest)
    summary = target / "printed.txt"
    summary.write_text("\n".join(printed) + "\n", encoding="utf-8")
    return [*written, summary]


def main(argv: list[str] | None = None) -> int:
    """Run the jobs named on the command line (default all)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("jobs", nargs="*", metavar="JOB",
                        help=f"jobs to run (default all: {', '.join(JOBS)})")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.jobs) - set(JOBS))
    if unknown:
        parser.error(f"unknown jobs {unknown}; known: {', '.join(JOBS)}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.jobs or list(JOBS):
            for path in run_job(name, Path(tmp)):
                print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
