"""Settings declared once: unit, bounds, default, choices and one line of doc per field.

In the spirit of scikit-learn's declared parameter constraints, a parameter
dataclass declares each of its fields with :func:`setting`::

    @dataclass(frozen=True)
    class SensorParams:
        latency: float = setting(0.0, "time", "from a measurement to the moment its "
                                 "decision acts", lo=0.0, hi=2.0)

        def __post_init__(self) -> None:
            validate(self)

and everything else is derived from that one declaration (:func:`declared`):

* the checks of ``__post_init__`` (:func:`validate`): every bad field and every
  broken rule between fields (:class:`Rule`) in one :class:`vfs.errors.SettingsError`,
  each problem written ``Owner.field=value: problem (allowed: range unit)``;
* the fields of a definition file (:meth:`Setting.field`, :func:`fields_of`: the
  unit-suffixed keys of :mod:`vfs.catalog`) and its reading with every problem of
  a table reported at once (:func:`read_table`);
* the command line's ``choices`` and ``help`` (:func:`cli_kwargs`);
* the tables of the documentation (:func:`markdown_table`).

Bounds are in SI (:data:`vfs.catalog.QUANTITY_UNITS` gives the units a file may
name); choices are :class:`enum.StrEnum` classes whose values are the allowed
strings.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from vfs.catalog import QUANTITY_UNITS, Field, Unit, read_fields
from vfs.errors import DefinitionError, DefinitionErrors, SettingProblem, SettingsError

#: The key of a dataclass field's metadata that holds its :class:`Setting`.
METADATA_KEY = "vfs_setting"


class _NoDefault:
    def __repr__(self) -> str:
        return "NO_DEFAULT"


#: :attr:`Setting.default` of a field without a plain default (none, or a factory).
NO_DEFAULT: Any = _NoDefault()


@dataclass(frozen=True)
class Setting:
    """The declaration of one setting.

    Attributes
    ----------
    quantity : str
        A key of :data:`vfs.catalog.QUANTITY_UNITS` (its units, SI first where it has
        one), or ``"text"``, ``"bool"``, ``"int"``.
    doc : str
        One line: what it does.
    lo, hi : float
        Allowed range in SI; ``lo_open`` / ``hi_open`` exclude the bound (an open
        infinite bound means "finite").
    choices : StrEnum subclass, optional
        The allowed values of a text setting.
    optional : bool
        None is allowed too (``optional_doc`` says what None means).
    optional_doc : str
        What None (a key left out of a file) means.
    name : str
        The attribute; set by :func:`declared`.
    default : object
        The dataclass default; set by :func:`declared` (:data:`NO_DEFAULT` for a
        field with a default factory or none).
    """

    quantity: str
    doc: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    choices: type[StrEnum] | None = None
    optional: bool = False
    optional_doc: str = ""
    name: str = ""
    default: Any = NO_DEFAULT

    # ------------------------------------------------------------ derived forms

    def field(self) -> Field:
        """The field of a definition file (:mod:`vfs.catalog`)."""
        return Field(self.name, self.quantity, lo=self.lo, hi=self.hi, lo_open=self.lo_open,
                     hi_open=self.hi_open, choices=self.choice_values())

    def choice_values(self) -> tuple[str, ...]:
        """The allowed strings (empty for a setting without choices)."""
        return tuple(m.value for m in self.choices) if self.choices is not None else ()

    def si_unit(self) -> Unit:
        """The SI unit of the quantity (the one with the identity conversion)."""
        units = QUANTITY_UNITS.get(self.quantity, (Unit("", ""),))
        for unit in units:
            if unit.to_si(2.0) == 2.0:
                return unit
        return units[0]

    def allowed(self, unit: Unit | None = None) -> str:
        """The allowed values in ``unit`` (default SI), e.g. ``[0, 2] s``."""
        text = self.field().allowed(unit or self.si_unit())
        return f"{text}, or absent" if self.optional else text

    def problem(self, value: Any) -> str | None:
        """What is wrong with ``value`` (None when it is allowed)."""
        if value is None:
            return None if self.optional else "is required"
        if self.quantity == "text":
            if not isinstance(value, str):
                return "is not text"
            if self.choices is not None and value not in self.choice_values():
                return "is not allowed"
            return None
        if self.quantity == "bool":
            return None if isinstance(value, bool | np.bool_) else "is not a boolean"
        if isinstance(value, np.bool_):
            return "is not a number"
        if isinstance(value, bool) or not isinstance(value, int | float) and not hasattr(
                value, "__float__"):
            return "is not a number"
        try:
            number = float(value)
        except (TypeError, ValueError):
            return "is not a number"
        if self.quantity == "int" and number != int(number):
            return "is not an integer"
        if math.isnan(number):
            return "is out of range"
        lo_ok = number > self.lo if self.lo_open else number >= self.lo
        hi_ok = number < self.hi if self.hi_open else number <= self.hi
        return None if lo_ok and hi_ok else "is out of range"


def setting(default: Any, quantity: str, doc: str, *, lo: float = -math.inf,
            hi: float = math.inf, lo_open: bool = False, hi_open: bool = False,
            choices: type[StrEnum] | None = None, optional: bool = False,
            optional_doc: str = "") -> Any:
    """A dataclass field declared as a :class:`Setting` (the default is ``default``).

    Parameters are those of :class:`Setting`; ``default`` is the dataclass default.
    """
    declared_setting = Setting(quantity, doc, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open,
                               choices=choices, optional=optional, optional_doc=optional_doc)
    return dataclasses.field(default=default, metadata={METADATA_KEY: declared_setting})


@dataclass(frozen=True)
class Rule:
    """A rule between settings of one dataclass.

    Attributes
    ----------
    names : tuple of str
        The settings it relates (checked only when each of them is valid alone).
    holds : callable
        ``holds(obj) -> bool``.
    text : str
        The rule as a user reads it (``"min_speed < max_speed"``).
    """

    names: tuple[str, ...]
    holds: Callable[[Any], bool]
    text: str


def declared(cls: Any) -> dict[str, Setting]:
    """The declared settings of a dataclass (or instance), attribute name -> Setting."""
    out = {}
    for f in dataclasses.fields(cls):
        s = f.metadata.get(METADATA_KEY)
        if s is not None:
            default = NO_DEFAULT if f.default is dataclasses.MISSING else f.default
            out[f.name] = dataclasses.replace(s, name=f.name, default=default)
    return out


def rules_of(cls: Any) -> tuple[Rule, ...]:
    """The :class:`Rule` objects of a class (its ``RULES`` attribute; none by default)."""
    return tuple(getattr(cls, "RULES", ()))


def problems_of(obj: Any) -> list[SettingProblem]:
    """Every declared setting of ``obj`` that is out of bounds and every broken rule."""
    owner = type(obj).__name__
    problems = []
    bad = set()
    for name, s in declared(obj).items():
        value = getattr(obj, name)
        what = s.problem(value)
        if what is not None:
            bad.add(name)
            problems.append(SettingProblem(owner, name, value, what, s.allowed()))
    for rule in rules_of(obj):
        if bad.isdisjoint(rule.names) and not rule.holds(obj):
            values = ", ".join(f"{n}={getattr(obj, n)!r}" for n in rule.names)
            problems.append(SettingProblem(owner, ", ".join(rule.names), None,
                                           f"{values} break the rule", rule.text))
    return problems


def validate(obj: Any) -> None:
    """Check every declared setting and rule of ``obj`` (call it in ``__post_init__``).

    Raises
    ------
    SettingsError
        Listing every problem: owner, setting, value and what is allowed.
    """
    problems = problems_of(obj)
    if problems:
        raise SettingsError(problems)


def member(enum: type[StrEnum], value: Any, *, owner: str, name: str) -> Any:
    """``value`` as a member of ``enum`` (the choices of a setting of a function, which has
    no dataclass to declare it on).

    Raises
    ------
    SettingsError
        ``owner.name='x' is not allowed (allowed: one of ...)``.
    """
    try:
        return enum(value)
    except ValueError:
        allowed = "one of " + ", ".join(repr(m.value) for m in enum)
        raise SettingsError([SettingProblem(owner, name, value, "is not allowed",
                                            allowed)]) from None


# ----------------------------------------------------------------------------
# Definition files
# ----------------------------------------------------------------------------

def fields_of(cls: Any) -> tuple[Field, ...]:
    """The fields of a definition-file table holding the settings of ``cls``."""
    return tuple(s.field() for s in declared(cls).values())


def read_table(table: Any, fields: Sequence[Field], *, path: str | os.PathLike[str],
               where: str = "", extra: Sequence[str] = ()
               ) -> tuple[dict[str, Any], list[DefinitionError]]:
    """:func:`vfs.catalog.read_fields` that collects every problem of the table.

    Returns
    -------
    values : dict
        Attribute name -> SI value of the fields read without problem.
    problems : list of DefinitionError
        One per bad key (unknown, given twice, wrong type, out of range).
    """
    if not isinstance(table, Mapping):
        return {}, [DefinitionError(str(path), where.rstrip("."), "must be a table ([...])")]
    values: dict[str, Any] = {}
    problems: list[DefinitionError] = []
    for key, value in table.items():
        if key in extra:
            continue
        try:
            got = read_fields({key: value}, fields, path=path, where=where, extra=extra)
        except DefinitionError as exc:
            problems.append(exc)
            continue
        for name, v in got.items():
            if name in values:
                keys = next(f.keys() for f in fields if f.name == name)
                problems.append(DefinitionError(str(path), f"{where}{key}",
                                                f"{name} is given twice (in two units)",
                                                "one of " + ", ".join(keys)))
            values[name] = v
    return values, problems


def build(cls: Any, values: Mapping[str, Any], *, path: str | os.PathLike[str],
          where: str, problems: list[DefinitionError],
          labels: Mapping[str, str] | None = None) -> Any:
    """``cls(**values)``; its settings problems appended to ``problems`` as
    :class:`DefinitionError` of ``path`` (None returned then).

    ``labels`` maps an attribute to how the file names it (``warning_ttc`` ->
    ``warning.ttc_s``, relative to ``where``); default the attribute.
    """
    labels = labels or {}
    try:
        return cls(**values)
    except SettingsError as exc:
        for p in exc.problems:
            if p.value is None:  # a rule between fields: named by its table
                problems.append(DefinitionError(str(path), where.rstrip("."), p.problem,
                                                p.allowed))
            else:
                problems.append(DefinitionError(str(path), where + labels.get(p.name, p.name),
                                                f"{p.value!r} {p.problem}", p.allowed))
    except Exception as exc:  # another ParameterError of the class (one message)
        from vfs.errors import ParameterError

        if not isinstance(exc, ParameterError):
            raise
        problems.append(DefinitionError(str(path), where.rstrip("."), str(exc)))
    return None


def raise_problems(problems: Sequence[DefinitionError]) -> None:
    """Raise every problem of a file at once (one: itself; several: DefinitionErrors)."""
    if len(problems) == 1:
        raise problems[0]
    if problems:
        raise DefinitionErrors(list(problems))


# ----------------------------------------------------------------------------
# Command line and documentation
# ----------------------------------------------------------------------------

def cli_kwargs(s: Setting, default: Any = NO_DEFAULT) -> dict[str, Any]:
    """``choices``, ``default`` and ``help`` of an argparse option for setting ``s``
    (``default`` replaces the declared one, e.g. for a command's own default).
    """
    value = s.default if default is NO_DEFAULT else default
    out: dict[str, Any] = {"help": s.doc}
    if s.choices is not None:
        out["choices"] = s.choice_values()
    if value is not NO_DEFAULT:
        out["default"] = str(value) if isinstance(value, StrEnum) else value
        out["help"] = f"{s.doc} (default {out['default']})"
    return out


def _default_text(s: Setting, unit: Unit) -> str:
    value = s.default
    if value is NO_DEFAULT:
        return ""
    if value is None:
        return "absent"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, StrEnum):
        return repr(value.value)
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, int | float):
        number = unit.from_si(float(value))
        text = "inf" if math.isinf(number) else f"{number:.10g}"
        return f"{text} {unit.label}" if unit.label not in ("", "-") else text
    return str(value)


def markdown_table(cls: Any, *, exclude: Sequence[str] = (), include: Sequence[str] = (),
                   rename: Mapping[str, str] | None = None,
                   default_text: Mapping[str, str] | None = None) -> str:
    """The table ``| key | allowed | default | meaning |`` of the settings of ``cls``.

    ``rename`` maps an attribute to the base name of its file key (``warning_ttc`` ->
    ``ttc``); ``exclude`` leaves attributes out, a non-empty ``include`` keeps only those;
    ``default_text`` replaces the default shown (where a file's default differs).
    """
    rename = rename or {}
    default_text = default_text or {}
    lines = ["| key | allowed | default | meaning |", "|---|---|---|---|"]
    for name, s in declared(cls).items():
        if name in exclude or (include and name not in include):
            continue
        f = dataclasses.replace(s.field(), name=rename.get(name, name))
        keys = " or ".join(f"`{k}`" for k in f.keys())
        allowed = " / ".join(s.allowed(u) for u in f.units())
        default = default_text.get(name) or " / ".join(
            dict.fromkeys(_default_text(s, u) for u in f.units()))
        doc = s.doc + (f"; absent: {s.optional_doc}" if s.optional_doc else "")
        lines.append(f"| {keys} | {allowed} | {default} | {doc} |")
    return "\n".join(lines)


__all__ = [
    "METADATA_KEY",
    "NO_DEFAULT",
    "Rule",
    "Setting",
    "build",
    "cli_kwargs",
    "declared",
    "fields_of",
    "markdown_table",
    "member",
    "problems_of",
    "raise_problems",
    "read_table",
    "rules_of",
    "setting",
    "validate",
]
