"""The accident-case database: format (schema 1.0), validation, Parquet/CSV/PCM I/O.

A database is a folder of Parquet tables (``cases``, ``participants``,
``trajectories``, ``reconstruction``) plus ``meta.json``; the schema lives in
:mod:`vfs.database.schema` and is documented in ``docs/data-format.md``.
:func:`open_database` opens the bundled database (``"default"``) or a folder
in any supported format.
"""

from __future__ import annotations

from vfs.database.database import Database, default_meta
from vfs.database.io import (
    load_csv_folder,
    load_database,
    save_csv_folder,
    save_database,
    select_cases,
)
from vfs.database.pcm import PCM_COLUMNS, PcmDefaults, export_pcm, import_pcm
from vfs.database.schema import SCHEMA_VERSION, TABLES, ColumnSpec, TableSpec, schema_markdown
from vfs.database.source import (
    BUNDLED_DATABASES,
    FORMATS,
    DatabaseSelection,
    bundled_database_path,
    database_location,
    database_reference,
    detect_format,
    load_any,
    open_database,
    resolve_database_path,
    select_database,
)
from vfs.database.validation import validate_database, validate_meta
from vfs.errors import TargetExistsError

__all__ = [
    "BUNDLED_DATABASES",
    "FORMATS",
    "PCM_COLUMNS",
    "SCHEMA_VERSION",
    "TABLES",
    "ColumnSpec",
    "Database",
    "DatabaseSelection",
    "PcmDefaults",
    "TableSpec",
    "TargetExistsError",
    "bundled_database_path",
    "database_location",
    "database_reference",
    "default_meta",
    "detect_format",
    "export_pcm",
    "import_pcm",
    "load_any",
    "load_csv_folder",
    "load_database",
    "open_database",
    "resolve_database_path",
    "save_csv_folder",
    "save_database",
    "schema_markdown",
    "select_cases",
    "select_database",
    "validate_database",
    "validate_meta",
]
