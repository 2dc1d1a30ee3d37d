"""Mutation testing of the physics and scoring modules: do the tests notice a wrong sign.

A small AST mutator (no dependency beyond the test requirements).  For each configured
module it lists every mutation site, draws a seeded sample of ``--n`` mutants evenly
spread over the file (``--all`` takes every one), and for each mutant

1. writes the mutated module into a *temporary copy* of the tree (``vfs/`` and ``tests/``
   copied, the other top-level folders linked); the real files are never touched, so other
   processes importing ``vfs`` are not disturbed;
2. runs the module's own tests (``OWN_TESTS``), then every other test file that imports the
   module, with ``pytest -x -q -p no:cacheprovider`` and a per-mutant timeout.

Only the tests that executed the mutated line in an unmutated traced run are run (a mutant of
a line no test executes survives without a run: "not covered"); lines executed at import
(module constants, default arguments, dataclass fields) select every test of the files.
A mutant is *killed* when pytest fails (or the run exceeds the timeout: counted as killed,
listed as "timeout"), *survives* otherwise.  Mutants listed in ``EQUIVALENT`` (with the reason
each cannot change behaviour) are excluded from the kill rate and named in the report.

Operators: ``+ - * / ** //`` swaps, augmented ``+= -=`` / ``*= /=``, comparison boundary
(``<`` -> ``<=``) and negation (``<`` -> ``>=``), ``==`` <-> ``!=``, ``is``/``in`` negated,
``and`` <-> ``or``, ``not x`` -> ``x``, condition negation (``if``/``while``/ternary),
unary minus removed (sign flip), constant tweaks (number + 1, ``True`` <-> ``False``),
``any`` <-> ``all``, ``min`` <-> ``max`` (also ``np.minimum``/``np.maximum``,
``np.any``/``np.all``, ``floor``/``ceil``), return swaps (tuple order, ``True``/``False``),
removed statements (calls, augmented and subscript/attribute assignments, ``raise``,
``break``/``continue``).

Writes ``OUT/mutation-<date>[-<tag>].md`` and ``.json``: kill rate per module (own tests /
all importing tests), surviving mutants by file and line, equivalent mutants with reasons,
timeouts, and the CPU and wall time of the run.  Not run in CI (minutes to an hour).

Usage (from the repository root; docs/testing.md)::

    nice -n 10 python benchmarks/mutation.py [--n 40 | --all] [--seed 0] [--module impact]
        [--tag before] [--out benchmarks/results]
"""

from __future__ import annotations

import argparse
import ast
import copy
import datetime as _dt
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Module -> glob patterns (relative to the root) of its own tests.  Every other test file
#: that imports the module runs after them.
OWN_TESTS: dict[str, tuple[str, ...]] = {
    "vfs/physics/impact.py": ("tests/physics/test_impact*.py", "tests/test_impact_blocks.py"),
    "vfs/physics/geometry.py": ("tests/physics/test_geometry*.py",),
    "vfs/analysis/stats.py": ("tests/analysis/test_stats*.py",),
    "vfs/analysis/euro_ncap.py": ("tests/scenarios/test_euro_ncap*.py",
                                  "tests/analysis/test_euro_ncap*.py"),
    "vfs/physics/precrash.py": ("tests/physics/test_precrash*.py",),
    "vfs/physics/runout.py": ("tests/physics/test_runout*.py",
                              "tests/physics/test_core_runout.py"),
    "vfs/effects/learned.py": ("tests/effects/test_learned*.py", "tests/diagnosis/test_learn*.py",
                               "tests/diagnosis/test_channels.py"),
}

#: Environment of the test runs of a module (trace and mutants).  ``precrash.py`` and
#: ``runout.py`` hold the numpy reference of the pre-crash step and the run-out, whose compiled
#: twins (:mod:`vfs.physics.core` and the compiled run-out) run by default and are checked bit
#: for bit against them by their own tests: ``VFS_COMPILED=0`` makes the tests run the code that
#: is mutated.  (A test that sets the variable itself, e.g. to compare both paths, still can.)
MODULE_ENV: dict[str, dict[str, str]] = {
    # the impact's numpy block solver is the reference of vfs.physics.core_impact, which
    # solve_impact runs by default: its mutants are seen on the numpy path only
    "vfs/physics/impact.py": {"VFS_COMPILED": "0"},
    "vfs/physics/precrash.py": {"VFS_COMPILED": "0"},
    "vfs/physics/runout.py": {"VFS_COMPILED": "0"},
}
_CURRENT: list[str] = []  # the module being run

