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


def _numbers(node: ast.AST) -> set[float]:
    return {float(n.value) for n in ast.walk(node) if isinstance(n, ast.Constant)
            and isinstance(n.value, int | float) and not isinstance(n.value, bool)}


def _key(node: ast.AST) -> str | None:
    """The setting a node names: an attribute (``p.dt``), a string key (``s["dt"]``, a
    dict key); a bare local name (``dt``) is not the setting."""
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
        node = node.slice
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    return None


def _value(name: str | None, value: ast.AST, out: list[tuple[str, str, set[float]]]) -> None:
    """A value given to ``name``: a range when it is a tuple or list of numbers (its
    bounds), else a default."""
    if name:
        ranged = isinstance(value, ast.Tuple | ast.List) and len(_numbers(value)) >= 2
        out.append((name, "bounds" if ranged else "default", _numbers(value)))


def _bindings(stmt: ast.AST) -> list[tuple[str, str, set[float]]]:
    """Each number a statement binds to a setting's name: (name, "default" or "bounds",
    numbers) from keywords (``dt=0.01``), dict entries (``{"folds": (2, 9)}``),
    ``.get("name", 0.95)``, assignments to an attribute or key, and comparisons
    (``if not 0 < p.dt <= 0.1``: bounds)."""
    out: list[tuple[str, str, set[float]]] = []
    for n in ast.walk(stmt):
        if isinstance(n, ast.keyword) and n.arg:
            _value(n.arg, n.value, out)
        elif isinstance(n, ast.Dict):
            for k, v in zip(n.keys, n.values, strict=True):
                _value(_key(k) if k is not None else None, v, out)
        elif isinstance(n, ast.Call) and getattr(n.func, "attr", "") == "get" \
                and len(n.args) == 2:
            _value(_key(n.args[0]), n.args[1], out)
        elif isinstance(n, ast.Call) and n.args and _key(n.args[0]):  # Field("dt", hi=0.1)
            out.append((str(_key(n.args[0])), "any", _numbers(n)))
        elif isinstance(n, ast.Assign | ast.AnnAssign) and n.value is not None:
            for t in n.targets if isinstance(n, ast.Assign) else [n.target]:
                _value(_key(t) if not isinstance(t, ast.Constant) else None, n.value, out)
        elif isinstance(n, ast.Compare):
            names = {_key(x) for x in [n.left, *n.comparators]} - {None}
            out += [(str(k), "bounds", _numbers(n)) for k in names]
    return [(k, kind, nums - _TRIVIAL) for k, kind, nums in out if nums - _TRIVIAL]


#: Calls that declare a value of their own (their first argument is its name): the
#: parameters of the library effects and the channels of the learned laws.
_DECLARING_CALLS = {"EffectParameter", "Channel", "InputInfo"}
#: Calls that draw random data (a scene generator's ranges are data, not settings).
_DRAWS = {"uniform", "normal", "integers", "choice"}


Declaration = tuple[str, str, set[float], set[float]]


def _declarations(trees: dict[str, ast.Module]) -> list[Declaration]:
    """Every declared setting: (owner, name, bounds, default), owner a class of settings,
    an effect (its parameters) or ``Channel`` (the learned-law channels)."""
    from vfs.effects import get_effect, registered_effects
    from vfs.effects.learned import CHANNELS

    out = []
    for cls in _declaring_classes(trees):
        for name, s in declared(cls).items():
            bounds = {v for v in (s.lo, s.hi) if math.isfinite(v)}
            default = {float(s.default)} if isinstance(s.default, int | float) \
                and not isinstance(s.default, bool) else set()
            out.append((cls.__name__, name, bounds - _TRIVIAL, default - _TRIVIAL))
    for effect in registered_effects():
        for p in get_effect(effect).parameters:
            out.append((effect, p.name, {p.lo, p.hi} - _TRIVIAL, {p.default} - _TRIVIAL))
    for c in CHANNELS.values():
        out.append(("Channel", c.name, {c.lo, c.hi} - _TRIVIAL, set()))
    return out


