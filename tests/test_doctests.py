"""The examples in the docstrings run (numpydoc ``Examples`` sections as doctests)."""

from __future__ import annotations

import doctest
import importlib
import importlib.util
import pkgutil

import pytest

import vfs


def _modules_with_examples() -> list[str]:
    names = []
    for info in pkgutil.walk_packages(vfs.__path__, prefix="vfs."):
        if info.name.endswith("__main__"):
            continue
        spec = importlib.util.find_spec(info.name)
        if spec is None or spec.origin is None or not spec.origin.endswith(".py"):
            continue
        with open(spec.origin, encoding="utf-8") as fh:
            if ">>> " in fh.read():
                names.append(info.name)
    return names


MODULES = _modules_with_examples()


def test_examples_are_found():
    # the walk itself can fail silently (a renamed package): these modules have examples
    assert {"vfs.report.render", "vfs.analysis.stats", "vfs.registry"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