#: Equivalent mutants: (module, enclosing function, source line (stripped), original
#: source, mutated source) -> why no input can tell the mutant from the original.  Excluded
#: from the kill rate.
EQUIVALENT: dict[tuple[str, str, str, str, str], str] = {
    ("vfs/analysis/euro_ncap.py", "run_measures.kmh",
     "return np.round(np.round(values * KMH_PER_MS / step) * step, 1)", "1", "2"):
        "the second rounding of k x 0.1 (k an integer) to 1 or to 2 decimals gives the same "
        "double: k x 0.1 is within 1e-15 of k / 10, whose nearest double both return",
    **{("vfs/physics/geometry.py", f"RectangleFrame.{function}", line, "2", "3"):
       "the slice end 2 -> 3 of an (N, 2) array selects the same last column"
       for function, line in (
           ("to_local", "dy = points[..., 1] - self.centre[:, 1:2]"),
           ("to_local", "c, s = self.axis[:, 0:1], self.axis[:, 1:2]"),
           ("to_global", "c, s = self.axis[:, 0:1], self.axis[:, 1:2]"),
           ("to_global", "gy = self.centre[:, 1:2] + s * x + c * y"))},
    ("vfs/physics/geometry.py", "swept_overlap",
     "return np.where(norm > 0.0, np.minimum(common / shorter, 1.0), np.nan)",
     "norm > 0.0", "(norm >= 0.0)"):
        "at norm = 0 the direction is 0 / 0 = NaN, so common / shorter is NaN too and "
        "np.minimum keeps it: both branches give NaN there",
    ("vfs/physics/geometry.py", "contact_plane", "valid = ~np.isnan(points[..., 0])",
     "0", "1"):
        "the points are NaN in both coordinates or in neither (the input contract, as "
        ":func:`outline_intersections` writes them): x and y mark the same slots",
    ("vfs/physics/precrash.py", "PrecrashRun._settle",
     "if self.active is None or self.active[0].shape[0] != 2 * rows.shape[0]:", "0", "1"):
        "active is (path rows (2n,), their last knots (2n, fields)) of the same rows "
        "(precrash_contact.active_rows): both have 2n rows, so [0] and [1] give one count",
    ("vfs/physics/precrash.py", "PrecrashRun._settle",
     "w = np.clip((impact_time[r] - prev_tau[due]) / dt, 0.0, 1.0)[:, None]", "1.0", "2.0"):
        "a row is due only when impact_time <= tau + 1e-12, so w <= 1 + 1e-12 / dt: the upper "
        "clip 1 -> 2 moves dv at the impact by at most 1e-12 / dt (1e-10) of one step's "
        "change, an ulp-scale difference (equivalent within rounding, not bit for bit)",
    ("vfs/physics/precrash.py", "PrecrashRun._end_rows",
     "expired = ~pending[rows] & (tau >= self.case_horizon[rows] - 1e-9)",
     "tau >= self.case_horizon[rows] - 1e-9", "(tau > self.case_horizon[rows] - 1e-09)"):
        "differs only where k dt equals case_horizon - 1e-9 to the last bit; the 1e-9 is "
        "there to absorb the rounding of k dt, so a horizon on or off the step grid ends at "
        "the same step either way (equivalent within rounding)",
    ("vfs/physics/precrash.py", "PrecrashRun._settle",
     "due = pending[rows] & (impact_time[rows] <= tau + 1e-12)", "tau + 1e-12",
     "(tau - 1e-12)"):
        "differs only where the impact time lies on the step grid to within 1e-12 s; the row is "
        "then due one step later with w = 0, i.e. with the reductions of that same grid time, "
        "so the impact state is the same (equivalent within rounding)",
    ("vfs/physics/precrash.py", "PrecrashRun._settle_compiled", "rec = np.empty((2, m, 2))",
     "2", "3"):
        "the compiled step fills rec[0] and rec[1] only (recorded speed and acceleration); a "
        "third plane is never read",
    ("vfs/physics/runout.py", "_wheel_limits",
     "s[2] + lon - lat_r, s[3] + lon + lat_r])", "2", "3"):
        "the static loads of the two rear wheels are equal (static_wheel_loads: m g L1 / (2 L) "
        "each), so s[2] and s[3] are the same numbers",
    ("vfs/physics/impact.py", "<module>",
     '"m1": (np.nextafter(0.0, 1.0), 2.0e5), "m2": (np.nextafter(0.0, 1.0), 2.0e5),',
     "1.0", "2.0"):
        "np.nextafter(0.0, x) is the smallest subnormal for every x > 0: the lower bound of "
        "the masses does not change",
    ("vfs/physics/impact.py", "<module>",
     '"izz1": (np.nextafter(0.0, 1.0), 1.0e7), "izz2": (np.nextafter(0.0, 1.0), 1.0e7),',
     "1.0", "2.0"):
        "np.nextafter(0.0, x) is the smallest subnormal for every x > 0: the lower bound of "
        "the yaw inertias does not change",
    ("vfs/physics/precrash.py", "PrecrashRun._keep", "self.active = None", "self.active = None",
     "pass"):
        "active caches the path rows of the running rows for _settle, which recomputes it "
        "whenever its size differs from 2 x the running rows: a _keep that drops a row "
        "changes the size, one that drops none leaves the rows (and their active rows) as "
        "they were, and _start and start() reset it themselves",
    ("vfs/physics/precrash.py", "PrecrashRun._settle_compiled",
     "self.v_rec, self.a_rec = rec[0], rec[1]", "0", "1"):
        "v_rec (the recorded speeds of the running rows) is carried along (_keep, _start, "
        "start) but never read: the speeds the run needs come from record_pair "
        "(_taken_off) and from the compiled step itself; only a_rec is read (advance, "
        "observation)",
    ("vfs/effects/learned.py", "check_law", "evaluate_law(law, np.zeros(1))", "1", "2"):
        "check_law evaluates the law only to raise on a bad form or coefficient count; one "
        "feature value or two raise the same (the value is discarded)",
    ("vfs/effects/learned.py", "law_effect_class",
     'for n, v in zip(names, law["coefficients"], strict=True):', "True", "False"):
        "check_law (evaluate_law) has already raised unless the law has exactly as many "
        "coefficients as its form has names, so the zip never sees unequal lengths",
}

#: Equivalent mutants where a line holds the same constant twice: the key of
#: :data:`EQUIVALENT` and the column of the mutated constant.
EQUIVALENT_AT: dict[tuple[str, str, str, str, str, int], str] = {
    ("vfs/physics/precrash.py", "PrecrashRun._settle",
     "w = np.where(first, 0.0, np.clip((t_c - prev_tau[new_contact]) / dt, 0.0,", "0.0", "1.0",
     32):
        "a first contact at a row's own step 0 interpolates between the reductions of that "
        "step and of the step before, which are both 0 there (a fresh _Track and zero prev_* "
        "from __init__ and _start; no step of the row has been integrated), so the weight "
        "0 or 1 gives the same dv, ds and state",
}


def equivalent_reason(module: str, function: str, context: str, original: str, mutated: str,
                      col: int) -> str | None:
    """Why the mutant is equivalent (:data:`EQUIVALENT`, :data:`EQUIVALENT_AT`), or None."""
    key = (module, function, context, original, mutated)
    return EQUIVALENT.get(key, EQUIVALENT_AT.get((*key, col)))

#: Call names swapped by the call mutator (both directions).
_CALL_SWAPS = {
    "any": "all", "all": "any", "min": "max", "max": "min",
    "minimum": "maximum", "maximum": "minimum", "amin": "amax", "amax": "amin",
    "nanmin": "nanmax", "nanmax": "nanmin", "floor": "ceil", "ceil": "floor",
    "argmin": "argmax", "argmax": "argmin",
}
_BIN_SWAPS = {
    ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
    ast.Pow: ast.Mult, ast.FloorDiv: ast.Div, ast.Mod: ast.FloorDiv,
}
_CMP_BOUNDARY = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt}
_CMP_NEGATE = {
    ast.Lt: ast.GtE, ast.LtE: ast.Gt, ast.Gt: ast.LtE, ast.GtE: ast.Lt,
    ast.Eq: ast.NotEq, ast.NotEq: ast.Eq, ast.Is: ast.IsNot, ast.IsNot: ast.Is,
    ast.In: ast.NotIn, ast.NotIn: ast.In,
}


