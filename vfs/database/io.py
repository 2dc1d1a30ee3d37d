"""Reading and writing databases: Parquet folders (the native format) and CSV folders.

A database folder holds ``<table>.parquet`` for the four tables of
:data:`vfs.database.schema.TABLES` and ``meta.json``.  The CSV folder layout
is the same with ``<table>.csv``.  Writes are atomic: the files go into a
temporary sibling folder which then replaces the target.  Case selection
(``where``) is SQL evaluated by duckdb directly on the Parquet files.

A Parquet database can also be read from an fsspec URL (``file://...``,
``memory://...``, ``s3://...`` where the backend package is installed): its
tables are read with pyarrow through the fsspec file system, a selection is
evaluated by duckdb on the cases table and the other tables are read with a
``case_id`` filter.
"""

from __future__ import annotations

import json
import os
import re
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import duckdb
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from vfs.atomic import with_field_metadata, write_folder
from vfs.database.database import Database
from vfs.database.metadata import extra_column_metadata, field_metadata, with_units
from vfs.database.schema import (
    SCHEMA_VERSION,
    TABLE_NAMES,
    TABLES,
    empty_table,
    normalise_table,
    table_from_file_units,
    table_to_file_units,
)
from vfs.database.validation import validate_database
from vfs.errors import DataError, DataProblem
from vfs.threads import compute_threads

META_FILE = "meta.json"
#: Text read as missing in the numeric columns of CSV files.
CSV_NA_VALUES: tuple[str, ...] = ("", "NaN", "nan", "NA", "N/A", "null", "NULL")


# ----------------------------------------------------------------------------
# meta.json
# ----------------------------------------------------------------------------


def read_meta(folder: str | os.PathLike[str]) -> tuple[dict[str, object], list[DataProblem]]:
    """Read ``meta.json`` of a database folder.

    Parameters
    ----------
    folder : path or URL
        Database folder, or its fsspec URL (:func:`is_url`).

    Returns
    -------
    meta : dict
        Parsed contents; empty if the file is missing or unreadable.
    problems : list of DataProblem
        Problems reading the file (missing, invalid JSON, not an object).
    """
    text: str | None
    if is_url(folder):
        fs, root = url_filesystem(os.fspath(folder))
        file = f"{os.fspath(folder).rstrip('/')}/{META_FILE}"
        found = fs.isfile(f"{root}/{META_FILE}")
        read = lambda: fs.cat_file(f"{root}/{META_FILE}").decode("utf-8")  # noqa: E731
    else:
        path = Path(folder) / META_FILE
        file, found = str(path), path.is_file()
        read = lambda: path.read_text(encoding="utf-8")  # noqa: E731
    if not found:
        return {}, [DataProblem("meta", "schema_version", None, None,
                                f"{META_FILE} not found in {folder}")]
    try:
        text = read()
        meta = json.loads(text)
    except (OSError, ValueError) as exc:
        return {}, [DataProblem("meta", "", None, None, f"cannot read {file}: {exc}")]
    if not isinstance(meta, dict):
        return {}, [DataProblem("meta", "", None, None, f"{file} must hold a JSON object")]
    return meta, []


def _meta_for_writing(meta: dict[str, object]) -> str:
    out = dict(meta)
    out.setdefault("schema_version", SCHEMA_VERSION)
    return json.dumps(out, indent=2, sort_keys=True, default=_json_default) + "\n"


def _json_default(value: object) -> object:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"meta value {value!r} is not JSON serialisable")


# ----------------------------------------------------------------------------
# Databases by URL (fsspec)
# ----------------------------------------------------------------------------

#: ``scheme://`` at the start of a database location: an fsspec URL.
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.\-]*://")


def is_url(location: object) -> bool:
    """True for an fsspec URL (``file://``, ``memory://``, ``s3://``, ...), not a plain path.

    >>> is_url("memory://db"), is_url("s3://bucket/db"), is_url("/data/db"), is_url("default")
    (True, True, False, False)
    """
    return isinstance(location, str | os.PathLike) and bool(_URL.match(os.fspath(location)))


def url_filesystem(url: str) -> tuple[Any, str]:
    """The fsspec file system of a database URL and the folder's path on it.

    Raises
    ------
    DataError
        Unknown protocol, or its fsspec backend is not installed (e.g. s3fs
        for ``s3://``).
    """
    import fsspec

    try:
        fs, root = fsspec.core.url_to_fs(url)
    except (ImportError, ValueError) as exc:
        raise DataError(DataProblem("meta", "", None, None,
                                    f"cannot open database URL {url}: {exc}")) from None
    return fs, str(root).rstrip("/")


