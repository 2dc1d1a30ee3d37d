"""The PreCrash-Matrix (PCM) CSV format (docs/data-format.md, :mod:`vfs.database.pcm`)."""

from __future__ import annotations

from vfs.database.formats import DatabaseFormat, register_format
from vfs.database.pcm import export_pcm, import_pcm

FORMAT = register_format(DatabaseFormat(
    "pcm", "PreCrash-Matrix CSV folder (participant_data.csv, ...)", "participant_data.csv",
    lambda path, validate: import_pcm(path, validate=validate), export_pcm, priority=2))