def _bound_copies(trees: dict[str, ast.Module], declarations: list[Declaration]) -> list[str]:
    statements = []  # (where, enclosing class names, names declared here, bindings)
    for path, tree in trees.items():
        for stmt, parents in _simple_statements(tree):
            bindings = _bindings(stmt)
            draws = any(isinstance(c, ast.Call) and getattr(c.func, "attr", "") in _DRAWS
                        for c in ast.walk(stmt))
            if bindings and not draws:
                owners = {p.name for p in parents if isinstance(p, ast.ClassDef)}
                here = {c.args[0].value for c in ast.walk(stmt) if isinstance(c, ast.Call)
                        and getattr(c.func, "id", "") in _DECLARING_CALLS and c.args
                        and isinstance(c.args[0], ast.Constant)}
                statements.append((f"{path}:{stmt.lineno}", owners, here, bindings))
    found = []
    for owner, name, bounds, default in declarations:
        for where, owners, here, bindings in statements:
            if owner in owners or name in here:
                continue
            for key, kind, numbers in bindings:
                same = numbers & {"bounds": bounds, "default": default}.get(kind,
                                                                           bounds | default)
                if key == name and same:
                    found.append(f"{where}: {owner}.{name} {sorted(float(x) for x in same)}")
    return sorted(set(found))


def _function_default_copies(trees: dict[str, ast.Module], classes: list[type]) -> list[str]:
    """Functions of a module that holds or imports a declaring class, in its subpackage
    (``vfs/diagnosis`` for :class:`DiagnoseSpec`), whose parameter of a setting's name has
    its declared default written as a number (``grid_points: int = 9``;
    ``= DiagnoseSpec.grid_points`` is derived).  Parameters of the same name elsewhere
    (a bootstrap's ``confidence=0.95``, the law learning's own ``folds``) are other
    settings.
    """
    found = []
    for cls in classes:
        package = "/".join(cls.__module__.split(".")[:2])  # vfs/diagnosis, vfs/simulation
        defaults = {name: float(s.default) for name, s in declared(cls).items()
                    if isinstance(s.default, int | float) and not isinstance(s.default, bool)
                    and float(s.default) not in _TRIVIAL}
        for path, tree in trees.items():
            knows = any(isinstance(n, ast.ImportFrom | ast.ClassDef) and cls.__name__ in (
                [a.name for a in n.names] if isinstance(n, ast.ImportFrom) else [n.name])
                for n in ast.walk(tree))
            if not path.removesuffix(".py").startswith(package) or not knows:
                continue
            for f in ast.walk(tree):
                if not isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef):
                    continue
                a = f.args
                pos = a.posonlyargs + a.args
                pairs = [*zip(pos[len(pos) - len(a.defaults):], a.defaults, strict=True),
                         *((k, d) for k, d in zip(a.kwonlyargs, a.kw_defaults, strict=True)
                           if d is not None)]
                for arg, d in pairs:
                    if arg.arg in defaults and defaults[arg.arg] in _numbers(d):
                        found.append(f"{path}:{f.lineno}: {f.name}({arg.arg}=...) "
                                     f"{cls.__name__}.{arg.arg}")
    return sorted(found)


def _choice_copies(trees: dict[str, ast.Module], enums: dict[str, set[str]]) -> list[str]:
    found = []
    for path, tree in trees.items():
        for node in ast.walk(tree):
            if not isinstance(node, ast.Tuple | ast.List | ast.Set):
                continue
            strings = {e.value for e in node.elts
                       if isinstance(e, ast.Constant) and isinstance(e.value, str)}
            for enum, values in enums.items():
                if strings == values:
                    found.append(f"{path}:{node.lineno}: {sorted(strings)} ({enum})")
    return found


def test_no_bound_or_default_of_a_setting_stands_in_two_places() -> None:
    trees = _modules()
    declarations = _declarations(trees)
    owners = {owner for owner, *_ in declarations}
    assert len(owners) >= 10  # sensor, AEB, driver, brake actuator, effects, channels, ...
    assert {"SensorParams", "PrecrashParams", "StudySpec", "DiagnoseSpec", "Channel",
            "restitution_speed"} <= owners
    found = _bound_copies(trees, declarations)
    found += _function_default_copies(trees, _declaring_classes(trees))
    assert not found, "bounds/defaults written again:\n" + "\n".join(found)