# ----------------------------------------------------------------------------
# Writing
# ----------------------------------------------------------------------------


def write_folder_atomically(
    path: str | os.PathLike[str], writer: Callable[[Path], None], markers: Iterable[str],
) -> Path:
    """:func:`vfs.atomic.write_folder` for database folders."""
    return write_folder(path, writer, markers, kind="database")


def check_before_write(db: Database, validate: bool) -> Database:
    """The normalised database to write; with ``validate``, refuse an invalid one.

    The returned tables are SI; :func:`tables_for_writing` converts them to
    the units of the files.

    Raises
    ------
    DataError
        Listing every problem when ``validate`` is True and the database is invalid.
    """
    if validate:
        problems = validate_database(db)
        if problems:
            raise DataError(problems, header=f"not writing an invalid database: "
                                             f"{len(problems)} problem(s):")
    return db.normalised()


def tables_for_writing(db: Database) -> dict[str, pd.DataFrame]:
    """The tables of a (normalised, SI) database in the units of the files
    (:func:`vfs.database.schema.table_to_file_units`: angles stored in degrees).
    """
    return {name: table_to_file_units(df, name) for name, df in db.tables().items()}


# ----------------------------------------------------------------------------
# Parquet
# ----------------------------------------------------------------------------


def save_database(db: Database, path: str | os.PathLike[str], *, validate: bool = True) -> Path:
    """Write a database as a folder of Parquet files plus ``meta.json`` (atomically).

    Parameters
    ----------
    db : Database
        The database; tables are normalised (schema dtypes and column order)
        before writing.
    path : path
        Target folder; an existing database folder there is replaced.
    validate : bool
        Refuse to write an invalid database (raise :class:`DataError`).

    Returns
    -------
    Path
        The database folder.
    """
    norm = check_before_write(db, validate)

    def write(folder: Path) -> None:
        for name, df in tables_for_writing(norm).items():
            meta = {**extra_column_metadata(norm.meta, name, df.columns),
                    **field_metadata(df.columns, table=name, stored=True)}
            table = with_field_metadata(pa.Table.from_pandas(df, preserve_index=False), meta)
            pq.write_table(table, folder / f"{name}.parquet")
        (folder / META_FILE).write_text(_meta_for_writing(norm.meta), encoding="utf-8")

    return write_folder_atomically(path, write, [META_FILE, "cases.parquet"])


def unreadable_parquet(table: str, file: object, exc: BaseException) -> DataProblem:
    """The problem of a damaged table file: "file X is not a readable Parquet file".

    Truncated, zero-byte, random-byte or CSV-text files all end here (pyarrow's
    or duckdb's message follows, first line only).
    """
    first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    return DataProblem(table, "", None, None,
                       f"file {file} is not a readable Parquet file ({first})")


def duplicated_columns(table: str, file: object, names: Iterable[str]) -> DataProblem | None:
    """The problem of a table file with two columns of one name (None if there is none).

    pyarrow reads such a file, but a column name then selects two columns;
    the problem names the column and the file.
    """
    counts = Counter(names)
    twice = sorted(n for n, k in counts.items() if k > 1)
    if not twice:
        return None
    shown = ", ".join(repr(n) for n in twice)
    return DataProblem(table, twice[0], None, None,
                       f"file {file}: column {shown} appears twice; a table holds one column "
                       "of each name (rename or drop the copy)")


def _readable_parquet(name: str, file: Any, problems: list[DataProblem],
                      filesystem: Any = None, shown: object = None) -> bool:
    """Read the footer of one table file (cheap); a damaged file becomes a problem, as does
    one with two columns of one name.
    """
    try:
        meta = pq.read_metadata(file, filesystem=filesystem)
        names = meta.schema.to_arrow_schema().names
    except (OSError, ValueError, pa.ArrowException) as exc:
        problems.append(unreadable_parquet(name, shown or file, exc))
        return False
    twice = duplicated_columns(name, shown or file, names)
    if twice is not None:
        problems.append(twice)
        return False
    return True


def _to_pandas(table: pa.Table | pa.RecordBatch) -> pd.DataFrame:
    """``table.to_pandas()`` without the ``attrs`` a file written from pandas stores (its
    ``"attributes"``): the raw frames are converted and checked before the loaders give
    them their SI units (:func:`vfs.database.metadata.with_units`), and pandas deep-copies
    a frame's ``attrs`` into every frame derived from it (each column access).
    """
    frame = table.to_pandas()
    frame.attrs = {}
    return frame


