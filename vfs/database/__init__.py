"""The accident-case database: format (schema 1.0), validation, Parquet/CSV/PCM I/O.

A database is a folder of Parquet tables (``cases``, ``participants``,
``trajectories``, ``reconstruction``) plus ``meta.json``; the schema lives in
:mod:`vfs.database.schema` and is documented in ``docs/data-format.md``.
"""

from __future__ import annotations

from vfs.database.database import Database, default_meta
from vfs.database.example import make_example_database
from vfs.database.io import (
    TargetExistsError,
    detect_format,
    load_any,
    load_csv_folder,
    load_database,
    save_csv_folder,
    save_database,
    select_cases,
)
from vfs.database.pcm import PCM_COLUMNS, PcmDefaults, export_pcm, import_pcm
from vfs.database.schema import SCHEMA_VERSION, TABLES, ColumnSpec, TableSpec, schema_markdown
from vfs.database.validation import validate_database, validate_meta

__all__ = [
    "PCM_COLUMNS",
    "SCHEMA_VERSION",
    "TABLES",
    "ColumnSpec",
    "Database",
    "PcmDefaults",
    "TableSpec",
    "TargetExistsError",
    "default_meta",
    "detect_format",
    "export_pcm",
    "import_pcm",
    "load_any",
    "load_csv_folder",
    "load_database",
    "make_example_database",
    "save_csv_folder",
    "save_database",
    "schema_markdown",
    "select_cases",
    "validate_database",
    "validate_meta",
]
