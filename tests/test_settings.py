"""vfs.settings: declarations, checks derived from them, and the rule that no bound,
choice or default of a setting stands in two places in the package."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import math
from enum import StrEnum
from pathlib import Path

import pytest

from vfs.errors import SettingsError
from vfs.settings import NO_DEFAULT, Rule, cli_kwargs, declared, markdown_table, setting, validate

PACKAGE = Path(__file__).resolve().parents[1] / "vfs"


class Mode(StrEnum):
    FAST = "fast"
    SLOW = "slow"


@dataclasses.dataclass(frozen=True)
class Example:
    """A parameter class declared with :func:`setting`."""

    length: float = setting(2.0, "length", "how long", lo=0.0, lo_open=True, hi=10.0)
    speed: float = setting(10.0, "speed", "how fast", lo=0.0, hi=50.0)
    mode: str = setting("fast", "text", "which way", choices=Mode)
    limit: float | None = setting(None, "time", "a limit", lo=0.0, optional=True,
                                  optional_doc="no limit")
    RULES = (Rule(("length", "speed"), lambda e: e.length < e.speed, "length < speed"),)

    def __post_init__(self) -> None:
        validate(self)


def test_every_bad_setting_is_reported_at_once_with_its_range() -> None:
    with pytest.raises(SettingsError) as info:
        Example(length=0.0, speed=math.nan, mode="medium", limit=-1.0)
    lines = str(info.value).splitlines()
    assert lines == ["Example.length: 0.0 is out of range (allowed: (0, 10] m)",
                     "Example.speed: nan is out of range (allowed: [0, 50] m/s)",
                     "Example.mode: 'medium' is not allowed (allowed: one of 'fast', 'slow')",
                     "Example.limit: -1.0 is out of range (allowed: [0, inf] s, or absent)"]


def test_a_rule_is_checked_only_when_its_settings_are_valid_alone() -> None:
    with pytest.raises(SettingsError, match="length < speed"):
        Example(length=5.0, speed=4.0)
    with pytest.raises(SettingsError) as info:
        Example(length=50.0, speed=4.0)  # length out of range: the rule is not asked
    assert [p.name for p in info.value.problems] == ["length"]


@pytest.mark.parametrize("value", [True, "2", None, float("inf")])
def test_wrong_types_and_infinities_are_refused(value: object) -> None:
    with pytest.raises(SettingsError):
        Example(length=value)  # type: ignore[arg-type]


def test_declarations_carry_the_dataclass_defaults() -> None:
    got = declared(Example)
    assert [s.default for s in got.values()] == [2.0, 10.0, "fast", None]
    assert got["mode"].choice_values() == ("fast", "slow")
    assert Example() == Example(2.0, 10.0, "fast", None)


def test_the_cli_and_the_docs_are_derived() -> None:
    kwargs = cli_kwargs(declared(Example)["mode"])
    assert kwargs == {"help": "which way (default fast)", "choices": ("fast", "slow"),
                      "default": "fast"}
    table = markdown_table(Example)
    assert "| `speed_kmh` or `speed_mps` | [0, 180] km/h / [0, 50] m/s | 36 km/h / 10 m/s |" \
        in table
    assert "| `limit_s` | [0, inf] s, or absent | absent | a limit; absent: no limit |" in table
    assert cli_kwargs(dataclasses.replace(declared(Example)["length"], default=NO_DEFAULT)) \
        == {"help": "how long"}


# ----------------------------------------------------------------------------
# No bound, choice or default of a setting stands in two places
# ----------------------------------------------------------------------------

#: Values too common to say anything when they recur (0, 1, the infinities, booleans).
_TRIVIAL = {0.0, 1.0, -1.0}


def _modules() -> dict[str, ast.Module]:
    return {str(p.relative_to(PACKAGE.parent)): ast.parse(p.read_text(encoding="utf-8"))
            for p in PACKAGE.rglob("*.py")}


def _declaring_classes(trees: dict[str, ast.Module]) -> list[type]:
    out = []
    for path, tree in trees.items():
        module = path[:-3].replace("/", ".").removesuffix(".__init__")
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef) and any(
                    isinstance(c, ast.Call) and getattr(c.func, "id", "") == "setting"
                    for c in ast.walk(node)):
                out.append(getattr(importlib.import_module(module), node.name))
    return out


def _enums(trees: dict[str, ast.Module]) -> dict[str, set[str]]:
    """Every StrEnum of the package: ``module.Class`` -> its values."""
    out = {}
    for path, tree in trees.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef) and any(getattr(b, "id", "") == "StrEnum"
                                                      for b in node.bases):
                values = {s.value.value for s in node.body
                          if isinstance(s, ast.Assign) and isinstance(s.value, ast.Constant)}
                out[f"{path}:{node.name}"] = values
    return out


def _simple_statements(tree: ast.Module) -> list[tuple[ast.AST, list[ast.AST]]]:
    """Each simple statement (and each test/iter of a compound one) with its class chain."""
    out: list[tuple[ast.AST, list[ast.AST]]] = []

    def visit(node: ast.AST, parents: list[ast.AST]) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                visit(child, [*parents, child])
            elif isinstance(child, ast.If | ast.While):
                out.append((child.test, parents))
                visit(child, parents)
            elif isinstance(child, ast.For | ast.With | ast.Try):
                visit(child, parents)
            elif isinstance(child, ast.stmt):
                out.append((child, parents))

    visit(tree, [])
    return out


def _names_and_numbers(node: ast.AST) -> tuple[set[str], set[float]]:
    names, numbers = set(), set()
    for n in ast.walk(node):  # a bare local name (dt) is not the setting: attributes,
        if isinstance(n, ast.Attribute):  # keywords and strings (field names) are
            names.add(n.attr)
        elif isinstance(n, ast.keyword) and n.arg:
            names.add(n.arg)
        elif isinstance(n, ast.Constant) and isinstance(n.value, str):
            names.add(n.value)
        elif isinstance(n, ast.Constant) and isinstance(n.value, int | float) \
                and not isinstance(n.value, bool):
            numbers.add(float(n.value))
    return names, numbers


def test_no_bound_or_default_of_a_setting_stands_in_two_places() -> None:
    trees = _modules()
    classes = _declaring_classes(trees)
    assert len(classes) >= 4  # sensor, AEB, driver, brake actuator, ...
    statements = []  # (where, enclosing class names, names, numbers) of every statement
    for path, tree in trees.items():
        for stmt, parents in _simple_statements(tree):
            names, numbers = _names_and_numbers(stmt)
            if numbers - _TRIVIAL:
                owners = {p.name for p in parents if isinstance(p, ast.ClassDef)}
                statements.append((f"{path}:{stmt.lineno}", owners, names, numbers))
    found = []
    for cls in classes:
        for name, s in declared(cls).items():
            values = {v for v in (s.lo, s.hi) if math.isfinite(v)}
            if isinstance(s.default, int | float) and not isinstance(s.default, bool):
                values.add(float(s.default))
            values -= _TRIVIAL
            for where, owners, names, numbers in statements:
                if cls.__name__ not in owners and name in names and numbers & values:
                    found.append(f"{where}: {cls.__name__}.{name} {sorted(numbers & values)}")
    assert not found, "bounds/defaults written again:\n" + "\n".join(found)


#: Known copies in the diagnosis modules (vfs/diagnosis, outside this change):
#: file name and the choices; remove an entry when its copy is gone.
_ELSEWHERE = {("calibrate.py", frozenset({"primary", "all"})),
              ("diagnose.py", frozenset({"bh", "holm"}))}


def test_no_set_of_choices_stands_in_two_places() -> None:
    trees = _modules()
    enums = {k: v for k, v in _enums(trees).items() if len(v) >= 2}
    assert any(v == {"cv", "ctrv", "ca", "ctra"} for v in enums.values())
    assert any(v == {"1", "2", "both"} for v in enums.values())
    found = []
    for path, tree in trees.items():
        for node in ast.walk(tree):
            if not isinstance(node, ast.Tuple | ast.List | ast.Set):
                continue
            strings = {e.value for e in node.elts
                       if isinstance(e, ast.Constant) and isinstance(e.value, str)}
            for enum, values in enums.items():
                if strings == values and (Path(path).name, frozenset(values)) not in _ELSEWHERE:
                    found.append(f"{path}:{node.lineno}: {sorted(strings)} ({enum})")
    assert not found, "choices written again:\n" + "\n".join(found)


def test_no_cli_default_repeats_a_declared_default() -> None:
    trees = _modules()
    declared_defaults = {}
    for cls in _declaring_classes(trees):
        for name, s in declared(cls).items():
            if s.default is not NO_DEFAULT and s.default is not None:
                declared_defaults[name.replace("_", "-")] = s.default
    found = []
    for path, tree in trees.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
                options = [a.value.lstrip("-") for a in node.args
                           if isinstance(a, ast.Constant) and isinstance(a.value, str)]
                for kw in node.keywords:
                    if kw.arg == "default" and isinstance(kw.value, ast.Constant):
                        for option in options:
                            if option in declared_defaults \
                                    and declared_defaults[option] == kw.value.value:
                                found.append(f"{path}:{node.lineno}: --{option}")
    assert not found, "declared defaults written again in the CLI:\n" + "\n".join(found)