def _si_frame(frame: pd.DataFrame, table: str) -> pd.DataFrame:
    """A table read from a file, normalised, in SI units and with them in ``attrs``."""
    return with_units(table_from_file_units(normalise_table(frame, table), table), table)


def _read_parquet_tables(
    folder: Path, where: str | None, problems: list[DataProblem],
    names: Iterable[str] = TABLE_NAMES,
) -> dict[str, pd.DataFrame]:
    files = {name: folder / f"{name}.parquet" for name in names}
    present = {}
    for name, file in files.items():
        if not file.is_file():
            problems.append(DataProblem(name, "", None, None, f"file {file.name} missing "
                                                              f"in {folder}"))
        elif _readable_parquet(name, file, problems):
            present[name] = file
    if where is None:
        frames = {}
        for name, file in present.items():
            try:
                frames[name] = _to_pandas(pq.read_table(file))
            except (OSError, ValueError, pa.ArrowException) as exc:
                problems.append(unreadable_parquet(name, file, exc))
    elif "cases" not in present:
        frames = {}
    else:
        frames = _select_parquet(present, where, problems)
    return {name: frames.get(name, empty_table(name)) for name in TABLE_NAMES}


def _sql_error(where: str, exc: Exception) -> DataError:
    return DataError(DataProblem(
        "cases", "", None, None,
        f"invalid case selection predicate {where!r}: {exc}".replace("\n", " "),
    ))


def _selection_sql(source: str, where: str) -> str:
    sql = f"SELECT case_id FROM {source} WHERE ({where})"
    try:
        n_statements = len(duckdb.extract_statements(sql))
    except duckdb.Error as exc:
        raise _sql_error(where, exc) from exc
    if n_statements != 1:
        raise _sql_error(where, ValueError("the predicate must be one SQL expression"))
    return sql


def _connect() -> duckdb.DuckDBPyConnection:
    """An in-memory duckdb connection with :func:`vfs.threads.compute_threads` threads
    (``VFS_THREADS``; 1 in a study's worker processes).
    """
    return duckdb.connect(":memory:", config={"threads": compute_threads()})


def _select_parquet(files: dict[str, Path], where: str,
                    problems: list[DataProblem]) -> dict[str, pd.DataFrame]:
    """Read the tables restricted to the cases matching ``where`` (duckdb on Parquet)."""
    con = _connect()
    try:
        cases_file = str(files["cases"])
        try:
            selected = con.sql(
                _selection_sql("read_parquet($cases)", where), params={"cases": cases_file}
            ).to_arrow_table()
        except duckdb.Error as exc:
            raise _sql_error(where, exc) from exc
        con.register("selected_cases", selected)
        # the range of the selected ids lets duckdb skip row groups of files sorted by case
        # (their statistics); it selects nothing more than the IN
        ids = selected.column("case_id")
        bounds = pc.min_max(ids) if ids.null_count == 0 and len(ids) and \
            pa.types.is_integer(ids.type) else None
        between = "" if bounds is None else \
            f"AND case_id BETWEEN {int(bounds['min'].as_py())} AND {int(bounds['max'].as_py())} "
        frames = {}
        for name, file in files.items():
            try:
                table = con.sql(
                    "SELECT * EXCLUDE (file_row_number) "
                    "FROM read_parquet($file, file_row_number = true) "
                    f"WHERE case_id IN (SELECT case_id FROM selected_cases) {between}"
                    "ORDER BY file_row_number",
                    params={"file": str(file)},
                ).to_arrow_table()
            except duckdb.Error as exc:  # a damaged data page behind a readable footer
                problems.append(unreadable_parquet(name, file, exc))
                continue
            frames[name] = _to_pandas(table)
        return frames
    finally:
        con.close()


