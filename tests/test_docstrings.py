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


def broken_references(source: str) -> list[str]:
    """Fully qualified vfs cross-references in the docstrings of ``source`` that do not resolve."""
    bad = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            doc = ast.get_docstring(node, clean=False) or ""
            bad += [m.group(1) for m in ROLE.finditer(doc) if not resolves(m.group(1))]
    return bad


def test_the_check_catches_a_reference_to_a_missing_name() -> None:
    source = '"""See :func:`vfs.analysis.diagnose.write_report` and :class:`vfs.no_such`."""\n'
    assert broken_references(source) == ["vfs.analysis.diagnose.write_report", "vfs.no_such"]
    good = '"""See :func:`vfs.report.diagnose.write_diagnosis_report`."""\n'
    assert broken_references(good) == []


@pytest.mark.parametrize("path", sorted(str(p.relative_to(ROOT))
                                        for p in (ROOT / "vfs").rglob("*.py")))
def test_cross_references_resolve(path: str) -> None:
    assert broken_references((ROOT / path).read_text(encoding="utf-8")) == []