@dataclass
class Mutant:
    """One mutation: the source span it replaces and the replacement text."""

    module: str
    line: int
    col: int
    end_line: int
    end_col: int
    kind: str
    function: str
    original: str
    mutated: str
    status: str = "pending"  # killed-own, killed-all, timeout, survived, not-covered, equivalent
    seconds: float = 0.0
    tests_run: int = 0
    reason: str = ""
    lines: tuple[int, int] = (0, 0)
    context: str = ""  # the source line of the mutation, stripped

    @property
    def key(self) -> tuple[str, str, str, str, str]:
        """The key of :data:`EQUIVALENT` (stable while the line's text stays)."""
        return (self.module, self.function, self.context, self.original, self.mutated)


def _flat(text: str) -> str:
    return re.sub(r"\s+", " ", text).strip()


class _Sites(ast.NodeVisitor):
    """Collect the mutation sites of one module."""

    def __init__(self, module: str, source: str) -> None:
        self.module = module
        self.source = source
        self.stack: list[str] = []
        self.found: list[Mutant] = []
        self.stmt: ast.stmt | None = None

    # -- helpers ---------------------------------------------------------------------------
    def _segment(self, node: ast.AST) -> str:
        return ast.get_source_segment(self.source, node) or ast.unparse(node)

    def _add(self, node: ast.AST, kind: str, replacement: str, *, paren: bool = True) -> None:
        original = self._segment(node)
        text = f"({replacement})" if paren else replacement
        if _flat(original) == _flat(replacement):
            return
        stmt = self.stmt if self.stmt is not None else node
        self.found.append(
            Mutant(
                module=self.module,
                line=node.lineno,  # type: ignore[attr-defined]
                col=node.col_offset,  # type: ignore[attr-defined]
                end_line=node.end_lineno,  # type: ignore[attr-defined]
                end_col=node.end_col_offset,  # type: ignore[attr-defined]
                kind=kind,
                function=".".join(self.stack) or "<module>",
                original=_flat(original),
                mutated=_flat(text),
                lines=(stmt.lineno, stmt.end_lineno or stmt.lineno),
                context=self.source.splitlines()[node.lineno - 1].strip(),  # type: ignore[attr-defined]
            )
        )

    def _replace(self, node: ast.expr, kind: str, mutate) -> None:  # type: ignore[no-untyped-def]
        new = copy.deepcopy(node)
        out = mutate(new)
        self._add(node, kind, ast.unparse(out if out is not None else new))

    # -- scopes and skipped parts ----------------------------------------------------------
    def _scope(self, node: ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) -> None:
        self.stack.append(node.name)  # decorators (dataclass options) are not mutated
        self.stmt = node  # defaults are evaluated where the def runs
        if isinstance(node, ast.ClassDef):
            body = node.body
        else:
            for default in node.args.defaults + [d for d in node.args.kw_defaults if d]:
                self.visit(default)
            body = node.body
        for stmt in body:
            self.visit(stmt)
        self.stack.pop()

    visit_FunctionDef = _scope  # type: ignore[assignment]
    visit_AsyncFunctionDef = _scope  # type: ignore[assignment]
    visit_ClassDef = _scope  # type: ignore[assignment]

    def visit_JoinedStr(self, node: ast.JoinedStr) -> None:  # messages
        return

    def visit_Assert(self, node: ast.Assert) -> None:
        return

    def visit_AnnAssign(self, node: ast.AnnAssign) -> None:
        self.stmt = node
        if node.value is not None:
            self.visit(node.value)

    def visit_Raise(self, node: ast.Raise) -> None:
        self.stmt = node
        self._add(node, "remove raise", "pass", paren=False)

    def visit_Import(self, node: ast.Import) -> None:
        return

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        return

    def visit_If(self, node: ast.If) -> None:
        if isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            return
        self.stmt = node
        self._negate(node.test)
        self.visit(node.test)
        for stmt in node.body + node.orelse:
            self.visit(stmt)

    def visit_While(self, node: ast.While) -> None:
        self.stmt = node
        self._negate(node.test)
        self.visit(node.test)
        for stmt in node.body + node.orelse:
            self.visit(stmt)

    def visit_IfExp(self, node: ast.IfExp) -> None:
        self._negate(node.test)
        self.generic_visit(node)

    def _negate(self, test: ast.expr) -> None:
        if isinstance(test, ast.UnaryOp) and isinstance(test.op, ast.Not):
            return  # "not x" -> "x" is the UnaryOp mutator
        if isinstance(test, ast.Compare):
            return  # the comparison negation covers it
        self._add(test, "negate condition", f"not ({self._segment(test)})")

    # -- statements ------------------------------------------------------------------------
    def generic_visit(self, node: ast.AST) -> None:
        if isinstance(node, ast.stmt):
            self.stmt = node
        super().generic_visit(node)

    def visit_Expr(self, node: ast.Expr) -> None:
        self.stmt = node
        if isinstance(node.value, ast.Constant):
            return  # docstring
        if isinstance(node.value, ast.Call):
            self._add(node, "remove statement", "pass", paren=False)
        self.visit(node.value)

    def visit_AugAssign(self, node: ast.AugAssign) -> None:
        self.stmt = node
        self._add(node, "remove statement", "pass", paren=False)
        swap = _BIN_SWAPS.get(type(node.op))
        if swap is not None and swap is not ast.FloorDiv:
            new = copy.deepcopy(node)
            new.op = swap()
            self._add(node, "augmented operator", ast.unparse(new), paren=False)
        self.visit(node.value)

    def visit_Assign(self, node: ast.Assign) -> None:
        self.stmt = node
        if any(isinstance(t, ast.Subscript | ast.Attribute) for t in node.targets):
            self._add(node, "remove statement", "pass", paren=False)
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            return
        self.visit(node.value)

    def visit_Break(self, node: ast.Break) -> None:
        self._add(node, "remove statement", "pass", paren=False)

    def visit_Continue(self, node: ast.Continue) -> None:
        self._add(node, "remove statement", "pass", paren=False)

    def visit_Return(self, node: ast.Return) -> None:
        self.stmt = node
        value = node.value
        if isinstance(value, ast.Tuple) and len(value.elts) >= 2:
            a, b = (self._segment(e) for e in value.elts[:2])
            rest = [self._segment(e) for e in value.elts[2:]]
            self._add(value, "swap returned values", ", ".join([b, a, *rest]))
        if isinstance(value, ast.Constant) and isinstance(value.value, bool):
            self._add(value, "return constant", str(not value.value), paren=False)
        if value is not None:
            self.visit(value)

    # -- expressions -----------------------------------------------------------------------
    def visit_BinOp(self, node: ast.BinOp) -> None:
        swap = _BIN_SWAPS.get(type(node.op))
        if swap is not None:
            def mutate(n: ast.BinOp) -> None:
                n.op = swap()
            self._replace(node, "arithmetic operator", mutate)
        self.generic_visit(node)

    def visit_Compare(self, node: ast.Compare) -> None:
        for i, op in enumerate(node.ops):
            for table, kind in ((_CMP_BOUNDARY, "comparison boundary"),
                                (_CMP_NEGATE, "comparison negation")):
                new_op = table.get(type(op))
                if new_op is None:
                    continue

                def mutate(n: ast.Compare, i: int = i, new_op: type = new_op) -> None:
                    n.ops[i] = new_op()
                self._replace(node, kind, mutate)
        self.generic_visit(node)

    def visit_BoolOp(self, node: ast.BoolOp) -> None:
        def mutate(n: ast.BoolOp) -> None:
            n.op = ast.Or() if isinstance(n.op, ast.And) else ast.And()
        self._replace(node, "and/or", mutate)
        self.generic_visit(node)

    def visit_UnaryOp(self, node: ast.UnaryOp) -> None:
        if isinstance(node.op, ast.USub):
            self._add(node, "sign flip", self._segment(node.operand))
        elif isinstance(node.op, ast.Not):
            self._add(node, "remove not", self._segment(node.operand))
        self.generic_visit(node)

    def visit_Constant(self, node: ast.Constant) -> None:
        value = node.value
        if isinstance(value, bool):
            self._add(node, "constant", str(not value), paren=False)
        elif isinstance(value, int):
            self._add(node, "constant", repr(value + 1), paren=False)
        elif isinstance(value, float):  # 0 -> 1, small + 1, large x 2
            tweak = value + 1.0 if abs(value) < 1.0 else 2.0 * value
            self._add(node, "constant", repr(tweak), paren=False)

    def visit_Call(self, node: ast.Call) -> None:
        func = node.func
        name = func.id if isinstance(func, ast.Name) else (
            func.attr if isinstance(func, ast.Attribute) else None)
        if name in _CALL_SWAPS:
            def mutate(n: ast.Call) -> None:
                if isinstance(n.func, ast.Name):
                    n.func.id = _CALL_SWAPS[n.func.id]
                else:
                    n.func.attr = _CALL_SWAPS[n.func.attr]  # type: ignore[attr-defined]
            self._replace(node, "call swap", mutate)
        self.generic_visit(node)

    def visit_Subscript(self, node: ast.Subscript) -> None:
        self.visit(node.value)
        self.visit(node.slice)