def _read_parquet_tables_url(
    url: str, where: str | None, problems: list[DataProblem],
    names: Iterable[str] = TABLE_NAMES,
) -> dict[str, pd.DataFrame]:
    """The tables of a Parquet database at an fsspec URL (pyarrow through fsspec).

    With ``where``, duckdb evaluates it on the cases table and every table is
    read with a ``case_id`` filter (row groups outside the selection are
    skipped); rows keep their file order, as :func:`_select_parquet` does.
    """
    fs, root = url_filesystem(url)
    present = {}
    for name in dict.fromkeys(["cases", *names]) if where else names:
        file = f"{root}/{name}.parquet"
        if not fs.isfile(file):
            problems.append(DataProblem(name, "", None, None,
                                        f"file {name}.parquet missing in {url}"))
        elif _readable_parquet(name, file, problems, fs, f"{url.rstrip('/')}/{name}.parquet"):
            present[name] = file

    def read(name: str, filters: Any = None) -> pa.Table | None:
        try:
            return pq.read_table(present[name], filesystem=fs, filters=filters)
        except (OSError, ValueError, pa.ArrowException) as exc:
            problems.append(unreadable_parquet(name, f"{url.rstrip('/')}/{name}.parquet", exc))
            return None

    tables: dict[str, pa.Table | None] = {}
    if where is None:
        tables = {name: read(name) for name in present}
    elif "cases" in present:
        cases = read("cases")
        if cases is not None:
            con = _connect()
            try:
                con.register("vfs_cases", cases)
                selected = con.sql(_selection_sql("vfs_cases", where)).to_arrow_table()
            except duckdb.Error as exc:
                raise _sql_error(where, exc) from exc
            finally:
                con.close()
            ids = selected.column("case_id").combine_chunks()
            keep = pc.field("case_id").isin(ids)
            tables = {name: cases.filter(keep) if name == "cases" else read(name, keep)
                      for name in present if name in names}
    frames = {name: _to_pandas(table) for name, table in tables.items()
              if table is not None}
    return {name: frames.get(name, empty_table(name)) for name in TABLE_NAMES}


def _finish_loading(
    frames: dict[str, pd.DataFrame], meta: dict[str, object], problems: list[DataProblem],
    validate: bool,
) -> Database:
    if any(p.table != "meta" for p in problems):  # a missing or damaged file: its
        raise DataError(problems)  # consequences (orphans, cases without rows) are noise
    db = Database(**frames, meta=meta).normalised()
    db = Database(**{name: table_from_file_units(df, name) for name, df in db.tables().items()},
                  meta=db.meta)
    if validate:
        from vfs.database.checks import check_database, settle

        found = check_database(db)
        errors = found.errors
        if any(p.table == "meta" for p in problems):  # supersedes "meta.json missing"
            errors = [p for p in errors if p.table != "meta"]
        settle(problems + errors, found.warnings)
    return db


def finish_loading(frames: dict[str, pd.DataFrame], meta: dict[str, object],
                   problems: list[DataProblem], validate: bool) -> Database:
    """The database of tables read from files in the file units (:mod:`vfs.database.schema`):
    normalised, converted to SI and, with ``validate``, checked (every problem at once).

    Raises
    ------
    DataError
        ``problems`` of a table (a missing or damaged file), or the problems the checks find.
    """
    return _finish_loading(frames, meta, problems, validate)


def meta_text(meta: dict[str, object]) -> str:
    """``meta.json`` as written with a database."""
    return _meta_for_writing(meta)


def load_database(
    path: str | os.PathLike[str], *, where: str | None = None, validate: bool = True
) -> Database:
    """Load a Parquet database folder.

    Parameters
    ----------
    path : path or URL
        Database folder (``<table>.parquet`` files and ``meta.json``), or its
        fsspec URL (``file:///data/db``, ``memory://db``, ``s3://bucket/db``
        with s3fs installed).
    where : str, optional
        SQL predicate on the cases table, evaluated by duckdb, e.g.
        ``"accident_type = 241 AND road_friction < 0.5"``; the other tables
        are restricted to the selected cases.
    validate : bool
        Validate and raise :class:`DataError` listing every problem.

    Returns
    -------
    Database
        Normalised database in SI units (schema dtypes and column order;
        columns stored in degrees converted to rad).

    Raises
    ------
    DataError
        If the folder or a table file is missing, the predicate is invalid
        SQL, or (with ``validate``) the data violate the schema.
    """
    if is_url(path):
        url = os.fspath(path)
        fs, root = url_filesystem(url)
        if not fs.isdir(root):
            raise DataError(DataProblem("meta", "", None, None, f"database URL {url} "
                                                                "does not exist"))
        meta, problems = read_meta(url)
        frames = _read_parquet_tables_url(url, where, problems)
        return _finish_loading(frames, meta, problems, validate)
    folder = Path(path)
    if not folder.is_dir():
        raise DataError(DataProblem("meta", "", None, None, f"database folder {folder} "
                                                            "does not exist"))
    meta, problems = read_meta(folder)
    frames = _read_parquet_tables(folder, where, problems)
    return _finish_loading(frames, meta, problems, validate)


