"""Atomic writes: a file or folder appears whole or not at all.

Every writer goes through a temporary sibling (same folder, so that
:func:`os.replace` is an atomic rename on POSIX and Windows) and renames it
into place; a crash or a full disk leaves the previous file (or none), never
a half-written one.  All of vfs writes its outputs through this module.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import uuid
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vfs.errors import DataError, DataProblem, TargetExistsError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    from matplotlib.figure import Figure

PathLike = str | os.PathLike[str]


def json_default(value: object) -> object:
    """``json.dumps(default=...)`` for numpy scalars and arrays, paths and other objects.

    numpy scalars become Python scalars, arrays lists, anything else its
    ``str()`` (a record of what was used, never an error in a report).
    """
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def strict_json(obj: Any) -> Any:
    """``obj`` with NaN and infinities replaced by None (strict JSON has no NaN)."""
    if isinstance(obj, dict):
        return {k: strict_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [strict_json(v) for v in obj]
    if isinstance(obj, float | np.floating) and not math.isfinite(float(obj)):
        return None
    return obj


def write_atomic(path: PathLike, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on a temporary sibling of ``path``, then rename it to ``path``.

    Parameters
    ----------
    path : path
        Target file; its folder is created.
    write : callable
        ``write(tmp_path)`` writes the whole file; the temporary name keeps
        the target's suffix, so writers that choose a format by suffix work.

    Returns
    -------
    Path
        The target.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    # created like open() creates files (mode 0o666 less the umask), not 0o600 as mkstemp
    tmp = str(target.parent / f".{target.stem}.tmp-{uuid.uuid4().hex}{target.suffix}")
    os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
    try:
        write(Path(tmp))
        os.replace(tmp, target)
    except OSError as exc:  # pyarrow's "Error writing bytes to file ... [errno 28]": name it
        if exc.filename is None:
            raise _naming(exc, target) from exc
        raise
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return target


def _naming(exc: OSError, target: Path) -> OSError:
    """``exc`` with the target file as its filename (and the errno pyarrow puts in the text)."""
    code = exc.errno
    if code is None:
        found = re.search(r"errno (\d+)", str(exc), re.IGNORECASE)
        code = int(found.group(1)) if found else None
    text = os.strerror(code) if code else str(exc).splitlines()[0]
    if code:
        return OSError(code, text, str(target))
    named = OSError(f"{text} (writing {target})")
    named.filename = str(target)
    return named


def write_text(path: PathLike, text: str) -> Path:
    """Write UTF-8 text atomically."""
    return write_atomic(path, lambda p: p.write_text(text, encoding="utf-8"))


def write_json(path: PathLike, data: Any, *, strict: bool = True) -> Path:
    """Write JSON atomically (indented, numpy-aware; NaN as null when ``strict``)."""
    payload = strict_json(data) if strict else data
    return write_text(path, json.dumps(payload, indent=2, default=json_default) + "\n")


def write_table(path: PathLike, df: pd.DataFrame,
                field_metadata: Mapping[str, Mapping[str, str]] | None = None) -> Path:
    """Write a table atomically as Parquet (``.parquet``/``.pq``) or CSV (``.csv``).

    Parameters
    ----------
    path : path
        Target file.
    df : pandas.DataFrame
        The table (its index is not written).
    field_metadata : mapping, optional
        Per column, key-value pairs (e.g. ``unit``, ``description``) written as Parquet
        field metadata (UTF-8); ignored for CSV.

    Raises
    ------
    DataError
        For any other suffix.
    """
    suffix = Path(path).suffix.lower()
    if suffix in (".parquet", ".pq"):
        if not field_metadata:
            return write_atomic(path, lambda p: df.to_parquet(p, index=False))
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = with_field_metadata(pa.Table.from_pandas(df, preserve_index=False),
                                    field_metadata)
        return write_atomic(path, lambda p: pq.write_table(table, p))
    if suffix == ".csv":
        return write_atomic(path, lambda p: df.to_csv(p, index=False))
    raise DataError(DataProblem(Path(path).name, "", None, None,
                                f"unknown table format {suffix!r} (use .parquet or .csv)"))


def with_field_metadata(table: Any, field_metadata: Mapping[str, Mapping[str, str]]) -> Any:
    """A pyarrow Table whose fields carry ``field_metadata`` (per column, str -> str)."""
    import pyarrow as pa

    fields = []
    for f in table.schema:
        meta = field_metadata.get(f.name)
        if meta:
            merged = dict(f.metadata or {})
            merged.update({k.encode(): str(v).encode() for k, v in meta.items()})
            f = f.with_metadata(merged)
        fields.append(f)
    return table.cast(pa.schema(fields, metadata=table.schema.metadata))


def write_figure(path: PathLike, fig: Figure, **savefig: Any) -> Path:
    """Save a matplotlib figure atomically (format from the suffix)."""
    fmt = Path(path).suffix.lstrip(".") or None
    return write_atomic(path, lambda p: fig.savefig(p, format=fmt, **savefig))


def write_folder(path: PathLike, writer: Callable[[Path], None], markers: Iterable[str],
                 kind: str = "database") -> Path:
    """Write a folder through a temporary sibling folder, then swap it into place.

    Parameters
    ----------
    path : path
        Target folder.  If it exists it must be empty or contain one of
        ``markers`` (i.e. be a folder of the same kind), else nothing is
        written.
    writer : callable
        ``writer(tmp_folder)`` writes all files into the (empty) temporary folder.
    markers : iterable of str
        File names that identify a folder this function may replace.
    kind : str
        What the folder is, for the message when it may not be replaced.

    Returns
    -------
    Path
        The target folder.

    Raises
    ------
    TargetExistsError
        If ``path`` is a file or a non-empty folder of another kind.
    """
    target = Path(path)
    if target.exists():
        if not target.is_dir():
            raise TargetExistsError(f"{target} exists and is not a folder")
        if any(target.iterdir()) and not any((target / m).exists() for m in markers):
            raise TargetExistsError(
                f"{target} is a non-empty folder that does not look like a {kind}; "
                "refusing to replace it"
            )
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.parent / f".{target.name}.tmp-{uuid.uuid4().hex}"
    tmp.mkdir()
    try:
        writer(tmp)
        if target.exists():
            old = target.parent / f".{target.name}.old-{uuid.uuid4().hex}"
            os.replace(target, old)
            try:
                os.replace(tmp, target)
            except BaseException:
                os.replace(old, target)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return target


__all__ = [
    "json_default",
    "strict_json",
    "write_atomic",
    "write_figure",
    "write_folder",
    "write_json",
    "write_table",
    "write_text",
]
