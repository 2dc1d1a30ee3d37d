"""Census of a vfs source tree for issue 39 (one place for each setting).

Measures, from the syntax trees of ``ROOT/vfs`` (nothing is imported from that tree):

* the largest module (lines);
* the longest parameter lists (function, count of named parameters without
  ``self``/``cls``; ``*args``/``**kwargs`` count one each), of all functions and of the
  public ones (no leading underscore: the compiled kernels take their arrays one by one);
* for each bound of the AEB settings (the sensor, AEB, driver and brake-actuator
  parameters as the *current* checkout declares them, :mod:`vfs.settings`), the number of
  statements that write it: statements naming the setting (an attribute, a keyword or a
  string: the attribute name or one of its definition-file keys) together with the bound's
  number in one of the units a file may use.  Counted in the whole package, the declaration
  included, so 1 is the ideal (0: no such bound in that tree, or one the search misses);
* the same for the bounds and numeric defaults of the settings declared in the second part
  (pre-crash parameters, the study and diagnosis specs, the uncertainty model settings): an
  upper bound, since a statement of another setting of the same name and value counts too
  (``RunoutParams.dt``, the ``confidence`` of a bootstrap); tests/test_settings.py binds a
  number to its name (keyword, key, comparison) and finds no copy.

Usage::

    python benchmarks/settings_census.py ROOT [ROOT ...] [--json OUT]

e.g. a checkout of an older commit made with ``git archive <commit> vfs | tar -x -C DIR``.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vfs.adas.params import AEBParams, DriverParams, SensorParams  # noqa: E402
from vfs.diagnosis.diagnose_spec import DiagnoseSpec  # noqa: E402
from vfs.physics.braking import BrakeActuatorParams  # noqa: E402
from vfs.physics.precrash import PrecrashParams  # noqa: E402
from vfs.settings import declared  # noqa: E402
from vfs.study.spec import StudySpec  # noqa: E402
from vfs.uncertainty.config import UncertaintyConfig  # noqa: E402

AEB_CLASSES = (SensorParams, AEBParams, DriverParams, BrakeActuatorParams)
#: The settings declared in the second part of the issue (bounds and numeric defaults).
OTHER_CLASSES = (PrecrashParams, StudySpec, DiagnoseSpec, UncertaintyConfig)
#: Numbers too common to identify a bound.
TRIVIAL = {0.0, 1.0, -1.0}


def _trees(root: Path) -> dict[str, tuple[ast.Module, int]]:
    out = {}
    for p in sorted((root / "vfs").rglob("*.py")):
        text = p.read_text(encoding="utf-8")
        out[str(p.relative_to(root))] = (ast.parse(text), len(text.splitlines()))
    return out


def _statements(tree: ast.Module) -> list[ast.AST]:
    out: list[ast.AST] = []

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef
                          | ast.For | ast.With | ast.Try):
                visit(child)
            elif isinstance(child, ast.If | ast.While):
                out.append(child.test)
                visit(child)
            elif isinstance(child, ast.stmt):
                out.append(child)

    visit(tree)
    return out


def _evaluate(node: ast.AST, env: dict[str, Any]) -> Any:
    """The value of a constant expression (numbers, names of constants, math.pi,
    arithmetic, ``dict(...)``), else None.
    """
    try:
        return eval(compile(ast.Expression(node), "<census>", "eval"),  # noqa: S307
                    {"__builtins__": {"dict": dict}, "math": math}, dict(env))
    except Exception:
        return None


def _numbers(value: Any) -> set[float]:
    values = value.values() if isinstance(value, dict) else [value]
    return {round(float(v), 9) for v in values
            if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)}


def _constants(trees: dict[str, tuple[ast.Module, int]]) -> dict[str, tuple[Any, str]]:
    """Module-level constants of the package: name -> (value, where); two passes so
    that a constant may use one defined in another module.
    """
    out: dict[str, tuple[Any, str]] = {}
    for _ in range(2):
        env = {k: v for k, (v, _w) in out.items()}
        for path, (tree, _) in trees.items():
            for stmt in tree.body:
                target = stmt.targets[0] if isinstance(stmt, ast.Assign) and len(
                    stmt.targets) == 1 else getattr(stmt, "target", None)
                if isinstance(stmt, ast.Assign | ast.AnnAssign) and isinstance(
                        target, ast.Name) and stmt.value is not None:
                    value = _evaluate(stmt.value, env)
                    if _numbers(value):
                        out[target.id] = (value, f"{path}:{stmt.lineno}")
    return out


def _names_numbers(node: ast.AST, constants: dict[str, tuple[Any, str]], where: str
                   ) -> tuple[set[str], dict[float, set[str]]]:
    """Names in a statement, and each number it writes -> where it is written (here, or
    the definition of a constant it names).
    """
    names: set[str] = set()
    numbers: dict[float, set[str]] = {}
    env = {k: v for k, (v, _w) in constants.items()}
    for n in ast.walk(node):
        if isinstance(n, ast.Attribute):
            names.add(n.attr)
        elif isinstance(n, ast.keyword) and n.arg:
            names.add(n.arg)
        elif isinstance(n, ast.Name):
            names.add(n.id)
            if n.id in constants:
                for x in _numbers(constants[n.id][0]):
                    numbers.setdefault(x, set()).add(constants[n.id][1])
        elif isinstance(n, ast.Constant) and isinstance(n.value, str):
            if n.value.replace(".", "_").isidentifier():  # a key, not a sentence
                names.update(n.value.split("."))
        if isinstance(n, ast.Constant | ast.BinOp | ast.UnaryOp) and not isinstance(
                getattr(n, "value", None), str):
            for x in _numbers(_evaluate(n, env)):
                numbers.setdefault(x, set()).add(where)
    return names, numbers


def census(root: Path) -> dict[str, Any]:
    """The figures of the tree under ``root``."""
    trees = _trees(root)
    largest = max(trees.items(), key=lambda kv: kv[1][1])
    params = []
    for path, (tree, _) in trees.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                a = node.args
                named = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs
                         if x.arg not in ("self", "cls")]
                n = len(named) + (a.vararg is not None) + (a.kwarg is not None)
                params.append((n, f"{path}:{node.lineno} {node.name}"))
    params.sort(key=lambda t: (-t[0], t[1]))
    constants = _constants(trees)
    statements = [_names_numbers(s, constants, f"{path}:{s.lineno}")
                  for path, (tree, _) in trees.items() for s in _statements(tree)]
    return {"root": str(root), "modules": len(trees),
            "largest_module": {"path": largest[0], "lines": largest[1][1]},
            "longest_parameter_lists": [{"function": f, "parameters": n}
                                        for n, f in params[:3]],
            "longest_public_parameter_lists": [
                {"function": f, "parameters": n}
                for n, f in [p for p in params if not p[1].split()[-1].startswith("_")][:3]],
            **_places(statements, AEB_CLASSES, "aeb_bound", defaults=False),
            **_places(statements, OTHER_CLASSES, "other_setting", defaults=True)}


def _places(statements: list[tuple[set[str], dict[float, set[str]]]], classes: tuple[Any, ...],
            label: str, *, defaults: bool) -> dict[str, Any]:
    """Where each bound (and numeric default) of the settings of ``classes`` is written."""
    bounds = {}
    for cls in classes:
        for name, s in declared(cls).items():
            field = s.field()
            keys = {name, *field.keys()}
            values = [("lo", s.lo), ("hi", s.hi)]
            if defaults and isinstance(s.default, int | float) \
                    and not isinstance(s.default, bool):
                values.append(("default", float(s.default)))
            for label_, value in values:
                if not math.isfinite(value):
                    continue
                forms = {round(u.from_si(value), 9) for u in field.units()} - TRIVIAL
                if not forms:
                    continue
                places = sorted({w for names, numbers in statements if names & keys
                                 for x in forms & numbers.keys() for w in numbers[x]})
                bounds[f"{cls.__name__}.{name}.{label_}={value:g}"] = places
    return {f"{label}_places": {k: len(v) for k, v in bounds.items()},
            f"{label}_where": bounds}


def main(argv: list[str] | None = None) -> int:
    """Print the census of each root (and write them as JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("roots", nargs="+", type=Path)
    parser.add_argument("--label", action="append", default=[],
                        help="a name per root for the table (default the path)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    labels = args.label + [str(r) for r in args.roots[len(args.label):]]
    results = [census(r) | {"label": lab} for r, lab in zip(args.roots, labels, strict=True)]
    for r in results:
        print(f"== {r['label']}")
        print(f"largest module: {r['largest_module']['path']} "
              f"({r['largest_module']['lines']} lines)")
        for p in r["longest_parameter_lists"]:
            print(f"parameters: {p['parameters']:3d}  {p['function']}")
        for p in r["longest_public_parameter_lists"]:
            print(f"parameters (public): {p['parameters']:3d}  {p['function']}")
        for what, key in (("AEB bounds", "aeb_bound"),
                          ("other settings' bounds and defaults", "other_setting")):
            counts = r[f"{key}_places"]
            hist: dict[int, int] = {}
            for c in counts.values():
                hist[c] = hist.get(c, 0) + 1
            print(f"{what}: {len(counts)}; places per value: "
                  + ", ".join(f"{n} place(s): {k}" for n, k in sorted(hist.items()))
                  + f"; most: {max(counts.values())}; total {sum(counts.values())}")
            for k, c in counts.items():
                print(f"  {c}  {k}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
