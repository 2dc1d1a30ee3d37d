"""Source papers are cited by title, never by their storage name ("seed 00N").

Legitimate uses of "seed" stay allowed: ``--seed 0`` flags and RNG seeds such as "seeds 0-4".
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from vfs.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
#: A paper's storage name: "seed 001", "Seed 004's", "seeds 001/004", "seed 00".
FORBIDDEN = re.compile(r"seeds? 0\d\d|seeds? 00", re.IGNORECASE)


def _help_texts() -> dict[str, str]:
    """``vfs <cmd> --help`` of every (sub)command, rendered in-process."""
    texts: dict[str, str] = {}

    def walk(parser: argparse.ArgumentParser, name: str) -> None:
        texts[name] = parser.format_help()
        for action in parser._actions:  # noqa: SLF001 - argparse has no public walk
            if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
                for sub_name, sub in action.choices.items():
                    walk(sub, f"{name} {sub_name}")

    walk(build_parser(), "vfs")
    return texts


def test_forbidden_pattern_matches_paper_names_only() -> None:
    """The pattern hits storage names and spares RNG seeds (so the other tests can fail)."""
    for bad in ("seed 001", "Seed 004's", "seeds 001/004", "SEED 002"):
        assert FORBIDDEN.search(bad), bad
    for ok in ("--seed 0", "seeds 0-4", "seed 0 to 4", "--seed 0 --cases 10"):
        assert not FORBIDDEN.search(ok), ok


def test_cli_help_cites_papers_by_title() -> None:
    texts = _help_texts()
    assert len(texts) > 5
    hits = {name: FORBIDDEN.findall(t) for name, t in texts.items() if FORBIDDEN.search(t)}
    assert not hits, hits


@pytest.mark.parametrize("pattern", ["vfs/**/*.py", "vfs/**/*.toml", "docs/**/*.md", "README.md",
                                     "examples/**/*.py"])
def test_sources_and_docs_cite_papers_by_title(pattern: str) -> None:
    files = sorted(ROOT.glob(pattern))
    assert files
    hits = []
    for f in files:
        for no, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            if FORBIDDEN.search(line):
                hits.append(f"{f.relative_to(ROOT)}:{no}: {line.strip()}")
    assert not hits, "\n".join(hits)


def test_no_pointer_to_files_outside_the_repository() -> None:
    """Reports and docs link docs/references.md, not the shared REFERENCES.md."""
    hits = [str(f.relative_to(ROOT)) for pat in ("vfs/**/*.py", "docs/**/*.md", "README.md")
            for f in ROOT.glob(pat) if "REFERENCES.md" in f.read_text(encoding="utf-8")]
    assert not hits, hits
    assert (ROOT / "docs" / "references.md").is_file()