def sites(module: str, root: Path = ROOT) -> list[Mutant]:
    """Every mutation site of ``module`` (a path relative to ``root``), in source order."""
    source = (root / module).read_text()
    visitor = _Sites(module, source)
    visitor.visit(ast.parse(source))
    found = []
    for m in visitor.found:
        if _apply(source, m) is not None:
            found.append(m)
    found.sort(key=lambda m: (m.line, m.col, m.kind, m.mutated))
    return found


def _apply(source: str, m: Mutant) -> str | None:
    """The source with ``m`` applied, or None where it does not parse."""
    lines = source.splitlines(keepends=True)
    offsets = np.cumsum([0] + [len(s.encode()) for s in lines])
    data = source.encode()
    start = int(offsets[m.line - 1]) + m.col
    end = int(offsets[m.end_line - 1]) + m.end_col
    out = (data[:start] + m.mutated.encode() + data[end:]).decode()
    try:
        ast.parse(out)
    except SyntaxError:
        return None
    return out


def sample(all_sites: list[Mutant], n: int | None, seed: int) -> list[Mutant]:
    """``n`` sites evenly spread (one from each of n equal strata in source order), seeded."""
    if n is None or n >= len(all_sites):
        return list(all_sites)
    rng = np.random.default_rng([seed, zlib.crc32(all_sites[0].module.encode())])
    edges = np.linspace(0, len(all_sites), n + 1).astype(int)
    pairs = zip(edges[:-1], edges[1:], strict=True)
    return [all_sites[int(rng.integers(lo, hi))] for lo, hi in pairs]


# -- the tests of a module ------------------------------------------------------------------
def _imports_module(path: Path, module: str) -> bool:
    dotted = module[:-3].replace("/", ".")
    package, _, leaf = dotted.rpartition(".")
    try:
        tree = ast.parse(path.read_text())
    except SyntaxError:
        return False
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(
            a.name == dotted or a.name.startswith(dotted + ".") for a in node.names
        ):
            return True
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.module == dotted or node.module.startswith(dotted + "."):
                return True
            if node.module == package and any(a.name == leaf for a in node.names):
                return True
    return False


def test_files(module: str, root: Path = ROOT) -> tuple[list[str], list[str]]:
    """(own test files, other test files importing the module), relative to ``root``."""
    own: list[str] = []
    for pattern in OWN_TESTS[module]:
        own += sorted(str(p.relative_to(root)) for p in root.glob(pattern))
    own = list(dict.fromkeys(own))
    others = sorted(
        str(p.relative_to(root))
        for p in (root / "tests").rglob("test_*.py")
        if str(p.relative_to(root)) not in own and _imports_module(p, module)
    )
    return own, others


# -- the temporary tree ---------------------------------------------------------------------
def make_tree(at: str | None = None, tests_at: str | None = None) -> Path:
    """A temporary copy of vfs/ and tests/ (other top-level entries linked): of the working
    tree, or of commit ``at`` (``git archive``; e.g. the tests before new ones were added);
    ``tests_at``: tests/ of that commit with the code of the working tree (the "before" of
    new tests where the code changed meanwhile: the same mutants, the old tests).
    """
    tmp = Path(tempfile.mkdtemp(prefix="vfs-mutation-"))
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".hypothesis")
    if at:
        archive = subprocess.run(["git", "archive", at, "vfs", "tests"], cwd=ROOT,
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
    else:
        for name in ("vfs", "tests"):
            shutil.copytree(ROOT / name, tmp / name, ignore=ignore)
    if tests_at:
        shutil.rmtree(tmp / "tests")
        archive = subprocess.run(["git", "archive", tests_at, "tests"], cwd=ROOT,
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
    for entry in ROOT.iterdir():
        if entry.name in ("vfs", "tests", ".git") or (tmp / entry.name).exists():
            continue
        if entry.is_file():
            shutil.copy2(entry, tmp / entry.name)
        else:
            (tmp / entry.name).symlink_to(entry)
    return tmp


def _env(tree: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tree), str(tree / "benchmarks")])
    env.pop("VFS_COMPILED", None)  # both_runout_paths runs the numpy reference too
    if _CURRENT:
        env.update(MODULE_ENV.get(_CURRENT[0], {}))
    return env


