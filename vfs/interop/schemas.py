"""Validation of OpenSCENARIO and OpenDRIVE files against the official ASAM schemas.

The schemas ship with vfs in ``vfs/data/schemas`` (unmodified ASAM files,
see the README there): OpenSCENARIO XML 1.3.1 and OpenDRIVE 1.7.0.
Validation needs ``xmlschema`` (optional extra ``xosc``).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from typing import Any

from vfs.errors import DataError, DataProblem
from vfs.interop.extra import require_extra

__all__ = ["SCHEMA_DIR", "SCHEMA_FILES", "schema_errors", "validate_file"]

#: Folder of the shipped schemas.
SCHEMA_DIR = Path(__file__).resolve().parent.parent / "data" / "schemas"
#: Root element -> main schema file.
SCHEMA_FILES: dict[str, str] = {"OpenSCENARIO": "OpenSCENARIO_1_3_1.xsd",
                                "OpenDRIVE": "opendrive_17_core.xsd"}


@lru_cache(maxsize=4)
def _schema(file: str) -> Any:
    xmlschema = require_extra("xmlschema")
    return xmlschema.XMLSchema(str(SCHEMA_DIR / file))


def schema_errors(path: str | os.PathLike[str], limit: int = 10) -> list[str]:
    """Schema violations of an OpenSCENARIO or OpenDRIVE file (empty list: valid).

    Parameters
    ----------
    path : path
        ``.xosc`` or ``.xodr`` file; the schema is chosen by its root element.
    limit : int
        At most this many messages.

    Raises
    ------
    DataError
        The file is not XML or neither kind of file.
    MissingExtraError
        xmlschema is not installed.
    """
    file = Path(path)
    try:
        root = ET.parse(file).getroot()
    except (OSError, ET.ParseError) as exc:
        raise DataError(DataProblem(file.name, "", None, None, f"cannot read: {exc}")) from None
    if root.tag not in SCHEMA_FILES:
        raise DataError(DataProblem(file.name, "", None, None,
                                    f"root element {root.tag!r} is neither OpenSCENARIO nor "
                                    "OpenDRIVE"))
    schema = _schema(SCHEMA_FILES[root.tag])
    out = []
    for error in schema.iter_errors(str(file)):
        out.append(f"{error.path}: {error.reason}")
        if len(out) >= limit:
            break
    return out


def validate_file(path: str | os.PathLike[str]) -> None:
    """Raise a DataError listing the schema violations of a file (none: return).

    Parameters
    ----------
    path : path
        ``.xosc`` or ``.xodr`` file.
    """
    errors = schema_errors(path)
    if errors:
        name = Path(path).name
        raise DataError([DataProblem(name, "", None, None, e) for e in errors],
                        header=f"{name} does not validate against the ASAM schema:")