def test_no_set_of_choices_stands_in_two_places() -> None:
    trees = _modules()
    enums = {k: v for k, v in _enums(trees).items() if len(v) >= 2}
    assert any(v == {"cv", "ctrv", "ca", "ctra"} for v in enums.values())
    assert any(v == {"1", "2", "both"} for v in enums.values())
    found = _choice_copies(trees, enums)
    assert not found, "choices written again:\n" + "\n".join(found)


_PLANTED = """
def check(params, correction, settings):
    if correction not in ("bh", "holm"):
        raise ValueError(correction)
    if not 0.0 < params.ttc_horizon <= 30.0:
        raise ValueError("ttc_horizon")
    RANGES["grid_points"] = (3, 101)
    SCAN = {"contact_friction": (0.0, 1.2)}
    return PrecrashParams(dt=min(0.01, params.dt)), settings.get("confidence", 0.95)


FIELD = Field("latency", "time", lo=0.0, hi=2.0)
"""


def test_a_planted_copy_is_found() -> None:
    """The searches above can fail: a module that writes a choice set, an AEB bound, a
    diagnosis range and a channel bound again is reported, each copy by its line."""
    trees = _modules()
    planted = {**trees, "vfs/planted.py": ast.parse(_PLANTED)}
    enums = {k: v for k, v in _enums(trees).items() if len(v) >= 2}
    assert [f.split(" (")[0] for f in _choice_copies(planted, enums)] == [
        "vfs/planted.py:3: ['bh', 'holm']"]
    found = {f for f in _bound_copies(planted, _declarations(trees))
             if f.startswith("vfs/planted.py")}
    assert found == {"vfs/planted.py:5: AEBParams.ttc_horizon [30.0]",
                     "vfs/planted.py:7: DiagnoseSpec.grid_points [3.0, 101.0]",
                     "vfs/planted.py:8: Channel.contact_friction [1.2]",
                     "vfs/planted.py:9: DiagnoseSpec.confidence [0.95]",
                     "vfs/planted.py:9: PrecrashParams.dt [0.01]",
                     "vfs/planted.py:12: SensorParams.latency [2.0]"}


def _referenced(node: ast.AST) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


def _cli_default_copies(trees: dict[str, ast.Module], classes: list[type]) -> list[str]:
    """Options of a parser that takes settings of a declaring class (one of its
    ``add_argument`` calls names the class, a variable holding ``declared(Class)`` or a
    function of the module that names it) whose ``default=`` repeats a declared default of
    that class; options of other parsers (another command's ``--seed``) are other settings.
    """
    names = {c.__name__: c for c in classes}
    found = []
    for path, tree in trees.items():
        helpers: dict[str, set[str]] = {}  # module function -> classes it names
        for f in tree.body:
            if isinstance(f, ast.FunctionDef):
                helpers[f.name] = _referenced(f) & set(names)
        for func in [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)]:
            aliases = {}  # spec = declared(StudySpec)
            for n in ast.walk(func):
                if isinstance(n, ast.Assign) and len(n.targets) == 1 \
                        and isinstance(n.targets[0], ast.Name):
                    aliases[n.targets[0].id] = _referenced(n.value) & set(names)
            calls: dict[str, list[ast.Call]] = {}
            for n in ast.walk(func):
                if isinstance(n, ast.Call) and getattr(n.func, "attr", "") == "add_argument" \
                        and isinstance(n.func.value, ast.Name):
                    calls.setdefault(n.func.value.id, []).append(n)
            for group in calls.values():
                owners: set[str] = set()
                for call in group:
                    for ref in _referenced(call):
                        owners |= ({ref} & set(names)) | aliases.get(ref, set()) \
                            | helpers.get(ref, set())
                defaults = {name.replace("_", "-"): s.default for owner in owners
                            for name, s in declared(names[owner]).items()
                            if s.default is not NO_DEFAULT and s.default is not None}
                for call in group:
                    options = [a.value.lstrip("-") for a in call.args
                               if isinstance(a, ast.Constant) and isinstance(a.value, str)]
                    for kw in call.keywords:
                        if kw.arg == "default" and isinstance(kw.value, ast.Constant):
                            found += [f"{path}:{call.lineno}: --{o}" for o in options
                                      if o in defaults and defaults[o] == kw.value.value]
    return sorted(set(found))


