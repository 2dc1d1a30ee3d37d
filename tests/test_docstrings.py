"""Docstrings of vfs: cross-references to vfs names resolve (Sphinx roles and ``See Also``).

A rename that leaves a docstring pointing at a name that no longer exists (a
``write_report`` after the function became ``write_diagnosis_report``) fails here.
"""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: ``:func:`vfs.x.y``` and friends with a fully qualified vfs target (a leading ``~`` or a
#: trailing ``()`` is allowed, as Sphinx allows them).
ROLE = re.compile(r":(?:func|class|meth|data|attr|mod|obj|exc):`~?(vfs(?:\.\w+)+)(?:\(\))?`")


def resolves(dotted: str) -> bool:
    """Whether ``dotted`` names a module or an attribute path below one."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            if not hasattr(obj, name):
                # a dataclass / NamedTuple field documented on the class
                fields = getattr(obj, "__dataclass_fields__", None) or getattr(obj, "_fields", ())
                if name not in fields and name not in getattr(obj, "__annotations__", {}):
                    return False
                return True
            obj = getattr(obj, name)
        return True
    return False


def docstrings(source: str, clean: bool = False) -> list[str]:
    """The docstrings of the module, classes and functions of ``source``."""
    return [ast.get_docstring(node, clean=clean) or "" for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef
                          | ast.AsyncFunctionDef)]


def broken_references(source: str) -> list[str]:
    """Fully qualified vfs cross-references in the docstrings of ``source`` that do not resolve."""
    return [m.group(1) for doc in docstrings(source) for m in ROLE.finditer(doc)
            if not resolves(m.group(1))]


def test_the_check_catches_a_reference_to_a_missing_name() -> None:
    source = '"""See :func:`vfs.diagnosis.diagnose.write_report` and :class:`vfs.no_such`."""\n'
    assert broken_references(source) == ["vfs.diagnosis.diagnose.write_report", "vfs.no_such"]
    good = '"""See :func:`vfs.report.diagnose.write_diagnosis_report`."""\n'
    assert broken_references(good) == []


@pytest.mark.parametrize("path", sorted(str(p.relative_to(ROOT))
                                        for p in (ROOT / "vfs").rglob("*.py")))
def test_cross_references_resolve(path: str) -> None:
    assert broken_references((ROOT / path).read_text(encoding="utf-8")) == []


# ----------------------------------------------------------------------------
# Broken fragments: what a rename or a re-wrap leaves behind
# ----------------------------------------------------------------------------

#: A numpydoc parameter line (``name : type``, ``a, b : type``) or a line of parameter
#: names only (``n_boot, seed, confidence``): a new item, not a continuation of the prose.
PARAM_LINE = re.compile(r"^\*{0,2}[\w.]+(?:\s*,\s*\*{0,2}[\w.]+)*(?:\s*:(?:\s.*)?)?$")

#: Abbreviations whose period ends no sentence.
ABBREVIATIONS = frozenset({"e.g", "i.e", "cf", "vs", "al", "eq", "eqs", "fig", "figs", "approx",
                           "no", "ca", "resp", "incl", "ref", "sec", "ch", "et"})

#: Lowercase words a sentence may start with: names written lowercase by their owners, and
#: symbols of the formulas in the docstrings.
LOWERCASE_STARTS = frozenset({"vfs", "matplotlib", "numpy", "pandas", "scipy", "pyarrow",
                              "duckdb", "dask", "numba", "gymnasium", "dv", "eps", "mu"})

#: A sentence end followed by a lowercase word: ``<token>. <word>``.
SENTENCE_START = re.compile(r"(\S+)\.\s+([a-z][\w*/-]*)")


def _prose_paragraphs(doc: str) -> list[list[str]]:
    """Paragraphs of prose lines of a docstring: code (backticks, doctests), section rules,
    list items and parameter lines start new paragraphs.
    """
    paragraphs: list[list[str]] = [[]]
    lines = doc.splitlines()
    for k, raw in enumerate(lines):
        line = raw.strip()
        following = lines[k + 1] if k + 1 < len(lines) else ""
        indented_below = (len(following) - len(following.lstrip())
                          > len(raw) - len(raw.lstrip())) and bool(following.strip())
        param = PARAM_LINE.match(line) is not None and (
            ":" in line or "," in line or "_" in line or indented_below)
        starts_item = (not line or param
                       or line.startswith((">>>", "...", "*", "- ", "|", "=", "..", "["))
                       or set(line) <= set("-=~"))
        if starts_item:
            paragraphs.append([])
        if line and not line.startswith((">>>", "...")) and not set(line) <= set("-=~"):
            paragraphs[-1].append(raw)
    return [p for p in paragraphs if p]


def lowercase_sentence_starts(doc: str) -> list[str]:
    """``"<token>. <word>"`` where a sentence seems to start with a lowercase English word.

    Not counted: abbreviations (``e.g.``, ``i.e.``, ``vs.``, ...), enumerations (``1. the``),
    code in backticks, words with ``_``, ``/``, ``*`` or digits (identifiers, paths, units),
    one-letter symbols and :data:`LOWERCASE_STARTS`.
    """
    found = []
    text = re.sub(r"``.*?``|`[^`]*`", "CODE", doc, flags=re.S)
    for para in _prose_paragraphs(text):
        joined = " ".join(line.strip() for line in para)
        for m in SENTENCE_START.finditer(joined):
            token, word = m.group(1), m.group(2)
            bare = token.lstrip("([").lower()
            if (bare in ABBREVIATIONS or bare.rstrip(".") in ABBREVIATIONS
                    or re.fullmatch(r"\(?\d+\.?\d*\)?", token) or token.endswith(".")
                    or not word.isalpha() or len(word) == 1 or word in LOWERCASE_STARTS):
                continue
            found.append(f"{token}. {word}")
    return found


def stranded_lines(doc: str, short: int = 25, long: int = 40) -> list[str]:
    """Prose lines of at most ``short`` characters between two lines of at least ``long``
    at the same indentation: what a re-wrap after a rename leaves (``... the Momentum
    Based`` / ``Impact Model paper`` / ``(outlook): ...``).
    """
    found = []
    for para in _prose_paragraphs(doc):
        for prev, cur, nxt in zip(para, para[1:], para[2:], strict=False):
            indents = {len(s) - len(s.lstrip()) for s in (prev, cur, nxt)}
            text = cur.strip()
            if (len(indents) == 1 and len(text) <= short and len(prev.strip()) >= long
                    and len(nxt.strip()) >= long and not text.endswith((".", ":"))
                    and not text.startswith("``")):
                found.append(text)
    return found


def broken_fragments(source: str) -> list[str]:
    """Lowercase sentence starts and stranded lines in the docstrings of ``source``."""
    return [bad for doc in docstrings(source, clean=True)
            for bad in lowercase_sentence_starts(doc) + stranded_lines(doc)]


def test_the_fragment_check_catches_broken_docstrings() -> None:
    broken = ('"""Run-out.\n\n'
              'Whether a vehicle was rolling or sliding matters; the Collision Calculation\n'
              'Uncertainty paper: the rest. positions are the criterion a simulation is judged\n'
              'by (its Marquard run-out is the energy-only alternative); the Head-On paper\n'
              'shows\n'
              'that frontal deformation can lock wheels, hence a brake factor per wheel.\n"""\n')
    assert broken_fragments(broken) == ["rest. positions", "shows"]
    fine = ('"""Run-out (e.g. a slide; i.e. no rolling) at 0.5 m/s.  vfs stores CG positions.\n\n'
            'Steps:\n\n1. the pose moved; 2. the plane turned.  See ``run_out. x``.\n\n'
            'Parameters\n----------\nn_boot, seed, confidence\n    Bootstrap settings.\n'
            'params : RunoutParams\n    Default :class:`RunoutParams`.  k = 1 is a 2 x 2 table.\n'
            '"""\n')
    assert broken_fragments(fine) == []


@pytest.mark.parametrize("path", sorted(str(p.relative_to(ROOT))
                                        for p in (ROOT / "vfs").rglob("*.py")))
def test_no_broken_fragments(path: str) -> None:
    assert broken_fragments((ROOT / path).read_text(encoding="utf-8")) == []
