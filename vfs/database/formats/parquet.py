"""The Parquet database format: a folder of ``<table>.parquet`` files and ``meta.json``
(docs/data-format.md); the one format a URL may hold.
"""

from __future__ import annotations

from vfs.database.formats import DatabaseFormat, register_format
from vfs.database.io import load_database, save_database

FORMAT = register_format(DatabaseFormat(
    "parquet", "Parquet files and meta.json (the native format)", "cases.parquet",
    lambda path, validate: load_database(path, validate=validate), save_database, priority=0))