def test_no_cli_default_repeats_a_declared_default() -> None:
    trees = _modules()
    classes = _declaring_classes(trees)
    found = _cli_default_copies(trees, classes)
    assert not found, "declared defaults written again in the CLI:\n" + "\n".join(found)
    planted = {"vfs/cli/planted.py": ast.parse(
        "def add(p, r):\n"
        "    spec = declared(StudySpec)\n"
        "    p.add_argument('--chunk-size', **cli_kwargs(spec['chunk_size']))\n"
        "    p.add_argument('--seed', type=int, default=0)\n"
        "    r.add_argument('--seed', type=int, default=0)\n")}
    assert _cli_default_copies(planted, classes) == ["vfs/cli/planted.py:4: --seed"]


# ----------------------------------------------------------------------------
# Derived forms: the documentation tables and the command line
# ----------------------------------------------------------------------------

def test_the_docs_tables_are_the_ones_derived_from_the_declarations() -> None:
    from vfs.cli.settings_docs import BLOCKS, PAGES
    from vfs.database.docs import stale_blocks

    root = PACKAGE.parent
    held = set()
    for page in PAGES:
        assert stale_blocks(root / page, BLOCKS) == [], \
            f"run: python -m vfs.cli.settings_docs ({page})"
        held |= {name for name in BLOCKS if f"BEGIN GENERATED {name}" in
                 (root / page).read_text(encoding="utf-8")}
    assert held == set(BLOCKS)


def test_a_stale_table_is_found(tmp_path: Path) -> None:
    from vfs.cli.settings_docs import BLOCKS
    from vfs.database.docs import stale_blocks

    page = tmp_path / "page.md"
    page.write_text("<!-- BEGIN GENERATED study-settings -->\n| old |\n"
                    "<!-- END GENERATED study-settings -->\n", encoding="utf-8")
    assert stale_blocks(page, BLOCKS) == ["study-settings"]


def test_the_flags_are_derived_from_the_declarations() -> None:
    from vfs.cli import build_parser
    from vfs.diagnosis.diagnose_spec import DiagnoseSpec
    from vfs.study.spec import StudySpec

    parser = build_parser()
    study = parser.parse_args(["study", "--db", "default", "--systems", "ideal"])
    spec = declared(StudySpec)
    assert (study.chunk_size, study.task_cases, study.seed, study.engine) == (
        spec["chunk_size"].default, spec["task_cases"].default, spec["seed"].default,
        spec["engine"].default)
    diagnose = parser.parse_args(["diagnose", "--db", "default"])
    d = declared(DiagnoseSpec)
    assert (diagnose.alpha, diagnose.worst, diagnose.correction, diagnose.parameters) == (
        d["alpha"].default, d["worst"].default, "bh", "primary")
    with pytest.raises(SystemExit):
        parser.parse_args(["diagnose", "--db", "default", "--correction", "bonferroni"])


@pytest.mark.parametrize("command", ["compare", "study"])
def test_impact_parameters_one_spelling_the_old_one_with_a_warning(command: str) -> None:
    from vfs.cli import build_parser

    parser = build_parser()
    extra = ["--systems", "ideal"] if command == "study" else []
    args = parser.parse_args([command, "--db", "default", *extra, "--impact-parameters",
                              "default"])
    assert args.impact_parameters == "default"
    with pytest.warns(FutureWarning, match="use --impact-parameters default"):
        old = parser.parse_args([command, "--db", "default", *extra,
                                 "--impact-parameters", "defaults"])
    assert old.impact_parameters == "default"
    with pytest.raises(SystemExit):
        parser.parse_args([command, "--db", "default", *extra, "--impact-parameters", "x"])
    default = parser.parse_args([command, "--db", "default", *extra]).impact_parameters
    assert default == ("default" if command == "compare" else "reconstruction")
