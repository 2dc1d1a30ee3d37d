"""Compare two output folders of a vfs command file by file (bit-identical check).

Parquet files are compared as tables (``DataFrame.equals``: values, dtypes, order), the
other tables and records byte for byte; the lines of Markdown reports and JSON records
that differ are printed, so that provenance (commit, paths, times) can be told from results.

Usage::

    python benchmarks/compare_output_folders.py BEFORE AFTER [BEFORE AFTER ...]
"""

from __future__ import annotations

import difflib
import filecmp
import sys
from pathlib import Path

import pandas as pd

SUFFIXES = (".parquet", ".csv", ".json", ".jsonl", ".md")


def compare(before: Path, after: Path) -> list[str]:
    """Lines saying which files of ``before`` differ in ``after`` (and how, for text)."""
    out = []
    files = [f for f in sorted(before.rglob("*")) if f.is_file() and f.suffix in SUFFIXES]
    same = 0
    for f in files:
        g = after / f.relative_to(before)
        if not g.exists():
            out.append(f"  missing: {f.relative_to(before)}")
        elif f.suffix == ".parquet":
            if pd.read_parquet(f).equals(pd.read_parquet(g)):
                same += 1
            else:
                out.append(f"  differs (table): {f.relative_to(before)}")
        elif filecmp.cmp(f, g, shallow=False):
            same += 1
        else:
            a = f.read_text(encoding="utf-8").splitlines()
            b = g.read_text(encoding="utf-8").splitlines()
            lines = [x for x in difflib.unified_diff(a, b, lineterm="", n=0)
                     if x[:1] in "+-" and not x.startswith(("+++", "---"))]
            out.append(f"  differs in {len(lines)} line(s): {f.relative_to(before)}")
            out += [f"    {x[:160]}" for x in lines]
    return [f"{before} vs {after}: {len(files)} files, {same} identical", *out]


def main(argv: list[str]) -> int:
    """Print the comparison of each pair of folders."""
    if len(argv) % 2 or not argv:
        print(__doc__)
        return 2
    for before, after in zip(argv[::2], argv[1::2], strict=True):
        print("\n".join(compare(Path(before), Path(after))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
