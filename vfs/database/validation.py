"""Validation of an accident-case database against the schema.

:func:`validate_database` returns every problem as a
:class:`vfs.errors.DataProblem` naming table, column, row, case id and the
allowed range.  All column checks are generated from
:data:`vfs.database.schema.TABLES`; the cross-table checks (orphans,
participants 1 and 2, trajectories per participant, time axis, collision vs
reconstruction) are written out below.  Checks are vectorised with pandas;
the only per-row loop runs over the participants table (two rows per case) to
reuse :func:`vfs.physics.vehicle.validate_vehicle_values` for the layout.

To keep the report readable and fast on large tables, at most
:data:`MAX_REPORTED_ROWS` rows are listed per check; one more problem then
states how many further rows have the same problem.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

import numpy as np
import pandas as pd

from vfs.database.database import Database, python_scalar
from vfs.database.schema import (
    MAX_SAMPLE_SPACING,
    MEASURABLE_COLUMNS,
    MIN_TRAJECTORY_SAMPLES,
    OUTCOME_MEASUREMENT,
    OUTCOME_RECONSTRUCTION,
    SCHEMA_VERSION,
    SUPPORTED_SCHEMA_VERSIONS,
    TABLES,
    ColumnSpec,
    TableSpec,
)
from vfs.errors import DataProblem
from vfs.physics.vehicle import PARAMETER_RANGES, validate_vehicle_values

#: Largest number of rows reported per check (a summary problem counts the rest).
MAX_REPORTED_ROWS = 20
#: Tolerance of the sample-spacing check [s] (float round-off of time axes).
SPACING_TOLERANCE = 1e-9

_TRUE_FALSE = frozenset({"true", "false", "1", "0", "yes", "no"})


class _Report:
    """Collects problems; lists at most MAX_REPORTED_ROWS rows per check."""

    def __init__(self) -> None:
        self.problems: list[DataProblem] = []

    def add(self, table: str, column: str, row: int | None, case_id: object, message: str) -> None:
        self.problems.append(DataProblem(table, column, row, case_id, message))

    def rows(
        self, table: str, column: str, df: pd.DataFrame, mask: np.ndarray | pd.Series,
        message: str | list[str] | np.ndarray, summary: str,
    ) -> None:
        """One problem per True row of ``mask``; ``message`` is one text or one per True row."""
        positions = np.flatnonzero(np.asarray(mask, dtype=bool))
        if positions.size == 0:
            return
        case_ids = _case_ids_at(df, positions[:MAX_REPORTED_ROWS])
        for k, (pos, cid) in enumerate(zip(positions[:MAX_REPORTED_ROWS], case_ids, strict=True)):
            text = message if isinstance(message, str) else str(message[k])
            self.add(table, column, int(pos), cid, text)
        if positions.size > MAX_REPORTED_ROWS:
            self.add(table, column, None, None,
                     f"... and {positions.size - MAX_REPORTED_ROWS} more rows: {summary}")

    def cases(self, table: str, column: str, case_ids: np.ndarray, message: str) -> None:
        """One problem per case (no row), capped like :meth:`rows`."""
        for cid in case_ids[:MAX_REPORTED_ROWS]:
            self.add(table, column, None, python_scalar(cid), message)
        if len(case_ids) > MAX_REPORTED_ROWS:
            self.add(table, column, None, None,
                     f"... and {len(case_ids) - MAX_REPORTED_ROWS} more cases: {message}")


#: Added to a sample spacing 100 times the allowed one: the likely cause.
_UNIT_HINT = "; time in milliseconds, or a date? (t is in seconds)"


def _case_ids_at(df: pd.DataFrame, positions: np.ndarray) -> list[object]:
    if "case_id" not in df.columns:
        return [None] * len(positions)
    values = df["case_id"].to_numpy()[positions]
    return [None if _isnan(v) else python_scalar(v) for v in values]


def _isnan(value: object) -> bool:
    try:
        return bool(pd.isna(value))
    except (TypeError, ValueError):
        return False


def _fmt(value: object) -> str:
    if isinstance(value, float | np.floating):
        return f"{float(value):g}"
    return repr(python_scalar(value))


# ----------------------------------------------------------------------------
# Column checks, generated from the schema
# ----------------------------------------------------------------------------


def _numeric_values(series: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """Float values of a column and the mask of non-numeric entries."""
    if pd.api.types.is_numeric_dtype(series.dtype) or series.dtype == bool:
        return series.to_numpy(dtype=float, na_value=np.nan), np.zeros(len(series), bool)
    numeric = pd.to_numeric(series, errors="coerce")
    values = numeric.to_numpy(dtype=float, na_value=np.nan)
    return values, (np.isnan(values) & series.notna().to_numpy())


def _check_numeric(report: _Report, table: str, df: pd.DataFrame, col: ColumnSpec) -> None:
    series = df[col.name]
    values, non_numeric = _numeric_values(series)
    allowed = col.allowed_text()
    what = ("is not a number: case ids are integers (number the cases; text belongs in "
            "cases.description)" if col.name == "case_id" else f"is not a number (allowed "
            f"{allowed})")
    report.rows(
        table, col.name, df, non_numeric,
        [f"value {python_scalar(v)!r} {what}"
         for v in series.to_numpy()[non_numeric][:MAX_REPORTED_ROWS]],
        f"not a number (allowed {allowed})",
    )
    missing = np.isnan(values) & ~non_numeric
    if not col.nullable:
        report.rows(table, col.name, df, missing,
                    f"missing value (NaN) where a value is required (allowed {allowed})",
                    "missing values")
    infinite = np.isinf(values)
    report.rows(table, col.name, df, infinite,
                f"value is not finite (allowed {allowed})", "infinite values")
    finite = np.isfinite(values)
    if col.kind == "int":
        with np.errstate(invalid="ignore"):
            fractional = finite & (values != np.round(values))
        report.rows(table, col.name, df, fractional,
                    [f"{col.name}={v:g} is not an integer"
                     for v in values[fractional][:MAX_REPORTED_ROWS]],
                    "not an integer")
    if col.allowed:
        bad = finite & ~np.isin(values, np.asarray(col.allowed, dtype=float))
        report.rows(table, col.name, df, bad,
                    [f"{col.name}={v:g} is not one of {allowed}"
                     for v in values[bad][:MAX_REPORTED_ROWS]],
                    f"not one of {allowed}")
    if col.has_range:
        with np.errstate(invalid="ignore"):
            below = (values < col.lo) | ((values == col.lo) & col.lo_open)
            above = (values > col.hi) | ((values == col.hi) & col.hi_open)
        bad = finite & (below | above)
        messages = []
        for v in col.to_file(values[bad][:MAX_REPORTED_ROWS]):  # as in the files
            if v < 0 <= col.lo:
                messages.append(f"negative value {col.name}={v:g} (allowed range {allowed})")
            else:
                messages.append(f"{col.name}={v:g} outside the allowed range {allowed}")
        report.rows(table, col.name, df, bad, messages, f"outside the allowed range {allowed}")


def _check_bool(report: _Report, table: str, df: pd.DataFrame, col: ColumnSpec) -> None:
    series = df[col.name]
    if series.dtype == bool:
        return
    missing = series.isna().to_numpy()
    if pd.api.types.is_numeric_dtype(series.dtype):
        ok = np.isin(series.to_numpy(dtype=float, na_value=np.nan), (0.0, 1.0))
    else:
        ok = series.astype(str).str.strip().str.lower().isin(_TRUE_FALSE).to_numpy()
    report.rows(table, col.name, df, missing,
                "missing value where True or False is required", "missing values")
    bad = ~ok & ~missing
    report.rows(table, col.name, df, bad,
                [f"value {python_scalar(v)!r} is not a boolean (allowed {{True, False}})"
                 for v in series.to_numpy()[bad][:MAX_REPORTED_ROWS]],
                "not a boolean")


def _check_str(report: _Report, table: str, df: pd.DataFrame, col: ColumnSpec) -> None:
    if not col.allowed:
        return
    series = df[col.name]
    text = series.astype(object).where(series.notna(), "").map(str)
    bad = ~text.isin([str(a) for a in col.allowed]).to_numpy()
    allowed = col.allowed_text()
    report.rows(table, col.name, df, bad,
                [f"missing value (allowed {allowed})" if v == "" else
                 f"{col.name}={v!r} is not one of {allowed}"
                 for v in text.to_numpy()[bad][:MAX_REPORTED_ROWS]],
                f"not one of {allowed}")


def _check_columns(report: _Report, spec: TableSpec, df: pd.DataFrame) -> None:
    for col in spec.known_columns(list(df.columns)):
        if col.name not in df.columns:
            if col.required:
                report.add(spec.name, col.name, None, None,
                           f"required column missing ({col.kind}, unit {col.stored_unit or '-'}, "
                           f"allowed {col.allowed_text()})")
            continue
        if col.kind in ("int", "float"):
            _check_numeric(report, spec.name, df, col)
        elif col.kind == "bool":
            _check_bool(report, spec.name, df, col)
        else:
            _check_str(report, spec.name, df, col)


# ----------------------------------------------------------------------------
# Cross-table checks
# ----------------------------------------------------------------------------


def _has(df: pd.DataFrame, *columns: str) -> bool:
    return all(c in df.columns for c in columns)


def _check_unique(report: _Report, table: str, df: pd.DataFrame, key: tuple[str, ...]) -> None:
    if not key or not _has(df, *key) or df.empty:
        return
    duplicated = df.duplicated(list(key), keep=False).to_numpy()
    what = "case_id" if key == ("case_id",) else "(" + ", ".join(key) + ")"
    report.rows(table, key[-1], df, duplicated,
                f"duplicate {what}: each must appear only once in table '{table}'",
                f"duplicate {what}")


def _check_orphans(report: _Report, table: str, df: pd.DataFrame, cases: pd.DataFrame) -> None:
    if not _has(df, "case_id") or not _has(cases, "case_id"):
        return
    orphan = ~df["case_id"].isin(cases["case_id"]).to_numpy()
    report.rows(table, "case_id", df, orphan,
                "orphaned row: case_id is not in table 'cases'", "orphaned rows")


def _pairs(df: pd.DataFrame) -> pd.MultiIndex:
    return pd.MultiIndex.from_frame(df[["case_id", "participant"]].drop_duplicates())


def _check_participants(report: _Report, db: Database) -> None:
    parts, cases = db.participants, db.cases
    if not _has(parts, "case_id", "participant") or not _has(cases, "case_id"):
        return
    case_ids = cases["case_id"].drop_duplicates().to_numpy()
    for number in (1, 2):
        present = parts.loc[parts["participant"] == number, "case_id"]
        lacking = case_ids[~np.isin(case_ids, present.to_numpy())]
        report.cases("participants", "participant", lacking,
                     f"case has no participant {number} (every case needs exactly "
                     "participants 1 and 2)")


def _check_vehicle_layout(report: _Report, df: pd.DataFrame) -> None:
    """Layout consistency by :func:`vfs.physics.vehicle.validate_vehicle_values`.

    Only rows whose values are in range are checked.
    """
    fields = list(PARAMETER_RANGES)
    if not _has(df, *fields) or df.empty:
        return
    values = {}
    in_range = np.ones(len(df), bool)
    for name in fields:
        v, _ = _numeric_values(df[name])
        lo, hi = PARAMETER_RANGES[name]
        ok = np.isfinite(v) & (v >= lo) & (v <= hi)
        if name == "yaw_inertia":
            ok |= np.isnan(v)
        in_range &= ok
        values[name] = v
    positions = np.flatnonzero(in_range)
    layout_problems: list[tuple[int, str]] = []
    for position in positions.tolist():  # participants: two rows per case, not samples
        row: dict[str, object] = {name: float(values[name][position]) for name in fields}
        if math.isnan(values["yaw_inertia"][position]):
            row["yaw_inertia"] = None
        layout_problems += [(position, text) for text in validate_vehicle_values(row)]
    for row_number, text in layout_problems[:MAX_REPORTED_ROWS]:
        match = re.match(r"(\w+)", text)
        column = match.group(1) if match and match.group(1) in df.columns else ""
        report.add("participants", column, row_number,
                   _case_ids_at(df, np.array([row_number]))[0],
                   f"inconsistent vehicle layout: {text}")
    if len(layout_problems) > MAX_REPORTED_ROWS:
        report.add("participants", "", None, None,
                   f"... and {len(layout_problems) - MAX_REPORTED_ROWS} more layout problems")


def _check_trajectories(report: _Report, db: Database) -> None:
    traj, parts = db.trajectories, db.participants
    if not _has(traj, "case_id", "participant"):
        return
    # participants without trajectory and trajectories without participant
    if _has(parts, "case_id", "participant"):
        part_pairs, traj_pairs = _pairs(parts), _pairs(traj)
        for (cid, number) in part_pairs[~part_pairs.isin(traj_pairs)][:MAX_REPORTED_ROWS]:
            report.add("trajectories", "participant", None, python_scalar(cid),
                       f"participant {_fmt(number)} has no trajectory")
        extra = traj_pairs[~traj_pairs.isin(part_pairs)]
        known_cases = db.cases["case_id"] if _has(db.cases, "case_id") else pd.Series([])
        for (cid, number) in extra[:MAX_REPORTED_ROWS]:
            if known_cases.isin([cid]).any():  # orphans are reported once, as orphans
                report.add("trajectories", "participant", None, python_scalar(cid),
                           f"trajectory of participant {_fmt(number)} has no row in "
                           "table 'participants'")
    if "t" not in traj.columns or traj.empty:
        return
    if pd.api.types.is_datetime64_any_dtype(traj["t"]) or \
            pd.api.types.is_timedelta64_dtype(traj["t"]):
        report.add("trajectories", "t", None, None,
                   f"column 't' holds {traj['t'].dtype} values (dates or durations); time "
                   "must be a number of seconds (e.g. from the start of the record)")
        return
    t, _ = _numeric_values(traj["t"])
    time = pd.Series(t, index=traj.index)
    groups = time.groupby([traj["case_id"], traj["participant"]], sort=False)
    dt = groups.diff().to_numpy()
    with np.errstate(invalid="ignore"):
        decreasing = dt < 0
        duplicate = dt == 0
        coarse = dt > MAX_SAMPLE_SPACING + SPACING_TOLERANCE
    report.rows("trajectories", "t", traj, decreasing,
                [f"time t={v:g} s is earlier than the previous sample of this participant "
                 "(t must increase strictly)" for v in t[decreasing][:MAX_REPORTED_ROWS]],
                "non-monotonic time")
    report.rows("trajectories", "t", traj, duplicate,
                [f"duplicate time t={v:g} s of this participant (t must increase strictly)"
                 for v in t[duplicate][:MAX_REPORTED_ROWS]],
                "duplicate time")
    report.rows("trajectories", "t", traj, coarse,
                [f"sample spacing {d:g} s before t={v:g} s exceeds the allowed "
                 f"{MAX_SAMPLE_SPACING:g} s" + (_UNIT_HINT if d > 100 * MAX_SAMPLE_SPACING
                                                else "") for d, v in
                 zip(dt[coarse][:MAX_REPORTED_ROWS], t[coarse][:MAX_REPORTED_ROWS], strict=True)],
                f"sample spacing above {MAX_SAMPLE_SPACING:g} s")
    sizes = groups.size()
    short = sizes[sizes < MIN_TRAJECTORY_SAMPLES]
    for (cid, number), n in list(short.items())[:MAX_REPORTED_ROWS]:
        report.add("trajectories", "t", None, python_scalar(cid),
                   f"trajectory of participant {_fmt(number)} has {n} sample(s); at least "
                   f"{MIN_TRAJECTORY_SAMPLES} are required")


def _check_collision(report: _Report, db: Database) -> None:
    cases, rec = db.cases, db.reconstruction
    if not db.has_reconstruction or not _has(cases, "case_id", "collision"):
        return
    if not _has(rec, "case_id"):
        return
    collision = cases["collision"]
    if collision.dtype != bool:
        text = collision.astype(str).str.strip().str.lower()
        if not text.isin(_TRUE_FALSE).all():
            return  # reported by the column check
        collision = text.isin({"true", "1", "yes"})
    collision = collision.to_numpy(dtype=bool)
    has_row = cases["case_id"].isin(rec["case_id"]).to_numpy()
    report.rows("reconstruction", "case_id", cases, collision & ~has_row,
                "case has collision=True but no reconstruction row (near misses need "
                "collision=False; databases without reconstruction need "
                "meta has_reconstruction=false)",
                "colliding cases without reconstruction")
    near_miss = cases.loc[~collision, "case_id"]
    wrong = rec["case_id"].isin(near_miss).to_numpy()
    report.rows("reconstruction", "case_id", rec, wrong,
                "reconstruction row for a case with collision=False", "reconstruction of "
                "near misses")


def validate_meta(meta: Mapping[str, object] | None) -> list[DataProblem]:
    """Check the contents of ``meta.json``.

    Parameters
    ----------
    meta : mapping or None
        Parsed ``meta.json``; ``None`` or empty when the file is missing.

    Returns
    -------
    list of DataProblem
        Problems with table ``"meta"``.
    """
    problems: list[DataProblem] = []
    if not meta:
        return [DataProblem("meta", "schema_version", None, None,
                            f"meta.json is missing or empty (needs schema_version "
                            f"{SCHEMA_VERSION!r})")]
    version = meta.get("schema_version")
    if version is None:
        problems.append(DataProblem("meta", "schema_version", None, None,
                                    f"meta.json has no schema_version (expected "
                                    f"{SCHEMA_VERSION!r})"))
    elif str(version) not in SUPPORTED_SCHEMA_VERSIONS:
        problems.append(DataProblem(
            "meta", "schema_version", None, None,
            f"unknown schema_version {version!r} (supported: "
            f"{', '.join(SUPPORTED_SCHEMA_VERSIONS)})",
        ))
    flag = meta.get("has_reconstruction", True)
    if not isinstance(flag, bool):
        problems.append(DataProblem("meta", "has_reconstruction", None, None,
                                    f"has_reconstruction={flag!r} must be true or false"))
    return problems


def validate_database(db: Database, *, plausibility: bool = True) -> list[DataProblem]:
    """Check a database against the schema; return every problem found.

    Checks: ``meta.json`` (schema version); per column (from
    :data:`vfs.database.schema.TABLES`): presence of required columns,
    numeric type, NaN, finiteness, integers, allowed range or values; unique
    keys (``case_id``, ``(case_id, participant)``); orphaned rows (``case_id``
    not in ``cases``); every case has participants 1 and 2; every participant
    has a trajectory of at least 2 samples with strictly increasing time and
    spacing <= 0.1 s; vehicle layout (:func:`vfs.physics.vehicle.validate_vehicle_values`);
    ``collision=True`` cases have a reconstruction row and ``collision=False``
    cases none (skipped when ``meta["has_reconstruction"]`` is false); then, on
    schema-valid data, the physical plausibility errors of
    :func:`vfs.database.plausibility.check_plausibility` (jumps, km/h in m/s columns,
    yaw in degrees, physical limits, an empty database, impact times outside the
    trajectories; its warnings are for ``vfs db validate``).

    Parameters
    ----------
    db : Database
        The database (normalised or not).
    plausibility : bool
        Add the physical plausibility errors (default); False for the schema
        alone (:func:`vfs.database.checks.check_database` adds errors and
        warnings itself).

    Returns
    -------
    list of DataProblem
        Empty if the database is valid.
    """
    report = _Report()
    report.problems += validate_meta(db.meta)
    for name, df in db.tables().items():
        spec = TABLES[name]
        _check_columns(report, spec, df)
        _check_unique(report, name, df, spec.key if name != "trajectories" else ())
        if name != "cases":
            _check_orphans(report, name, df, db.cases)
    _check_participants(report, db)
    _check_vehicle_layout(report, db.participants)
    _check_trajectories(report, db)
    _check_collision(report, db)
    _check_outcome_source(report, db.reconstruction)
    if plausibility and not report.problems:  # physics on schema-valid data only
        from vfs.database.plausibility import check_plausibility

        # a selection (--where) may match no case: emptiness is vfs db validate's check
        report.problems += check_plausibility(db, require_cases=False).errors
    return report.problems


def _check_outcome_source(report: _Report, rec: pd.DataFrame) -> None:
    """Reconstruction rows give every outcome; only measurement rows may leave some NaN."""
    if rec.empty:
        return
    source = (rec["outcome_source"].astype(object) if "outcome_source" in rec.columns
              else pd.Series(OUTCOME_RECONSTRUCTION, index=rec.index))
    given = (source != OUTCOME_MEASUREMENT).to_numpy()
    text = "missing value (allowed only in outcome_source = 'measurement' rows: not measured)"
    for name in MEASURABLE_COLUMNS:
        if name in rec.columns and not name.startswith("velocity_angle_change"):
            values = pd.to_numeric(rec[name], errors="coerce").to_numpy(float)
            report.rows("reconstruction", name, rec, given & np.isnan(values), text, text)
    if "impact_type" in rec.columns:
        empty = (rec["impact_type"].astype(object).fillna("").map(str) == "").to_numpy()
        report.rows("reconstruction", "impact_type", rec, given & empty, text, text)


def validate_table(name: str, df: pd.DataFrame) -> list[DataProblem]:
    """The column and key checks of one table alone (e.g. the cases a study selects).

    Parameters
    ----------
    name : str
        Table name (key of :data:`vfs.database.schema.TABLES`).
    df : pandas.DataFrame
        The table (SI units).

    Returns
    -------
    list of DataProblem
        Types, missing values, ranges and duplicate keys: what
        :func:`validate_database` reports for this table.
    """
    spec = TABLES[name]
    report = _Report()
    _check_columns(report, spec, df)
    _check_unique(report, name, df, spec.key if name != "trajectories" else ())
    return report.problems


def check_values(table: str, values: Mapping[str, object]) -> list[DataProblem]:
    """Check single values against the column specs of ``table`` (e.g. defaults).

    Parameters
    ----------
    table : str
        Table name (key of :data:`vfs.database.schema.TABLES`).
    values : mapping
        Column name -> value; names not in the schema are ignored.

    Returns
    -------
    list of DataProblem
        Range, type and allowed-value problems (row 0 = the given values).
    """
    spec = TABLES[table]
    columns = tuple(c for c in spec.columns if c.name in values)
    one_row = pd.DataFrame({c.name: [values[c.name]] for c in columns})
    report = _Report()
    _check_columns(report, TableSpec(table, "", columns, ()), one_row)
    return report.problems
