"""Batch-solving tables of impact configurations (``vfs impact``).

The table layout is documented in docs/data-format.md ("Impact tables").
Input: one row per impact, SI units, columns :data:`INPUT_COLUMNS` (plus any
others, which are passed through; an optional ``stiffness_ratio`` = k1/k2
selects the stiffness rule of the EES split).  Output: the input columns
plus :data:`OUTPUT_COLUMNS`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from vfs.errors import DataError, DataProblem
from vfs.physics.impact import (
    ImpactConfig,
    config_problems,
    describe_range,
    impact_type_names,
    solve_impact,
)

#: Required input columns (SI): per vehicle i = 1, 2 and per impact.
INPUT_COLUMNS: tuple[str, ...] = ("case_id", *ImpactConfig._fields)

#: Output columns added by :func:`solve_impact_table`, with units.
OUTPUT_COLUMNS: dict[str, str] = {
    "impact_type": "'full', 'sliding', 'none' (separating), or 'error' (with --on-error record)",
    "vx1_post": "m/s", "vy1_post": "m/s", "yaw_rate1_post": "rad/s",
    "vx2_post": "m/s", "vy2_post": "m/s", "yaw_rate2_post": "rad/s",
    "delta_vx1": "m/s", "delta_vy1": "m/s", "delta_vx2": "m/s", "delta_vy2": "m/s",
    "delta_v1": "m/s", "delta_v2": "m/s",
    "ees1": "m/s", "ees2": "m/s", "energy_loss": "J",
    "pdof1": "deg", "pdof2": "deg", "pdof_clock1": "o'clock", "pdof_clock2": "o'clock",
    "velocity_angle_change1": "deg", "velocity_angle_change2": "deg",
    "impulse_t": "N s", "impulse_n": "N s", "impulse_x": "N s", "impulse_y": "N s",
    "closing_speed": "m/s", "error": "message for rows that could not be solved, else empty",
}

_DEGREE_FIELDS = ("pdof1", "pdof2", "velocity_angle_change1", "velocity_angle_change2")


def read_table(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a Parquet (``.parquet``/``.pq``) or CSV table."""
    p = Path(path)
    if not p.exists():
        raise DataError(DataProblem(p.name, "", None, None, f"file {p} does not exist"))
    suffix = p.suffix.lower()
    if suffix not in (".parquet", ".pq", ".csv"):
        raise DataError(DataProblem(p.name, "", None, None,
                                    f"unknown table format {p.suffix!r}; use .parquet or .csv"))
    try:
        df = pd.read_parquet(p) if suffix in (".parquet", ".pq") else pd.read_csv(p)
    except pd.errors.EmptyDataError:
        raise DataError(DataProblem(p.name, "", None, None,
                                    f"file {p} is empty (expected a header row with the "
                                    "columns of docs/data-format.md, 'Impact tables')")) from None
    except (UnicodeDecodeError, pd.errors.ParserError, OSError, ValueError) as exc:
        kind = "Parquet" if suffix in (".parquet", ".pq") else "CSV (UTF-8 text)"
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(DataProblem(p.name, "", None, None,
                                    f"file {p} is not a readable {kind} table: {first}")) from None
    if df.empty:
        raise DataError(DataProblem(p.name, "", None, None, f"file {p} has no rows"))
    return df


def _numeric_column(df: pd.DataFrame, name: str, table: str,
                    problems: list[DataProblem]) -> np.ndarray:
    values = pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    raw_missing = df[name].isna().to_numpy()
    not_numeric = np.isnan(values) & ~raw_missing
    for row in np.flatnonzero(not_numeric)[:20]:
        problems.append(DataProblem(table, name, int(row), df["case_id"].iloc[row],
                                    f"value {df[name].iloc[row]!r} is not a number"))
    return values


