"""The accident-type catalogue: one name per 3-digit type code, in one place.

Codes follow the three-digit scheme of the German/Austrian accident-type catalogue
("Unfalltypen-Katalog", used by GIDAS): the code names the conflict that led to the accident.
The names below are the descriptions the platform's synthetic scenes are built from
(:data:`vfs.scenarios.catalogue.SCENARIO_TYPES`, docs/data-format.md); they are short English
labels for reports, not a translation of the official catalogue, and only the codes the
platform generates or ships are listed.  Reports show a code as "code name" through
:func:`accident_type_label`; unknown codes keep the bare number.
"""

from __future__ import annotations

import numbers

__all__ = ["ACCIDENT_TYPES", "accident_type_label", "accident_type_name"]

#: Name of each accident-type code the platform generates or ships.
ACCIDENT_TYPES: dict[int, str] = {
    211: "left turn, oncoming",
    241: "head-on, straight road",
    242: "head-on in a bend",
    243: "head-on in a bend, corner cut",
    264: "head-on while overtaking",
    321: "crossing at a junction",
    601: "rear-end",
    799: "other (crash test)",
}


def _code(value: object) -> int | None:
    """The integer code of ``value`` (int, integral float or digit string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real) and float(value).is_integer():
        return int(value)
    if isinstance(value, str) and value.strip().isdigit():
        return int(value.strip())
    return None


def accident_type_name(code: object) -> str | None:
    """Name of an accident-type code, None if the catalogue does not know it.

    >>> accident_type_name(241)
    'head-on, straight road'
    >>> accident_type_name(999) is None
    True
    """
    c = _code(code)
    return None if c is None else ACCIDENT_TYPES.get(c)


def accident_type_label(code: object) -> str:
    """Label "code name" of an accident type for tables and charts.

    Unknown codes and non-codes (group names such as "all" or "unknown") are returned as text.

    >>> accident_type_label(601)
    '601 rear-end'
    >>> accident_type_label("all")
    'all'
    """
    c = _code(code)
    name = None if c is None else ACCIDENT_TYPES.get(c)
    return str(c if c is not None else code) if name is None else f"{c} {name}"
