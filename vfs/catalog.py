"""The catalogue: the data files users read and write, in ``adas/`` and ``scenarios/``.

The repository holds two folders of data beside the code: ``adas/`` (the AEB
systems as TOML definitions, :mod:`vfs.adas.definition`) and ``scenarios/``
(the generator's presets, the accident-type scene designs and the bundled
databases).  They are the one source of these numbers; vfs reads them through
this module only:

* in a clone or an editable install, the folders at the repository root
  (beside the ``vfs`` package, recognised by the ``pyproject.toml`` next to
  them);
* in an installed wheel, the copies that ``setup.py`` (its ``build_py`` step)
  puts into the package at build time, ``vfs/data/catalog/<folder>``, found
  with :mod:`importlib.resources`.

Nothing in these folders is Python that vfs imports (``adas/example_controller.py``
is an example users load with ``--plugin``).

The module also holds what every definition file shares: :func:`read_toml`
and the unit-suffixed fields (:class:`Field`, :func:`read_fields`): a key names
its unit (``range_m``, ``latency_s``, ``field_of_view_deg``, ``min_speed_kmh``),
the value is converted to SI at this edge and checked against the field's
allowed range; every problem raises :class:`vfs.errors.DefinitionError` naming
the file, the field and the allowed range.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from vfs.errors import DefinitionError, ParameterError
from vfs.units import KMH_PER_MS

#: The catalogue folders at the repository root (and inside a wheel).
CATALOGS: tuple[str, ...] = ("adas", "scenarios")

#: Where a wheel holds the catalogue folders, below the package ``vfs``.
PACKAGED: tuple[str, ...] = ("data", "catalog")


def checkout_root() -> Path | None:
    """The repository root when vfs runs from a clone or an editable install, else None.

    It is the folder holding the package ``vfs`` that also holds ``pyproject.toml``
    and a catalogue folder.
    """
    package = Path(str(resources.files("vfs")))
    root = package.parent
    if (root / "pyproject.toml").is_file() and any((root / c).is_dir() for c in CATALOGS):
        return root
    return None


def catalog_root(catalog: str) -> Path:
    """The folder of one catalogue (``"adas"`` or ``"scenarios"``) of this install.

    A clone's (or editable install's) repository folder; else the copy inside the
    installed package (``vfs/data/catalog/<catalog>``, read with :mod:`importlib.resources`).

    Raises
    ------
    ParameterError
        For a name that is not one of :data:`CATALOGS`, or an install that lacks the
        folder (a wheel built without ``setup.py``'s ``build_py`` step).
    """
    if catalog not in CATALOGS:
        raise ParameterError(f"unknown catalogue {catalog!r}; known: {', '.join(CATALOGS)}")
    root = checkout_root()
    if root is not None and (root / catalog).is_dir():
        return root / catalog
    packaged = Path(str(resources.files("vfs").joinpath(*PACKAGED, catalog)))
    if not packaged.is_dir():
        raise ParameterError(f"this install of vfs has no {catalog}/ catalogue (looked in "
                             f"{packaged}); reinstall it from a wheel built by setup.py")
    return packaged


def catalog_path(catalog: str, *parts: str) -> Path:
    """A file or folder of a catalogue, e.g. ``catalog_path("scenarios", "databases")``."""
    return catalog_root(catalog).joinpath(*parts)


def project_path(catalog: str, *parts: str,
                 cwd: str | os.PathLike[str] | None = None) -> Path | None:
    """The file or folder of the user's project catalogue (``./<catalog>/...``) if present.

    Parameters
    ----------
    catalog : str
        ``"adas"`` or ``"scenarios"``.
    *parts : str
        Below the folder.
    cwd : path, optional
        The project folder; default the current working directory.
    """
    path = Path(cwd if cwd is not None else os.getcwd(), catalog, *parts)
    return path if path.exists() else None


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The contents of a TOML file.

    Raises
    ------
    DefinitionError
        If the file is missing or not valid TOML (with tomllib's line and column).
    """
    p = Path(path)
    try:
        with p.open("rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise DefinitionError(str(p), "", "no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise DefinitionError(str(p), "", f"not valid TOML: {exc}") from None


# ----------------------------------------------------------------------------
# Unit-suffixed fields
# ----------------------------------------------------------------------------

def _same(value: float) -> float:
    return value


@dataclass(frozen=True)
class Unit:
    """A unit a key may name: its key suffix, its label and the conversions to SI.

    Attributes
    ----------
    suffix : str
        What the key ends with after an underscore (``"kmh"`` in ``min_speed_kmh``);
        empty for dimensionless values.
    label : str
        For messages (``"km/h"``).
    to_si, from_si : callable
        Conversions of a value in this unit to SI and back.
    """

    suffix: str
    label: str
    to_si: Callable[[float], float] = _same
    from_si: Callable[[float], float] = _same


def _kmh_to_ms(value: float) -> float:
    return value / KMH_PER_MS


def _ms_to_kmh(value: float) -> float:
    return value * KMH_PER_MS


#: The units a key may name per physical quantity (the first is the usual one).
QUANTITY_UNITS: dict[str, tuple[Unit, ...]] = {
    "length": (Unit("m", "m"),),
    "time": (Unit("s", "s"),),
    "speed": (Unit("kmh", "km/h", _kmh_to_ms, _ms_to_kmh), Unit("mps", "m/s")),
    "angle": (Unit("deg", "deg", math.radians, math.degrees), Unit("rad", "rad")),
    "acceleration": (Unit("mps2", "m/s^2"),),
    "angular_rate": (Unit("radps", "rad/s"),),
    "degrees": (Unit("deg", "deg"),),  # kept in degrees inside (e.g. noise of a PDOF)
    "jerk": (Unit("mps3", "m/s^3"),),
    "rate": (Unit("per_s", "1/s"),),
    "ratio": (Unit("", "-"),),
}


@dataclass(frozen=True)
class Field:
    """One field of a definition file.

    Attributes
    ----------
    name : str
        The attribute it sets (SI value); the key in the file is ``name_<suffix>``
        for one of the units of ``quantity`` (``name`` alone for a ratio or text).
    quantity : str
        A key of :data:`QUANTITY_UNITS`, or ``"text"``, ``"bool"``, ``"int"``, ``"pair"``
        (a list of two numbers of ``pair_of``, low <= high).
    lo, hi : float
        Allowed range in SI; ``lo_open`` / ``hi_open`` exclude the bound.
    choices : tuple of str
        Allowed values of a text field.
    pair_of : str
        Quantity of the two numbers of a pair.
    ordered : bool
        A pair is a range (low <= high); False for two values, one per participant.
    """

    name: str
    quantity: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()
    pair_of: str = ""
    ordered: bool = True

    def units(self) -> tuple[Unit, ...]:
        """The units its key may name."""
        q = self.pair_of if self.quantity == "pair" else self.quantity
        return QUANTITY_UNITS.get(q, (Unit("", ""),))

    def keys(self) -> tuple[str, ...]:
        """The keys it may have in a file."""
        return tuple(f"{self.name}_{u.suffix}" if u.suffix else self.name for u in self.units())

    def allowed(self, unit: Unit) -> str:
        """The allowed range in ``unit``, e.g. ``(0, 360] deg``."""
        if self.quantity == "text":
            return "one of " + ", ".join(repr(c) for c in self.choices) if self.choices \
                else "text"
        if self.quantity == "bool":
            return "true or false"
        lo, hi = unit.from_si(self.lo), unit.from_si(self.hi)
        text = (f"{'(' if self.lo_open else '['}{_num(lo)}, {_num(hi)}"
                f"{')' if self.hi_open else ']'}")
        if self.quantity == "int":
            text = "an integer in " + text
        elif self.quantity == "pair":
            text = ("[low, high], low <= high, each in " if self.ordered
                    else "[participant 1, participant 2], each in ") + text
        return f"{text} {unit.label}" if unit.label not in ("", "-") else text


def _num(value: float) -> str:
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.10g}"


def _in_range(f: Field, v: float) -> bool:
    if math.isnan(v):
        return False
    lo_ok = v > f.lo if f.lo_open else v >= f.lo
    hi_ok = v < f.hi if f.hi_open else v <= f.hi
    return lo_ok and hi_ok


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _convert(f: Field, key: str, unit: Unit, value: Any, path: str, where: str) -> Any:
    name = f"{where}{key}"
    if f.quantity == "text":
        if not isinstance(value, str) or (f.choices and value not in f.choices):
            raise DefinitionError(path, name, f"{value!r} is not allowed", f.allowed(unit))
        return value
    if f.quantity == "bool":
        if not isinstance(value, bool):
            raise DefinitionError(path, name, f"{value!r} is not a boolean", f.allowed(unit))
        return value
    if f.quantity == "pair":
        if not (isinstance(value, list) and len(value) == 2 and all(map(_number, value))):
            raise DefinitionError(path, name, f"{value!r} is not a pair of numbers",
                                  f.allowed(unit))
        pair = (unit.to_si(float(value[0])), unit.to_si(float(value[1])))
        if not (all(_in_range(f, v) for v in pair) and (pair[0] <= pair[1] or not f.ordered)):
            raise DefinitionError(path, name, f"{value!r} is out of range", f.allowed(unit))
        return pair
    if f.quantity == "int":
        if not (isinstance(value, int) and not isinstance(value, bool)) \
                or not _in_range(f, value):
            raise DefinitionError(path, name, f"{value!r} is out of range", f.allowed(unit))
        return value
    if not _number(value):
        raise DefinitionError(path, name, f"{value!r} is not a number", f.allowed(unit))
    si = unit.to_si(float(value))
    if not _in_range(f, si):
        raise DefinitionError(path, name, f"{value!r} is out of range", f.allowed(unit))
    return si


def read_fields(table: Any, fields: Sequence[Field], *, path: str | os.PathLike[str],
                where: str = "", extra: Sequence[str] = ()) -> dict[str, Any]:
    """The SI values of the fields present in one table of a definition file.

    Parameters
    ----------
    table : mapping
        The table as :mod:`tomllib` read it.
    fields : sequence of Field
    path : path
        The file, for messages.
    where : str
        The table's dotted prefix for messages (``"aeb.sensor."``).
    extra : sequence of str
        Further keys the caller reads itself (sub-tables, names).

    Returns
    -------
    dict
        Attribute name -> value in SI (absent fields are left out).

    Raises
    ------
    DefinitionError
        A table that is not a table, an unknown key (the message lists the known
        ones), a field given in two units, a wrong type or a value out of range.
    """
    p = str(path)
    if not isinstance(table, Mapping):
        raise DefinitionError(p, where.rstrip("."), "must be a table ([...])")
    by_key = {}
    for f in fields:
        for key, unit in zip(f.keys(), f.units(), strict=True):
            by_key[key] = (f, unit)
    unknown = [k for k in table if k not in by_key and k not in extra]
    if unknown:
        known = ", ".join(list(by_key) + list(extra))
        raise DefinitionError(p, f"{where}{unknown[0]}", "unknown field", f"fields: {known}")
    out: dict[str, Any] = {}
    for key, value in table.items():
        if key in extra:
            continue
        f, unit = by_key[key]
        if f.name in out:
            raise DefinitionError(p, f"{where}{key}", f"{f.name} is given twice (in two units)",
                                  "one of " + ", ".join(f.keys()))
        out[f.name] = _convert(f, key, unit, value, p, where)
    return out


def sub_table(table: Mapping[str, Any], key: str, *, path: str | os.PathLike[str],
              where: str = "") -> Mapping[str, Any] | None:
    """The sub-table ``key`` of ``table`` (None when absent).

    Raises
    ------
    DefinitionError
        If ``key`` is there but not a table.
    """
    value = table.get(key)
    if value is None:
        return None
    if not isinstance(value, Mapping):
        raise DefinitionError(str(path), f"{where}{key}", "must be a table ([...])")
    return value


__all__ = [
    "CATALOGS",
    "PACKAGED",
    "QUANTITY_UNITS",
    "Field",
    "Unit",
    "catalog_path",
    "catalog_root",
    "checkout_root",
    "project_path",
    "read_fields",
    "read_toml",
    "sub_table",
]
