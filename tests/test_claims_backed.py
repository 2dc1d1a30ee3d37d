"""Every claim of agreement in README, docs/*.md and the CLI help names what backs it.

The convention (docs/validation.md, "Claims and what backs them"):

* a *claim word* is one of match(es/ed), reproduce(s/d), agree(s/d), validate(s/d),
  confirm(s/ed) as a whole word;
* a paragraph (a block between blank lines, a list item or a table row) or a CLI help text
  that uses one must name its backing in the same block: a test, written
  ``tests/<file>.py`` or ``tests/<file>.py::<test>``, or a row of the claims table,
  written ``(claim C<n>)``;
* every named test file and test function must exist; every claims-table row must name a
  test that exists or a measurement whose script or command exists in the repository;
* not claims, so exempt: the word negated ("not", "no", "never", "n't" within the four
  words before it: a statement of disagreement needs no test), inside `code` or "quotes"
  (names, labels, messages), and the technical uses listed in :data:`NOT_CLAIMS`, each with
  its reason.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CLAIM_WORD = re.compile(
    r"\b(match(?:es|ed)?|reproduc(?:e|es|ed)|agree(?:s|d)?|validat(?:e|es|ed)|"
    r"confirm(?:s|ed)?)\b", re.I)
NEGATION = re.compile(r"\b(not|no|never|neither|nor|\w+n't)\b(\W+\w+){0,4}\W*$", re.I)
TEST_REF = re.compile(r"tests/([\w/]+\.py)(?:::(\w+))?")
CLAIM_REF = re.compile(r"\(claim (C\d+)\)")
#: Technical uses of a claim word that state no agreement with evidence (regex, reason).
NOT_CLAIMS: tuple[tuple[str, str], ...] = (
    (r"cross-validat\w*", "the name of a method (k-fold cross-validation)"),
    (r"\b(are|is|rows?) matched by\b", "how rows are joined (a key), not an agreement"),
    (r"\bvalidates? (the selected cases|blocks|a database|the files|them)\b",
     "a schema check the program performs, not a claim about it"),
    (r"\bvalidate, convert\b|\bvalidate\b.*\bschema", "the `vfs db validate` schema check"),
    (r"\bexported and validated\b", "schema validation of exported files (the count beside it "
     "is the measurement)"),
    (r"\bagree \(`b \+ c = 0`\)|\ball pairs agree\b", "a statistic's definition"),
    (r"\bwhen the two disagree\b", "a reading instruction"),
    (r"\b(that|best) reproduces? the reconstruction\b", "what `vfs identify` searches for (its "
     "definition), not a result"),
    (r"\bso CV and in-sample agree\b", "an identity: a model without parameters has nothing "
     "to fit per fold"),
    (r"\bconfirmed on top of\b|\bnot confirmed\b", "a status label of `vfs diagnose`"),
    (r"\bcould not be reproduced\b|\bwhich reproduces\b.*\bbatch\b",
     "what the report does when replaying, defined in the same paragraph"),
    (r"\bfixed seed reproduces\b", "determinism of a seeded computation, a definition"),
    (r"\breproduce the record exactly\b", "the defined behaviour of the replay controller"),
    (r"\breproduces the scene\b", "the definition of the feasible set"),
)


def _strip_code_and_quotes(text: str) -> str:
    text = re.sub(r"`[^`]*`", "``", text)
    return re.sub(r"\"[^\"\n]*\"", "\"\"", text)


def _blocks(text: str) -> list[tuple[int, str]]:
    """Paragraphs, list items and table rows of a Markdown text with their first line."""
    blocks, current, start, in_code = [], [], 0, False
    for i, line in enumerate(text.splitlines(), 1):
        if line.strip().startswith("```"):
            in_code = not in_code
            if current:
                blocks.append((start, " ".join(current)))
            current = []
            continue
        if in_code:
            continue
        new_item = re.match(r"^\s*([-*]|\d+\.)\s|^\s*\||^#", line)
        if not line.strip() or new_item:
            if current:
                blocks.append((start, " ".join(current)))
            current = []
        if line.strip():
            if not current:
                start = i
            current.append(line.strip())
            if line.startswith("#"):  # a heading is a block of its own
                blocks.append((start, " ".join(current)))
                current = []
    if current:
        blocks.append((start, " ".join(current)))
    return blocks


def _claims_without_backing(text: str) -> list[str]:
    """The claim words of a text block that are not exempt (empty: no claim)."""
    plain = _strip_code_and_quotes(text)
    for pattern, _ in NOT_CLAIMS:
        plain = re.sub(pattern, "", plain, flags=re.I)
    found = []
    for m in CLAIM_WORD.finditer(plain):
        if NEGATION.search(plain[:m.start()]):
            continue
        found.append(m.group(0))
    return found


def _documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _cli_texts() -> list[tuple[str, str]]:
    from vfs.cli import build_parser

    out: list[tuple[str, str]] = []

    def walk(parser: argparse.ArgumentParser, name: str) -> None:
        if parser.description:
            out.append((f"{name} (description)", parser.description))
        for action in parser._actions:  # argparse keeps its actions here only
            if isinstance(action, argparse._SubParsersAction):
                for choice in action._choices_actions:
                    out.append((f"{name} {choice.dest} (help)", choice.help or ""))
                for sub, subparser in action.choices.items():
                    walk(subparser, f"{name} {sub}")
            elif action.help and action.help != argparse.SUPPRESS:
                out.append((f"{name} {'/'.join(action.option_strings) or action.dest}",
                            action.help))

    walk(build_parser(), "vfs")
    return out


def _claims_table() -> dict[str, str]:
    text = (ROOT / "docs" / "validation.md").read_text(encoding="utf-8")
    return {m.group(1): m.group(3) for m in re.finditer(
        r"^\| (C\d+) \| ([^|]+) \| ([^|]+) \|$", text, re.M)}


def _test_exists(file: str, name: str | None) -> bool:
    path = ROOT / "tests" / file
    if not path.is_file():
        return False
    return name is None or re.search(rf"^def {name}\(", path.read_text(encoding="utf-8"),
                                     re.M) is not None


def _unbacked(where: str, text: str, table: dict[str, str]) -> list[str]:
    words = _claims_without_backing(text)
    if not words or re.match(r"^\| C\d+ \|", text):  # a claims-table row: checked apart
        return []
    refs = CLAIM_REF.findall(text)
    tests = TEST_REF.findall(text)
    problems = [f"{where}: unknown claims-table row {r}" for r in refs if r not in table]
    problems += [f"{where}: tests/{f}{'::' + n if n else ''} does not exist"
                 for f, n in tests if not _test_exists(f, n or None)]
    if not refs and not tests:
        problems.append(f"{where}: '{words[0]}' without a test or (claim Cn): "
                        f"{text[:140]}")
    return problems


def test_the_check_finds_an_unbacked_claim_and_accepts_backed_ones():
    table = _claims_table()
    assert _unbacked("x", "The model matches the paper.", table)
    assert not _unbacked("x", "The model does not match the paper.", table)
    assert not _unbacked("x", "The model matches the paper (claim C1).", table)
    assert not _unbacked(
        "x", "It agrees (tests/test_paper_values.py::test_marquard_table_on_the_bundled_"
        "database).".replace("_\n", "_"), table)
    assert _unbacked("x", "It agrees (tests/test_paper_values.py::no_such_test).", table)
    assert _unbacked("x", "It agrees (claim C999).", table)
    assert not _unbacked("x", "rows are matched by `case_id`", table)


def test_every_claims_table_row_names_an_existing_test_or_measurement():
    table = _claims_table()
    assert len(table) >= 5
    for cid, backing in table.items():
        tests = TEST_REF.findall(backing)
        for f, n in tests:
            assert _test_exists(f, n or None), f"{cid}: tests/{f}::{n}"
        scripts = re.findall(r"((?:examples|benchmarks|docs/figures)/[\w/]+\.py)", backing)
        for s in scripts:
            assert (ROOT / s).is_file(), f"{cid}: {s}"
        commands = re.findall(r"`vfs ([\w-]+)", backing)
        assert tests or scripts or commands, f"{cid} names neither a test nor a measurement"


@pytest.mark.parametrize("path", _documents(), ids=lambda p: p.name)
def test_every_claim_in_the_docs_is_backed(path):
    table = _claims_table()
    problems = []
    for line, block in _blocks(path.read_text(encoding="utf-8")):
        problems += _unbacked(f"{path.name}:{line}", block, table)
    assert not problems, "\n".join(problems)


def test_every_claim_in_the_cli_help_is_backed():
    table = _claims_table()
    problems = []
    for where, text in _cli_texts():
        problems += _unbacked(where, text, table)
    assert not problems, "\n".join(problems)
