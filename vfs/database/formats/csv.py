"""The CSV database format: a folder of ``<table>.csv`` files and ``meta.json``
(docs/data-format.md).
"""

from __future__ import annotations

from vfs.database.formats import DatabaseFormat, register_format
from vfs.database.io import load_csv_folder, save_csv_folder

FORMAT = register_format(DatabaseFormat(
    "csv", "CSV files and meta.json, one per table", "cases.csv",
    lambda path, validate: load_csv_folder(path, validate=validate), save_csv_folder,
    priority=1))