#: Third-party modules imported once in the runner and inherited by each forked test run
#: (vfs itself is imported in the child, from the temporary tree, mutated).
PRELOAD = ("numpy", "scipy.stats", "scipy.optimize", "scipy.spatial", "pandas", "hypothesis",
           "shapely", "statsmodels.api")


def _preload() -> None:
    import importlib

    for name in PRELOAD:
        try:
            importlib.import_module(name)
        except ImportError:
            pass


def _pytest(tree: Path, args: list[str], timeout: float, extra_env: dict[str, str] | None = None,
            stop_at_first: bool = True) -> tuple[str, float]:
    """Run pytest in ``tree`` in a forked child; ("pass" | "fail" | "timeout", wall seconds)."""
    env = _env(tree)
    if extra_env:
        env.update(extra_env)
    argv = ["-x"] * stop_at_first + ["-q", "-p", "no:cacheprovider", "-o", "addopts=", *args]
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # the child: a fresh session, the tree first on sys.path
        code = 3
        try:
            os.setsid()
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            os.environ.clear()
            os.environ.update(env)
            os.chdir(tree)
            sys.path[:0] = [str(tree), str(tree / "benchmarks")]
            code = int(pytest.main(argv))
        finally:
            os._exit(code)
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            rc = os.waitstatus_to_exitcode(status)
            return ("pass" if rc == 0 else "fail"), time.perf_counter() - t0
        if time.perf_counter() - t0 > timeout:
            try:
                os.killpg(pid, 9)
            except ProcessLookupError:
                pass
            os.waitpid(pid, 0)
            return "timeout", time.perf_counter() - t0
        time.sleep(0.05)


# -- line tracing (the pytest plugin side: ``-p mutation`` with MUTATION_TRACE set) ----------
_TRACE: dict[str, object] = {}


def pytest_configure(config) -> None:  # type: ignore[no-untyped-def]
    """Record the probes of the instrumented module, per test (plugin hook)."""
    out = os.environ.get("MUTATION_TRACE")
    if not out:
        return
    import builtins

    lines: dict[str, set[int]] = {}
    state = {"test": "<import>"}

    def hit(line: int) -> None:
        lines.setdefault(state["test"], set()).add(line)

    builtins.__mutation_hit__ = hit  # type: ignore[attr-defined]
    _TRACE.update(out=out, lines=lines, state=state, durations={})


_PROBE = "__mutation_hit__"


class _Probes(ast.NodeTransformer):
    """Insert ``__mutation_hit__(line)`` before every statement (the original line numbers)."""

    def _block(self, body: list[ast.stmt], top: bool = False) -> list[ast.stmt]:
        out: list[ast.stmt] = []
        for i, stmt in enumerate(body):
            skip = top and (
                (i == 0 and isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant))
                or (isinstance(stmt, ast.ImportFrom) and stmt.module == "__future__"))
            if not skip:
                out.append(ast.Expr(ast.Call(ast.Name(_PROBE, ast.Load()),
                                             [ast.Constant(stmt.lineno)], [])))
            out.append(self.visit(stmt))
        return out

    def generic_visit(self, node: ast.AST) -> ast.AST:
        for name in ("body", "orelse", "finalbody"):
            block = getattr(node, name, None)
            if isinstance(block, list) and block and isinstance(block[0], ast.stmt):
                setattr(node, name, self._block(block, top=isinstance(node, ast.Module)))
        for name, value in ast.iter_fields(node):
            if name in ("body", "orelse", "finalbody"):
                continue
            if isinstance(value, list):
                for item in value:
                    if isinstance(item, ast.AST):
                        self.visit(item)
            elif isinstance(value, ast.AST):
                self.visit(value)
        return node


def instrument(source: str) -> str:
    """``source`` with a line probe before every statement (for the coverage map)."""
    tree = _Probes().visit(ast.parse(source))
    return ast.unparse(ast.fix_missing_locations(tree))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):  # type: ignore[no-untyped-def]
    """Attribute the traced lines to the running test (plugin hook)."""
    if not _TRACE:
        yield
        return
    _TRACE["state"]["test"] = item.nodeid  # type: ignore[index]
    t0 = time.perf_counter()
    yield
    _TRACE["durations"][item.nodeid] = time.perf_counter() - t0  # type: ignore[index]
    _TRACE["state"]["test"] = "<import>"  # type: ignore[index]


def pytest_runtest_logreport(report):  # type: ignore[no-untyped-def]
    """Note the tests that fail unmutated (plugin hook): they select no mutant."""
    if _TRACE and report.failed:
        _TRACE.setdefault("failed", set()).add(report.nodeid)  # type: ignore[union-attr]


def pytest_unconfigure(config) -> None:  # type: ignore[no-untyped-def]
    """Write the traced lines (plugin hook)."""
    if not _TRACE:
        return
    lines = _TRACE["lines"]
    data = {"lines": {k: sorted(v) for k, v in lines.items()},  # type: ignore[attr-defined]
            "durations": _TRACE["durations"],
            "failed": sorted(_TRACE.get("failed", set()))}  # type: ignore[call-overload]
    Path(str(_TRACE["out"])).write_text(json.dumps(data))


@dataclass
class CoverageMap:
    """Which test (function, parameters folded) executed which line of the module."""

    lines: dict[str, set[int]]
    durations: dict[str, float]
    import_lines: set[int] = field(default_factory=set)
    failed: list[str] = field(default_factory=list)
    untraced: list[str] = field(default_factory=list)
    limit: float = 0.0
    run_untraced: bool = False


def _fold(nodeid: str) -> str:
    return nodeid.split("[", 1)[0]