def solve_impact_table(
    df: pd.DataFrame, *, on_error: Literal["raise", "record"] = "raise", table: str = "input",
) -> pd.DataFrame:
    """Solve every row of an impact table.

    Parameters
    ----------
    df : DataFrame
        Input table with :data:`INPUT_COLUMNS` (SI units).
    on_error : {'raise', 'record'}
        'raise': any bad row raises :class:`DataError` listing every bad
        row and column with the allowed range.  'record': bad rows get an
        ``error`` message and impact_type 'error'; the rest is solved.
    table : str
        Table name used in error messages (e.g. the file name).

    Returns
    -------
    DataFrame
        The input columns followed by :data:`OUTPUT_COLUMNS`.
    """
    missing = [c for c in INPUT_COLUMNS if c not in df.columns]
    if missing:
        raise DataError([DataProblem(table, c, None, None, "required column is missing")
                         for c in missing])
    df = df.reset_index(drop=True)
    problems: list[DataProblem] = []
    arrays = {f: _numeric_column(df, f, table, problems) for f in ImpactConfig._fields}
    config = ImpactConfig.from_arrays(**arrays)
    bad_rows = np.zeros(len(df), dtype=bool)
    messages = np.full(len(df), "", dtype=object)
    for field, mask in config_problems(config).items():
        bad_rows |= mask
        for row in np.flatnonzero(mask):
            value = float(getattr(config, field)[row])
            text = f"{field}={value!r} not allowed ({describe_range(field)})"
            messages[row] = f"{messages[row]}; {text}" if messages[row] else text
            problems.append(DataProblem(table, field, int(row), df["case_id"].iloc[row],
                                        f"value {value!r} not allowed ({describe_range(field)})"))
    stiffness = None
    if "stiffness_ratio" in df.columns:
        stiffness = pd.to_numeric(df["stiffness_ratio"], errors="coerce").to_numpy(float)
        # documented "> 0" (k1 / k2); NaN selects the mass rule
        with np.errstate(invalid="ignore"):
            wrong = ~np.isnan(stiffness) & ~((stiffness > 0) & (stiffness < 1e6))
        for row in np.flatnonzero(wrong):
            text = (f"stiffness_ratio={float(stiffness[row])!r} not allowed (finite, > 0 and "
                    "< 1e6; empty = mass rule)")
            messages[row] = f"{messages[row]}; {text}" if messages[row] else text
            problems.append(DataProblem(table, "stiffness_ratio", int(row),
                                        df["case_id"].iloc[row], text))
        bad_rows |= wrong
        stiffness = np.where(wrong, np.nan, stiffness)
    if problems and on_error == "raise":
        raise DataError(problems, header=f"{len(problems)} problem(s) in impact table '{table}' "
                        "(use --on-error record to solve the valid rows):")
    # solve valid rows only; bad rows are filled with a harmless configuration
    safe = ImpactConfig(*(np.where(bad_rows, 0.0, a) for a in config))
    safe = safe._replace(x2=np.where(bad_rows, 1.0, safe.x2),  # at rest, apart: no impact

        m1=np.where(bad_rows, 1.0, safe.m1), m2=np.where(bad_rows, 1.0, safe.m2),
        izz1=np.where(bad_rows, 1.0, safe.izz1), izz2=np.where(bad_rows, 1.0, safe.izz2),
        restitution=np.where(bad_rows, 0.0, safe.restitution),
        contact_friction=np.where(bad_rows, 0.0, safe.contact_friction),
    )
    result = solve_impact(safe, stiffness_ratio=stiffness)
    out = df.copy()
    impact_type = impact_type_names(result.impact_type).astype(object)
    impact_type[bad_rows] = "error"
    out["impact_type"] = impact_type
    rd = result._asdict()
    for col in OUTPUT_COLUMNS:
        if col in ("impact_type", "error"):
            continue
        values = np.asarray(rd[col])
        if col in _DEGREE_FIELDS:
            values = np.degrees(values)
        if col.startswith("pdof_clock"):
            values = np.where(bad_rows, 0, values).astype(np.int64)
        else:
            values = np.where(bad_rows, np.nan, values.astype(float))
        out[col] = values
    out["error"] = messages.astype(str)
    return out