def load_cases(path: str | os.PathLike[str], where: str | None = None) -> pd.DataFrame:
    """The cases table of a Parquet database (folder or URL), without the other tables.

    Parameters
    ----------
    path : path or URL
        Database folder or its fsspec URL.
    where : str, optional
        SQL predicate selecting cases (duckdb), as in :func:`load_database`.

    Returns
    -------
    pandas.DataFrame
        The selected rows in file order, normalised and in SI units: the
        ``cases`` table :func:`load_database` gives for the same arguments.

    Raises
    ------
    DataError
        The folder or its cases table is missing or unreadable, or the
        predicate is invalid.
    """
    problems: list[DataProblem] = []
    if is_url(path):
        frames = _read_parquet_tables_url(os.fspath(path), where, problems, names=("cases",))
    else:
        folder = Path(path)
        if not folder.is_dir():
            raise DataError(DataProblem("meta", "", None, None, f"database folder {folder} "
                                                                "does not exist"))
        frames = _read_parquet_tables(folder, where, problems, names=("cases",))
    if problems:
        raise DataError(problems)
    return _si_frame(frames["cases"], "cases")


def orphan_problems(path: str | os.PathLike[str]) -> list[DataProblem]:
    """Rows of participants, trajectories or reconstruction whose case is not in ``cases``.

    What :func:`vfs.database.validate_database` reports as orphaned rows, for a
    Parquet database read with a selection (which never loads such rows): duckdb
    anti-joins the files without loading them.

    Parameters
    ----------
    path : path or URL
        Parquet database folder or its fsspec URL.

    Returns
    -------
    list of DataProblem
        One per orphaned case id and table (at most 20 per table), naming table,
        column ``case_id`` and the case id.
    """
    problems: list[DataProblem] = []
    con = _connect()
    try:
        if is_url(path):
            fs, root = url_filesystem(os.fspath(path))
            for name in TABLE_NAMES:
                con.register(name, pq.read_table(f"{root}/{name}.parquet", filesystem=fs,
                                                  columns=["case_id"]))
            source = {name: name for name in TABLE_NAMES}
        else:
            source = {name: f"read_parquet('{Path(path) / f'{name}.parquet'}')"
                      for name in TABLE_NAMES}
        for name in TABLE_NAMES[1:]:
            found = con.sql(
                f"SELECT case_id, count(*) AS n FROM {source[name]} WHERE case_id NOT IN "
                f"(SELECT case_id FROM {source['cases']} WHERE case_id IS NOT NULL) "
                "GROUP BY case_id ORDER BY case_id LIMIT 21").fetchall()
            for case_id, n in found[:20]:
                problems.append(DataProblem(name, "case_id", None, case_id,
                                            f"orphaned rows ({n}): case_id is not in table "
                                            "'cases'"))
            if len(found) > 20:
                problems.append(DataProblem(name, "case_id", None, None,
                                            "... and more orphaned case ids"))
    except (duckdb.Error, OSError, pa.ArrowException):  # a damaged file: loading names it
        return []
    finally:
        con.close()
    return problems


def iter_table(path: str | os.PathLike[str], table: str, case_ids: np.ndarray | None = None,
               *, batch_rows: int = 65536) -> Iterator[pd.DataFrame]:
    """One table of a Parquet database in batches of rows, without holding it whole.

    Parameters
    ----------
    path : path or URL
        Database folder or its fsspec URL.
    table : str
        Table name (:data:`vfs.database.schema.TABLE_NAMES`).
    case_ids : ndarray, optional
        Keep only the rows of these cases.
    batch_rows : int
        Rows read at a time (before the case filter).

    Yields
    ------
    pandas.DataFrame
        Consecutive parts of the table in file order, each normalised and in
        SI units as in :func:`load_database`; at least one (empty for an
        empty table), so the columns are always known.
    """
    keep = None if case_ids is None else pa.array(np.asarray(case_ids))
    if is_url(path):
        fs, root = url_filesystem(os.fspath(path))
        source: Any = fs.open(f"{root}/{table}.parquet", "rb")
    else:
        source = open(Path(path) / f"{table}.parquet", "rb")  # closed below
    shown = f"{os.fspath(path).rstrip('/')}/{table}.parquet"
    try:
        file = pq.ParquetFile(source, pre_buffer=False)
    except (OSError, ValueError, pa.ArrowException) as exc:
        source.close()
        raise DataError(unreadable_parquet(table, shown, exc)) from None
    twice = duplicated_columns(table, shown, file.schema_arrow.names)
    if twice is not None:
        source.close()
        raise DataError(twice)
    with source, file:  # memory: a batch at a time
        empty = True
        for batch in file.iter_batches(batch_size=batch_rows):
            if keep is not None:
                batch = batch.filter(pc.is_in(batch.column("case_id"), value_set=keep))
            empty = False
            yield _si_frame(_to_pandas(batch), table)
        if empty:
            yield _si_frame(_to_pandas(file.schema_arrow.empty_table()), table)