def trace(tree: Path, module: str, files: list[str], limit: float) -> CoverageMap:
    """Run ``files`` once, unmutated, recording per test the lines of ``module`` executed.

    A file whose traced run exceeds ``limit`` seconds (the trace slows pure-Python code
    several times) is listed in ``untraced``: it runs whole for every mutant that survives
    the traced files.
    """
    lines: dict[str, set[int]] = {}
    durations: dict[str, float] = {}
    imports: set[int] = set()
    failed: list[str] = []
    untraced: list[str] = []
    target = tree / module
    original = target.read_text()
    _ORIGINALS[module] = original
    target.write_text(instrument(original))
    for pyc in (target.parent / "__pycache__").glob(target.stem + ".*.pyc"):
        pyc.unlink()
    try:
        _trace_files(tree, module, files, limit, lines, durations, imports, failed, untraced)
    finally:
        target.write_text(original)
        for pyc in (target.parent / "__pycache__").glob(target.stem + ".*.pyc"):
            pyc.unlink()
    return CoverageMap(lines, durations, imports, failed, untraced, limit)


_ORIGINALS: dict[str, str] = {}
TRACE_DIR: list[str] = []

#: Mapping runs by (test file, its text, the module's text): reused by a later run
#: (``--survivors-of``) where neither changed.
TRACE_CACHE: dict[str, dict] = {}


def _trace_files(tree: Path, module: str, files: list[str], limit: float,  # noqa: PLR0913
                 lines: dict[str, set[int]], durations: dict[str, float], imports: set[int],
                 failed: list[str], untraced: list[str]) -> None:
    module_key = zlib.crc32(_ORIGINALS[module].encode())
    for f in files:
        key = f"{module}|{f}|{zlib.crc32((tree / f).read_bytes())}|{module_key}"
        earlier = (Path(TRACE_DIR[0]) / f".trace-{zlib.crc32(f.encode())}.json"
                   if TRACE_DIR else None)
        if key in TRACE_CACHE:
            status, data = TRACE_CACHE[key]["status"], TRACE_CACHE[key]["data"]
            print(f"  traced {f}: {status} (reused)", flush=True)
        elif earlier is not None:  # the mapping files of an interrupted run's tree
            data = json.loads(earlier.read_text()) if earlier.exists() else None
            status = "pass" if data is not None else "timeout"
            TRACE_CACHE[key] = {"status": status, "data": data}
            print(f"  traced {f}: {status} (from {TRACE_DIR[0]})", flush=True)
        else:
            out = tree / f".trace-{zlib.crc32(f.encode())}.json"
            status, seconds = _pytest(
                tree, ["-p", "mutation", f], timeout=limit,
                extra_env={"MUTATION_TRACE": str(out),
                           "MUTATION_TRACE_TARGET": str(tree / module)},
                stop_at_first=False,
            )
            print(f"  traced {f}: {status} ({seconds:.0f} s)", flush=True)
            data = json.loads(out.read_text()) if out.exists() else None
            TRACE_CACHE[key] = {"status": status, "data": data}
        if status == "timeout":
            untraced.append(f)
            continue
        if data is None:
            continue
        bad = {_fold(t) for t in data.get("failed", [])}
        failed += sorted(bad)
        for nodeid, ls in data["lines"].items():
            if _fold(nodeid) in bad:
                continue  # fails unmutated (e.g. a path check in the temporary tree)
            if nodeid == "<import>":
                imports |= set(ls)
            else:
                lines.setdefault(_fold(nodeid), set()).update(ls)
        for nodeid, d in data["durations"].items():
            if _fold(nodeid) not in bad:
                durations[_fold(nodeid)] = durations.get(_fold(nodeid), 0.0) + d


def _select(cov: CoverageMap, m: Mutant, files: list[str]) -> list[str]:
    span = set(range(m.line, m.end_line + 1)) | {m.lines[0]}
    if span & cov.import_lines and not any(span & ls for ls in cov.lines.values()):
        chosen = [t for t in cov.lines if t.split("::")[0] in files]
        chosen += [t for t in cov.durations if t not in chosen and t.split("::")[0] in files]
    else:
        chosen = [t for t, ls in cov.lines.items() if span & ls and t.split("::")[0] in files]
    order = {f: i for i, f in enumerate(files)}
    chosen = sorted(chosen, key=lambda t: (order[t.split("::")[0]], cov.durations.get(t, 0.0)))
    return chosen + [f for f in files if f in cov.untraced and cov.run_untraced]


def run_mutant(tree: Path, m: Mutant, source: str, cov: CoverageMap, own: list[str],
               others: list[str], factor: float, floor: float) -> None:
    """Apply ``m`` in ``tree``, run the selected tests, set ``m.status``; restore the file."""
    reason = equivalent_reason(*m.key, m.col)
    if reason is not None:
        m.status, m.reason = "equivalent", reason
        return
    target = tree / m.module
    pycache = target.parent / "__pycache__"
    mutated = _apply(source, m)
    assert mutated is not None
    t0 = time.perf_counter()
    try:
        target.write_text(mutated)
        for pyc in pycache.glob(target.stem + ".*.pyc"):
            pyc.unlink()
        ran = 0
        for phase, files in (("own", own), ("all", others)):
            tests = _select(cov, m, files)
            if not tests:
                continue
            ran += len(tests)
            budget = floor + factor * sum(
                cov.limit if t in cov.untraced else cov.durations.get(t, 1.0) for t in tests)
            status, _ = _pytest(tree, tests, timeout=budget)
            if status != "pass":
                m.status = "timeout" if status == "timeout" else f"killed-{phase}"
                break
        else:
            m.status = "survived" if ran else "not-covered"
        m.tests_run = ran
    finally:
        target.write_text(source)
        for pyc in pycache.glob(target.stem + ".*.pyc"):
            pyc.unlink()
        m.seconds = time.perf_counter() - t0


# -- report ---------------------------------------------------------------------------------
def _rates(ms: list[Mutant]) -> dict[str, float | int]:
    scored = [m for m in ms if m.status != "equivalent"]
    own = sum(m.status == "killed-own" for m in scored)
    allk = sum(m.status in ("killed-own", "killed-all", "timeout") for m in scored)
    return {
        "mutants": len(ms), "equivalent": len(ms) - len(scored),
        "killed_own": own, "killed_all": allk,
        "timeout": sum(m.status == "timeout" for m in scored),
        "survived": sum(m.status in ("survived", "not-covered") for m in scored),
        "not_covered": sum(m.status == "not-covered" for m in scored),
        "own_rate": own / len(scored) if scored else 1.0,
        "all_rate": allk / len(scored) if scored else 1.0,
    }


