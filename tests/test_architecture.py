"""The package's shape: light imports, module sizes, the public API (the non-editable install:
tests/test_install.py).

The layer contracts themselves are checked by ``lint-imports`` (``.ci/run``,
contracts in pyproject.toml).
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "vfs"


def _modules_after_import(statement: str) -> set[str]:
    code = f"import sys, json; {statement}; print(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    return set(json.loads(out.stdout))


@pytest.mark.parametrize("statement", [
    "import vfs.physics.impact",
    "import vfs",
    "import vfs.simulation",
    "import vfs.effects",
])
def test_core_imports_are_light(statement: str) -> None:
    loaded = _modules_after_import(statement)
    heavy = {"pandas", "matplotlib", "duckdb", "pyarrow", "dask", "scipy.stats", "vfs.cli",
             "vfs.report", "vfs.analysis", "vfs.diagnosis", "vfs.scenarios"}
    assert not heavy & loaded, f"{statement} imports {sorted(heavy & loaded)}"


def test_lazy_public_api_resolves_every_name() -> None:
    import vfs

    for name in vfs.__all__:
        assert getattr(vfs, name) is not None, name
    with pytest.raises(AttributeError):
        vfs.no_such_name  # noqa: B018


def test_no_top_level_helper_packages() -> None:
    # vfs is the only top-level package of the distribution; tests/ is a package too (its
    # folders mirror vfs/ and hold same-named files, which pytest imports as tests.<sub>.<name>)
    # but is not shipped: the package finder includes vfs* only
    top = {p.name for p in ROOT.iterdir() if (p / "__init__.py").exists()}
    assert top == {"vfs", "tests"}
    finder = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert finder["packages"]["find"]["include"] == ["vfs*"]


def _python_modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def test_module_sizes() -> None:
    # one concept per module: none over 1,250 lines, at most three over 900
    sizes = {str(p.relative_to(ROOT)): len(p.read_text().splitlines())
             for p in _python_modules()}
    too_big = {k: v for k, v in sizes.items() if v > 1250}
    assert not too_big, too_big
    large = {k: v for k, v in sizes.items() if v > 900}
    assert len(large) <= 3, large


def test_no_private_name_crosses_a_module_boundary() -> None:
    """``from vfs.x import _name`` appears nowhere in the package."""
    offenders = []
    for path in _python_modules():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("vfs"):
                for alias in node.names:
                    if alias.name.startswith("_") and not alias.name.startswith("__"):
                        offenders.append(f"{path.relative_to(ROOT)}: {node.module}.{alias.name}")
    assert not offenders, offenders


def test_matplotlib_is_never_switched_globally() -> None:
    pattern = re.compile(r"matplotlib\.use\(|import matplotlib\.pyplot|from matplotlib import "
                         r"pyplot")
    offenders = [str(p.relative_to(ROOT)) for p in _python_modules()
                 if pattern.search(p.read_text())]
    assert not offenders, offenders


def _api_example() -> tuple[str, str]:
    text = (ROOT / "docs" / "api.md").read_text()
    blocks = re.findall(r"```(python|text)\n(.*?)```", text, flags=re.S)
    code = next(b for kind, b in blocks if kind == "python")
    expected = next(b for kind, b in blocks if kind == "text")
    return code, expected


def test_api_example_runs_and_prints_what_the_docs_show(tmp_path: Path) -> None:
    code, expected = _api_example()
    script = tmp_path / "study.py"
    script.write_text(code)
    env = {**os.environ, "MPLBACKEND": "Agg", "CI": "true"}
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == expected.split()


def _sibling_imports(package: Path) -> dict[str, set[str]]:
    """Module -> sibling modules it imports, type-only (``if TYPE_CHECKING:``) imports and
    imports inside functions included (import-linter skips the former)."""
    prefix = "vfs." + ".".join(package.relative_to(PACKAGE).parts)
    prefix = prefix.rstrip(".") + "."
    names = {p.stem for p in package.glob("*.py") if p.stem != "__init__"}
    edges: dict[str, set[str]] = {name: set() for name in names}
    for name in names:
        tree = ast.parse((package / f"{name}.py").read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            for target in targets:
                if target.startswith(prefix):
                    sibling = target[len(prefix):].split(".")[0]
                    if sibling in names and sibling != name:
                        edges[name].add(sibling)
    return edges


def _cycle(edges: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        state[node] = 2
        stack.pop()
        return None

    for start in sorted(edges):
        if start not in state and (found := visit(start)):
            return found
    return None


def test_cycle_finder_sees_a_type_only_cycle() -> None:
    edges = _sibling_imports(PACKAGE / "gym")
    assert "observation" in edges["config"]
    edges["observation"].add("config")  # the former back edge under TYPE_CHECKING
    assert _cycle(edges) is not None


@pytest.mark.parametrize("package", sorted(p.name for p in PACKAGE.iterdir()
                                            if (p / "__init__.py").exists()))
def test_no_import_cycle_between_sibling_modules(package: str) -> None:
    # type-only imports count: a cycle of them still means the two modules cannot be
    # understood (or split) one without the other
    assert _cycle(_sibling_imports(PACKAGE / package)) is None
