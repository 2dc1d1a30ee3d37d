"""Names shared by every part of a study: the baseline label, equip rules, files, columns."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

import numpy as np

from vfs.errors import ParameterError

#: Value of the ``system`` column for the runs without a system (recorded behaviour).
BASELINE = "baseline"

class Equip(StrEnum):
    """Which vehicles carry the system in the treatment runs (``--equip``)."""

    ONE = "1"
    TWO = "2"
    BOTH = "both"


#: Which vehicles carry the system: ``--equip`` value -> equipped flags of (vehicle 1, 2).
EQUIP_RULES: dict[str, tuple[bool, bool]] = {
    Equip.ONE: (True, False),
    Equip.TWO: (False, True),
    Equip.BOTH: (True, True),
}

#: Default number of cases per chunk.
DEFAULT_CHUNK_SIZE = 200

MANIFEST_FILE = "study.json"
CASES_FILE = "cases.parquet"
RUNS_FILE = "runs.parquet"
CHUNK_DIR = "chunks"
#: Value of ``study.json["format"]``; identifies a study folder.
MANIFEST_FORMAT = "vfs-study"
MANIFEST_VERSION = 1

#: Manifest entries that must match for ``resume`` (the inputs that determine the results).
RESUME_KEYS: tuple[str, ...] = ("data_hash", "case_ids_hash", "system_names",
                                "system_definitions", "equip", "seed", "chunk_size",
                                "impact_parameters", "params")

#: Columns every runs table starts with (then those of :func:`results_table`, then events).
KEY_COLUMNS: tuple[str, ...] = ("case_id", "system", "accident_type", "weight", "error",
                                "equipped1", "equipped2")

#: Integer columns; stored as pandas' nullable ``Int64`` (NA for failed runs).
INT_COLUMNS: tuple[str, ...] = ("cp_rule",)

#: Boolean columns; stored as pandas' nullable ``boolean`` (NA for failed runs).
BOOL_COLUMNS: tuple[str, ...] = ("collided", "avoided", "at_rest1", "at_rest2",
                                 "secondary_collision", "equipped1", "equipped2")




def equipped_flags(equip: str | int, n: int) -> np.ndarray:
    """Equipped vehicles (N, 2) bool for an ``equip`` rule (:data:`EQUIP_RULES`)."""
    key = str(equip)
    if key not in EQUIP_RULES:
        raise ParameterError(f"equip={equip!r}; use one of {', '.join(EQUIP_RULES)}")
    return np.tile(np.asarray(EQUIP_RULES[key], dtype=bool), (n, 1))



def chunk_path(folder: Path, index: int) -> Path:
    """File of chunk ``index`` in a study folder."""
    return folder / CHUNK_DIR / f"chunk_{index:06d}.parquet"


__all__ = [
    "BASELINE",
    "BOOL_COLUMNS",
    "CASES_FILE",
    "CHUNK_DIR",
    "DEFAULT_CHUNK_SIZE",
    "EQUIP_RULES",
    "Equip",
    "INT_COLUMNS",
    "KEY_COLUMNS",
    "MANIFEST_FILE",
    "MANIFEST_FORMAT",
    "MANIFEST_VERSION",
    "RESUME_KEYS",
    "RUNS_FILE",
    "chunk_path",
    "equipped_flags",
]