def write_report(out: Path, stem: str, results: dict[str, dict], meta: dict) -> Path:
    """Write ``stem``.json and ``stem``.md under ``out``; return the markdown path."""
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps({"meta": meta, "modules": results}, indent=1))
    # the mapping runs, for a later --survivors-of run (large; not a record to commit)
    (Path(tempfile.gettempdir()) / f"{stem}.trace.json").write_text(json.dumps(TRACE_CACHE))
    md = [f"# Mutation run {meta['date']}{' (' + meta['tag'] + ')' if meta['tag'] else ''}", "",
          f"`{meta['command']}` at commit `{meta['commit']}`; {meta['n']} mutants per module "
          f"(seed {meta['seed']}), evenly spread over each file.  Run time: "
          f"{meta['wall_s']:.0f} s wall, {meta['cpu_s']:.0f} s CPU (children included), "
          f"machine load {meta['load']}.", "",
          "Killed: the module's own tests fail / any test importing it fails (a timeout "
          "counts as killed).  Equivalent mutants are excluded from the rates.", "",
          "| module | sites | mutants | equivalent | killed own | killed all | rate own | "
          "rate all | survived (not covered) | timeouts | seconds |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    for mod, r in results.items():
        s = r["summary"]
        md.append(
            f"| {mod} | {r['sites']} | {s['mutants']} | {s['equivalent']} | {s['killed_own']} | "
            f"{s['killed_all']} | {100 * s['own_rate']:.1f} % | {100 * s['all_rate']:.1f} % | "
            f"{s['survived']} ({s['not_covered']}) | {s['timeout']} | {r['seconds']:.0f} |")
    md += ["", "## Surviving mutants", ""]
    for mod, r in results.items():
        surv = [m for m in r["mutants"] if m["status"] in ("survived", "not-covered")]
        if not surv:
            continue
        md.append(f"### {mod}")
        md.append("")
        for m in surv:
            note = " (no test executes the line)" if m["status"] == "not-covered" else ""
            md.append(f"- line {m['line']} in `{m['function']}` ({m['kind']}): "
                      f"`{m['original']}` -> `{m['mutated']}`{note}")
        md.append("")
    md += ["## Equivalent mutants", ""]
    eq = [m for r in results.values() for m in r["mutants"] if m["status"] == "equivalent"]
    md += [f"- {m['module']}:{m['line']} in `{m['function']}`: `{m['original']}` -> "
           f"`{m['mutated']}`: {m['reason']}" for m in eq] or ["(none in this sample)"]
    md += ["", "## Timeouts (counted as killed)", ""]
    to = [m for r in results.values() for m in r["mutants"] if m["status"] == "timeout"]
    md += [f"- {m['module']}:{m['line']} `{m['original']}` -> `{m['mutated']}`"
           for m in to] or ["(none)"]
    md += ["", "## Trace notes", ""]
    md += [f"- {mod}: failing unmutated in the temporary tree, so never selected: "
           f"{', '.join(r['trace_failed'])}" for mod, r in results.items()
           if r["trace_failed"]] or ["(the unmutated runs passed)"]
    md += [f"- {mod}: {', '.join(r['untraced'])} slower than the mapping limit: "
           + ("run whole for the mutants the mapped files leave alive" if r.get("run_untraced")
              else "not run (--run-untraced runs them)")
           for mod, r in results.items() if r["untraced"]]
    md += [f"- {mod}: tests run with "
           + ", ".join(f"{k}={v}" for k, v in r["env"].items())
           for mod, r in results.items() if r.get("env")]
    path = out / f"{stem}.md"
    path.write_text("\n".join(md) + "\n")
    return path


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=40, help="mutants per module (default 40)")
    ap.add_argument("--all", action="store_true", help="every mutation site")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--module", action="append", default=None,
                    help="a configured module (substring of its path); repeatable")
    ap.add_argument("--factor", type=float, default=4.0,
                    help="timeout = floor + factor x the unmutated time of the selected tests")
    ap.add_argument("--floor", type=float, default=30.0, help="timeout floor in seconds")
    ap.add_argument("--trace-limit", type=float, default=150.0,
                    help="seconds for the mapping run of one test file; slower files are "
                         "left out (listed in the report) unless --run-untraced")
    ap.add_argument("--run-untraced", action="store_true",
                    help="run the files too slow to map whole, for the mutants the mapped "
                         "files leave alive")
    ap.add_argument("--at", default=None,
                    help="mutate and test the tree of this commit (default: the working tree)")
    ap.add_argument("--tests-at", default=None, metavar="COMMIT",
                    help="the tests of COMMIT with the code of the working tree")
    ap.add_argument("--survivors-of", action="append", default=None, metavar="JSON",
                    help="an earlier report of the same code: run only its survivors, keep "
                         "its kills (tests were only added)")
    ap.add_argument("--merge", nargs="+", default=None, metavar="JSON",
                    help="combine the reports of runs on parts of the modules and stop")
    ap.add_argument("--trace-dir", default=None,
                    help="reuse the mapping files (.trace-*.json) of an interrupted run's tree")
    ap.add_argument("--shard", default=None, metavar="K/M",
                    help="run only the sampled mutants k, k + M, k + 2M, ... (merge the "
                         "shards' records with --merge)")
    ap.add_argument("--own-only", action="store_true",
                    help="run the module's own tests only (not the other importing files)")
    ap.add_argument("--table", nargs=2, default=None, metavar=("BEFORE", "AFTER"),
                    help="print the before/after kill rates of two (merged) records and stop")
    ap.add_argument("--tag", default="")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--list", action="store_true", help="list the sampled mutants and stop")
    args = ap.parse_args(argv)

    if args.table:
        return _table(args.table[0], args.table[1])
    if args.merge:
        return _merge(args)
    if args.trace_dir:
        TRACE_DIR.append(args.trace_dir)
    modules = list(OWN_TESTS) if args.module is None else [
        m for s in args.module for m in OWN_TESTS if s in m]
    previous: dict[str, dict] = {}
    for f in args.survivors_of or []:
        data = json.loads(Path(f).read_text())
        previous.update(data["modules"])
        TRACE_CACHE.update(data.get("trace_cache", {}))
        cached = Path(tempfile.gettempdir()) / (Path(f).stem + ".trace.json")
        if cached.exists():
            TRACE_CACHE.update(json.loads(cached.read_text()))
    n = None if args.all else args.n
    date = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d")
    stem = f"mutation-{date}" + (f"-{args.tag}" if args.tag else "")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                            capture_output=True, text=True).stdout.strip()
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    results: dict[str, dict] = {}
    tree = None if args.list else make_tree(args.at, args.tests_at)
    root = ROOT if tree is None else tree
    if args.at:
        commit = args.at
    elif args.tests_at:
        commit += f" (tests of {args.tests_at})"
    if tree is not None:
        _preload()
    try:
        for module in modules:
            all_sites = sites(module, root)
            chosen = sample(all_sites, n, args.seed)
            if args.shard:
                k, of = (int(x) for x in args.shard.split("/"))
                chosen = chosen[k::of]
            if args.list:
                for m in chosen:
                    print(f"{module}:{m.line} {m.kind}: {m.original} -> {m.mutated}")
                continue
            assert tree is not None
            t0 = time.perf_counter()
            _CURRENT[:] = [module]
            own, others = test_files(module, root)
            if args.own_only:
                others = []
            cov = trace(tree, module, own + others, args.trace_limit)
            cov.run_untraced = args.run_untraced
            source = (tree / module).read_text()
            before = {(b["line"], b["col"], b["kind"], b["mutated"]): b
                      for b in previous.get(module, {}).get("mutants", [])}
            for i, m in enumerate(chosen):
                old = before.get((m.line, m.col, m.kind, m.mutated))
                if old is not None and old["status"] in ("killed-own", "killed-all", "timeout"):
                    m.status, m.reason = old["status"], "killed in the earlier run"
                    continue  # added tests cannot revive a killed mutant
                run_mutant(tree, m, source, cov, own, others, args.factor, args.floor)
                print(f"[{module} {i + 1}/{len(chosen)}] {m.status:12s} line {m.line} "
                      f"{m.kind}: {m.original[:60]} -> {m.mutated[:60]} ({m.seconds:.0f} s)",
                      flush=True)
            results[module] = {
                "sites": len(all_sites), "own_tests": own, "other_tests": others,
                "trace_failed": cov.failed, "untraced": cov.untraced,
                "run_untraced": cov.run_untraced, "env": MODULE_ENV.get(module, {}),
                "seconds": time.perf_counter() - t0,
                "summary": _rates(chosen), "mutants": [asdict(m) for m in chosen],
            }
            s = results[module]["summary"]
            print(f"== {module}: own {100 * s['own_rate']:.1f} % all {100 * s['all_rate']:.1f} %"
                  f" ({results[module]['seconds']:.0f} s)", flush=True)
            # a partial record after each module
            _finish(args, results, stem, date, commit, n, t_wall, t_cpu)
    finally:
        if tree is not None:
            shutil.rmtree(tree, ignore_errors=True)
    if not args.list:
        print(_finish(args, results, stem, date, commit, n, t_wall, t_cpu))
    return 0