def select_cases(db: Database, where: str) -> Database:
    """Cases of an in-memory database matching an SQL predicate (evaluated by duckdb).

    Parameters
    ----------
    db : Database
        The database.
    where : str
        SQL predicate on the columns of ``db.cases``.

    Returns
    -------
    Database
        :meth:`Database.subset` of the matching cases.

    Raises
    ------
    DataError
        If the predicate is not valid SQL for the cases table.
    """
    con = _connect()
    try:
        con.register("cases", pa.Table.from_pandas(db.cases, preserve_index=False))
        try:
            ids = con.sql(_selection_sql("cases", where)).fetchnumpy()["case_id"]
        except duckdb.Error as exc:
            raise _sql_error(where, exc) from exc
    finally:
        con.close()
    return db.subset(np.asarray(ids))


# ----------------------------------------------------------------------------
# CSV folders
# ----------------------------------------------------------------------------


def save_csv_folder(db: Database, path: str | os.PathLike[str], *, validate: bool = True) -> Path:
    """Write a database as a folder of ``<table>.csv`` files plus ``meta.json`` (atomically).

    Floats are written with full precision (round trip exact), booleans as
    ``True``/``False``, missing values as empty fields.

    Parameters
    ----------
    db : Database
        The database.
    path : path
        Target folder; an existing database folder there is replaced.
    validate : bool
        Refuse to write an invalid database.

    Returns
    -------
    Path
        The folder.
    """
    norm = check_before_write(db, validate)

    def write(folder: Path) -> None:
        for name, df in tables_for_writing(norm).items():
            df.to_csv(folder / f"{name}.csv", index=False, lineterminator="\n")
        (folder / META_FILE).write_text(_meta_for_writing(norm.meta), encoding="utf-8")

    return write_folder_atomically(path, write, [META_FILE, "cases.csv"])


def read_csv_table(file: Path, table: str) -> pd.DataFrame:
    """Read one CSV table: schema string columns as text (``""`` kept), others parsed.

    Parameters
    ----------
    file : Path
        The CSV file.
    table : str
        Table name (key of :data:`vfs.database.schema.TABLES`).

    Returns
    -------
    pandas.DataFrame
        Raw table (not yet normalised).
    """
    header = pd.read_csv(file, nrows=0).columns
    text_columns = {c.name for c in TABLES[table].columns if c.kind == "str"}
    return pd.read_csv(
        file,
        dtype={c: "str" for c in header if c in text_columns},
        keep_default_na=False,
        na_values={c: list(CSV_NA_VALUES) for c in header if c not in text_columns},
    )


def load_csv_folder(path: str | os.PathLike[str], *, validate: bool = True) -> Database:
    """Load a CSV database folder written by :func:`save_csv_folder`.

    Parameters
    ----------
    path : path
        Folder with ``<table>.csv`` files and ``meta.json``.
    validate : bool
        Validate and raise :class:`DataError` listing every problem.

    Returns
    -------
    Database
        Normalised database in SI units; identical (dtypes included) to the
        database the folder was written from, except that the columns stored
        in degrees went through one rounded conversion each way.
    """
    folder = Path(path)
    if not folder.is_dir():
        raise DataError(DataProblem("meta", "", None, None, f"CSV folder {folder} does "
                                                            "not exist"))
    meta, problems = read_meta(folder)
    frames = {}
    for name in TABLE_NAMES:
        file = folder / f"{name}.csv"
        if not file.is_file():
            problems.append(DataProblem(name, "", None, None, f"file {file.name} missing "
                                                              f"in {folder}"))
            frames[name] = empty_table(name)
            continue
        try:
            frames[name] = read_csv_table(file, name)
        except (OSError, ValueError) as exc:
            problems.append(DataProblem(name, "", None, None, f"cannot read {file}: {exc}"))
            frames[name] = empty_table(name)
    return _finish_loading(frames, meta, problems, validate)