def _table(before: str, after: str) -> int:
    """Print a markdown table of the kill rates of two records."""
    b = json.loads(Path(before).read_text())["modules"]
    a = json.loads(Path(after).read_text())["modules"]

    def cell(r: dict | None, key: str) -> str:
        if r is None:
            return "-"
        s = r["summary"]
        scored = s["mutants"] - s["equivalent"]
        own_only = not r["other_tests"]  # every timeout then was a run of the own tests
        k = s["killed_all"] if key == "all" or own_only else s["killed_own"]
        return f"{100 * k / scored:.1f} % ({k}/{scored})" if scored else "-"

    print("| module | before: own tests | before: all | after: own tests | after: all | "
          "equivalent | seconds before / after |")
    print("|---|---|---|---|---|---|---|")
    for module in OWN_TESTS:
        rb, ra = b.get(module), a.get(module)
        if rb is None and ra is None:
            continue
        importers = test_files(module)[1]
        eq = (ra or rb)["summary"]["equivalent"]
        secs = " / ".join(f"{r['seconds']:.0f}" if r else "-" for r in (rb, ra))

        def every(r: dict | None, importers: list[str] = importers) -> str:
            if r is not None and not r["other_tests"] and importers:
                return "not run"  # --own-only
            return cell(r, "all") if importers else "no other importer"

        print(f"| {module} | {cell(rb, 'own')} | {every(rb)} | {cell(ra, 'own')} | "
              f"{every(ra)} | {eq} | {secs} |")
    return 0


def _merge(args: argparse.Namespace) -> int:
    """Write one report from the JSON reports of several partial runs."""
    results: dict[str, dict] = {}
    metas = []
    for f in args.merge:
        data = json.loads(Path(f).read_text())
        metas.append(data["meta"])
        for module, r in data["modules"].items():
            if module not in results:
                results[module] = r
                continue
            into = results[module]  # another shard of the same module
            into["mutants"] = sorted(into["mutants"] + r["mutants"],
                                     key=lambda m: (m["line"], m["col"], m["kind"], m["mutated"]))
            into["seconds"] += r["seconds"]
            for k in ("trace_failed", "untraced"):
                into[k] = sorted(set(into[k]) | set(r[k]))
        TRACE_CACHE.update(data.get("trace_cache", {}))
    for module, r in results.items():  # equivalents named after the run: excluded here too
        lines = (ROOT / module).read_text().splitlines()
        for m in r["mutants"]:
            m.setdefault("context", lines[m["line"] - 1].strip())
            reason = equivalent_reason(module, m["function"], m["context"], m["original"],
                                       m["mutated"], m["col"])
            if reason is not None:
                m["status"], m["reason"] = "equivalent", reason
        r["summary"] = _rates([Mutant(**{k: (tuple(v) if k == "lines" else v)
                                         for k, v in m.items()}) for m in r["mutants"]])
    order = [m for m in OWN_TESTS if m in results]
    meta = dict(metas[0])
    meta["command"] = " + ".join(m["command"] for m in metas)
    meta["wall_s"] = max(m["wall_s"] for m in metas)
    meta["cpu_s"] = sum(m["cpu_s"] for m in metas)
    meta["load"] = "; ".join(m["load"] for m in metas)
    meta["tag"] = args.tag
    stem = f"mutation-{meta['date']}" + (f"-{args.tag}" if args.tag else "")
    print(write_report(args.out, stem, {m: results[m] for m in order}, meta))
    return 0


def _finish(args, results, stem, date, commit, n, t_wall, t_cpu) -> Path:  # type: ignore[no-untyped-def]
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    meta = {
        "date": date, "tag": args.tag, "commit": commit, "seed": args.seed,
        "n": "all" if n is None else n,
        "command": "python benchmarks/mutation.py " + " ".join(sys.argv[1:]),
        "wall_s": time.perf_counter() - t_wall,
        "cpu_s": time.process_time() - t_cpu + usage.ru_utime + usage.ru_stime,
        "load": " ".join(f"{x:.1f}" for x in os.getloadavg()),
    }
    return write_report(args.out, stem, results, meta)


if __name__ == "__main__":
    raise SystemExit(main())
