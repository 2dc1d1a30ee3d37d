"""Batch-solving tables of impact configurations (``vfs impact``).

The table layout is documented in docs/data-format.md ("Impact tables").
Input: one row per impact, SI units, columns :data:`INPUT_COLUMNS` (plus any
others, which are passed through; an optional ``stiffness_ratio`` = k1/k2
selects the stiffness rule of the EES split).  Output: the input columns
plus :data:`OUTPUT_COLUMNS`.
"""

from __future__ import annotations

import contextlib
import csv
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
import pandas as pd

from vfs.errors import DataError, DataProblem
from vfs.physics.impact import (
    CONFIG_COLUMNS,
    ImpactConfig,
    config_problems,
    describe_range,
    impact_type_names,
    solve_impact,
)
from vfs.units import wrap_angle

#: Required input columns (SI): per vehicle i = 1, 2 and per impact.
INPUT_COLUMNS: tuple[str, ...] = ("case_id", *CONFIG_COLUMNS)

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


#: Mass [kg] below which an impact-table vehicle warns (tonnes?): the lightest road
#: vehicle of the database schema (:data:`vfs.physics.vehicle.PARAMETER_RANGES`).
MIN_VEHICLE_MASS = 50.0
#: Mass [kg] above which it warns (pounds?): the heaviest of the schema, 60 t.
MAX_VEHICLE_MASS = 60000.0
#: Band of the yaw radius of gyration sqrt(izz / m) [m]: 0.3 m (a motorcycle or bicycle
#: with rider, about 60 kg m^2 for 250 kg: 0.49 m) to 8 m (a uniform rod of the longest
#: combination on EU roads, 25.25 m (Directive (EU) 2015/719): 25.25 / sqrt(12) = 7.3 m).
#: A car has 1.2-1.6 m (I = m L1 L2 of the front-to-side energy balance paper).
GYRATION_RADIUS = (0.3, 8.0)
#: CG distance [m] below which two vehicles "share a centre of gravity": 0.5 m (two cars
#: side by side in full contact are at least a car width, about 1.7 m, apart).
MIN_CG_DISTANCE = 0.5
#: POI distance from the nearer CG [m] that warns: 15 m (half the 25.25 m combination
#: plus its width; a POI farther away lies outside every road vehicle).
MAX_POI_DISTANCE = 15.0
#: Delta-v [m/s] that warns (speeds in km/h?): 30 m/s (108 km/h), where the NHTSA fatality
#: risk curve of DOT HS 813 219 (2022) passes 90 %; real crash data end there.
MAX_DELTA_V = 30.0
#: Speed [m/s] that warns (km/h?): the database's warning limit for road vehicles.
MAX_SPEED = 60.0
#: Yaw rate [rad/s] that warns (deg/s?): one turn per second, 2 pi rad/s.  A car of
#: 1,500 kg and 2,500 kg m^2 then holds 49 kJ of rotational energy, that of the whole car
#: at 29 km/h; yaw rates in deg/s of turning or spinning vehicles (10-200 deg/s) read as
#: rad/s lie above it.
MAX_YAW_RATE = 2.0 * np.pi
#: Contact-plane angle [rad] that warns (degrees?): beyond one turn, 2 pi.
MAX_CP_ANGLE = 2.0 * np.pi
#: Speed [m/s] that warns in a crossing impact (velocity directions 30-150 deg apart):
#: 30 m/s (108 km/h), above the 100 km/h speed limit of rural roads of most EU states,
#: where crossing traffic meets; urban speeds in km/h (30-60) read as m/s lie at or above
#: it.  Same-direction and head-on impacts (motorways, overtaking) are left to
#: :data:`MAX_SPEED` and :data:`MAX_DELTA_V`.
MAX_CROSSING_SPEED = 30.0
#: Mass [kg] above which a vehicle is a truck or bus (EU categories N2/N3, M2/M3).
HEAVY_VEHICLE_MASS = 3500.0
#: Speed [m/s] that warns for a heavy vehicle: their speed limiters stop at 90 km/h
#: (trucks) and 100 km/h (buses) (Council Directive 92/6/EEC as amended by 2002/85/EC);
#: 100 km/h plus 10 %.
MAX_HEAVY_SPEED = 100.0 / 3.6 * 1.1
#: Factor on the sum of both vehicles' half-lengths estimated from the radius of gyration
#: (a uniform rod of length L has k = L / sqrt(12), half-length sqrt(3) k) above which
#: the CGs are too far apart for the outlines to touch: 1.5 (mass concentrated towards the
#: centre and the widths).
CONTACT_REACH_FACTOR = 1.5


def impact_table_warnings(df: pd.DataFrame, config: ImpactConfig, table: str
                          ) -> list[DataProblem]:
    """Values each in range but not from a real impact (units mixed up), per row.

    Masses in tonnes or pounds, a yaw inertia whose radius of gyration no road
    vehicle has, yaw angles, yaw rates or the contact-plane angle in degrees, both
    centres of gravity at one point or too far apart to touch, a POI far from both
    vehicles, speeds above any road vehicle's, above a truck's speed limiter, or a
    crossing impact at speeds of km/h read as m/s; the limits are the constants
    above, with their sources.  Delta-v is checked after solving
    (:func:`solve_impact_table`).

    Returns
    -------
    list of DataProblem
        One per row and finding (at most 20 per finding).
    """
    out: list[DataProblem] = []
    ids = df["case_id"].to_numpy()

    def add(column: str, mask: np.ndarray, texts: list[str]) -> None:
        rows = np.flatnonzero(mask)
        for row, text in list(zip(rows, texts, strict=True))[:20]:
            out.append(DataProblem(table, column, int(row), ids[row], text))
        if rows.size > 20:
            out.append(DataProblem(table, column, None, None,
                                   f"... and {rows.size - 20} more rows"))

    with np.errstate(invalid="ignore", divide="ignore"):
        for i in (1, 2):
            m, izz, yaw = (getattr(config, f)[:, i - 1] for f in ("m", "izz", "yaw"))
            vx, vy = config.vx[:, i - 1], config.vy[:, i - 1]
            free = np.isfinite(m)
            light = free & (m < MIN_VEHICLE_MASS)
            add(f"m{i}", light, [f"m{i}={v:g} kg is below the {MIN_VEHICLE_MASS:g} kg of the "
                                 "lightest road vehicle: mass in tonnes? (kg required)"
                                 for v in m[light]])
            heavy = free & (m > MAX_VEHICLE_MASS)
            add(f"m{i}", heavy, [f"m{i}={v:g} kg is above the {MAX_VEHICLE_MASS:g} kg of the "
                                 "heaviest road vehicle: mass in pounds? (kg required)"
                                 for v in m[heavy]])
            radius = np.sqrt(izz / m)
            odd = free & ~light & ((radius < GYRATION_RADIUS[0]) | (radius > GYRATION_RADIUS[1]))
            add(f"izz{i}", odd, [f"izz{i}={j:g} kg m^2 for m{i}={v:g} kg is a radius of "
                                 f"gyration of {r:.3g} m, outside the {GYRATION_RADIUS[0]:g}-"
                                 f"{GYRATION_RADIUS[1]:g} m of road vehicles (a car: about "
                                 "1.4 m)" for j, v, r in zip(izz[odd], m[odd], radius[odd],
                                                            strict=True)])
            speed = np.hypot(vx, vy)
            heading = np.arctan2(vy, vx)
            moving = speed > 2.0
            rad_off = np.abs(wrap_angle(yaw - heading)) > np.radians(45.0)
            deg_fits = np.abs(wrap_angle(np.radians(yaw) - heading)) < np.radians(15.0)
            degrees = (np.abs(yaw) > 2.0 * np.pi) | (moving & rad_off & deg_fits & (yaw != 0))
            add(f"yaw{i}", degrees, [f"yaw{i}={v:g} looks like degrees (rad required)"
                                     + (": it follows the velocity only read as degrees"
                                        if mv else "") for v, mv in
                                     zip(yaw[degrees], (moving & deg_fits)[degrees],
                                         strict=True)])
            fast = speed > MAX_SPEED
            add(f"vx{i}", fast, [f"speed {v:.4g} m/s of vehicle {i} is above the "
                                 f"{MAX_SPEED:g} m/s of road vehicles in a crash: km/h? (m/s "
                                 "required)" for v in speed[fast]])
            heavy_fast = ~fast & (m > HEAVY_VEHICLE_MASS) & (speed > MAX_HEAVY_SPEED)
            add(f"vx{i}", heavy_fast,
                [f"speed {v:.4g} m/s ({v * 3.6:.4g} km/h) of vehicle {i}, a truck or bus of "
                 f"{w:g} kg, is above the {MAX_HEAVY_SPEED:.3g} m/s its speed limiter allows: "
                 "km/h? (m/s required)" for v, w in zip(speed[heavy_fast], m[heavy_fast],
                                                         strict=True)])
            rate = config.yaw_rate[:, i - 1]
            spin = np.abs(rate) > MAX_YAW_RATE
            add(f"yaw_rate{i}", spin,
                [f"yaw_rate{i}={v:g} rad/s is more than one turn per second "
                 f"({MAX_YAW_RATE:.3g} rad/s): deg/s? (rad/s required)" for v in rate[spin]])
        speed1 = np.hypot(config.vx[:, 0], config.vy[:, 0])
        speed2 = np.hypot(config.vx[:, 1], config.vy[:, 1])
        between = np.abs(wrap_angle(np.arctan2(config.vy[:, 0], config.vx[:, 0])
                                    - np.arctan2(config.vy[:, 1], config.vx[:, 1])))
        crossing = ((speed1 > 2.0) & (speed2 > 2.0) & (between > np.radians(30.0))
                    & (between < np.radians(150.0)))
        top = np.maximum(speed1, speed2)
        urban = crossing & (top > MAX_CROSSING_SPEED) & (top <= MAX_SPEED)
        add("vx1", urban, [f"a crossing impact (velocities {np.degrees(b):.0f} deg apart) at "
                           f"{v:.4g} m/s ({v * 3.6:.4g} km/h): above the {MAX_CROSSING_SPEED:g} "
                           "m/s of crossing traffic; speeds in km/h? (m/s required)"
                           for b, v in zip(between[urban], top[urban], strict=True)])
        cp = config.cp_angle
        cp_deg = np.abs(cp) > MAX_CP_ANGLE
        add("cp_angle", cp_deg, [f"cp_angle={v:g} is more than one turn read as radians: "
                                 "degrees? (rad required)" for v in cp[cp_deg]])
        x1, x2, y1, y2 = config.x[:, 0], config.x[:, 1], config.y[:, 0], config.y[:, 1]
        gap = np.hypot(x1 - x2, y1 - y2)
        close = gap < MIN_CG_DISTANCE
        add("x2", close, [f"the centres of gravity of both vehicles are {g:.3g} m apart "
                          f"(below {MIN_CG_DISTANCE:g} m): two vehicles cannot share one point"
                          for g in gap[close]])
        free_both = np.isfinite(config.m).all(axis=1)
        half = np.sqrt(3.0) * np.sqrt(config.izz / config.m)
        reach = CONTACT_REACH_FACTOR * half.sum(axis=1)
        apart = free_both & ~close & (gap > reach)
        add("x2", apart, [f"the centres of gravity are {g:.4g} m apart, more than the {r:.3g} m "
                          "at which vehicles of these masses and yaw inertias can touch: "
                          "positions in other units, or of another moment? (m required)"
                          for g, r in zip(gap[apart], reach[apart], strict=True)])
        poi = np.minimum(np.hypot(config.poi_x - x1, config.poi_y - y1),
                         np.hypot(config.poi_x - x2, config.poi_y - y2))
        far = poi > MAX_POI_DISTANCE
        add("poi_x", far, [f"the POI is {d:.4g} m from the nearer centre of gravity (above "
                           f"{MAX_POI_DISTANCE:g} m): outside both vehicles" for d in poi[far]])
    return out


def _duplicated_columns(df: pd.DataFrame, table: str) -> list[DataProblem]:
    """Columns that appear twice (pandas renames the second copy of ``m1`` to ``m1.1``)."""
    out = []
    names = [str(c) for c in df.columns]
    for name in names:
        base, dot, suffix = name.rpartition(".")
        if dot and suffix.isdigit() and base in names:
            out.append(DataProblem(table, base, None, None,
                                   f"column '{base}' appears twice in the file (the second "
                                   f"copy was read as '{name}'); keep one"))
    for name in pd.Index(names)[pd.Index(names).duplicated()].unique():
        out.append(DataProblem(table, name, None, None, f"column '{name}' appears twice"))
    return out


def _numeric_column(df: pd.DataFrame, name: str, table: str,
                    problems: list[DataProblem]) -> np.ndarray:
    values = pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    raw_missing = df[name].isna().to_numpy()
    not_numeric = np.isnan(values) & ~raw_missing
    for row in np.flatnonzero(not_numeric)[:20]:
        problems.append(DataProblem(table, name, int(row), df["case_id"].iloc[row],
                                    f"value {df[name].iloc[row]!r} is not a number"))
    return values


def _check_columns(columns: pd.Index, table: str) -> None:
    """Refuse a table without the required columns or with one of them twice."""
    frame = pd.DataFrame(columns=columns)
    missing = [c for c in INPUT_COLUMNS if c not in columns]
    duplicated = _duplicated_columns(frame, table)
    if missing or duplicated:
        raise DataError(duplicated + [DataProblem(table, c, None, None,
                                                  "required column is missing")
                                      for c in missing])


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
    _check_columns(df.columns, table)
    block = solve_block(df.reset_index(drop=True), on_error=on_error, table=table)
    if block.problems and on_error == "raise":
        raise DataError(block.problems, header=_problems_header(len(block.problems), table))
    from vfs.database.checks import settle

    settle([], block.warnings, header=_warnings_header(table))
    if block.table is None:  # pragma: no cover - problems with "raise" raised above
        raise DataError(block.problems)
    return block.table


def _problems_header(n: int, table: str) -> str:
    return (f"{n} problem(s) in impact table '{table}' (use --on-error record to solve the "
            "valid rows):")


def _warnings_header(table: str) -> str:
    return f"impact table '{table}': plausibility warnings under --strict:"


class SolvedBlock(NamedTuple):
    """One block of rows of an impact table, solved (:func:`solve_block`).

    Attributes
    ----------
    table : DataFrame or None
        The rows with :data:`OUTPUT_COLUMNS`; None when ``on_error="raise"`` found
        problems (nothing is solved then).
    problems : list of DataProblem
        Values that are not allowed (rows counted within the block).
    warnings : list of DataProblem
        Plausibility warnings (rows counted within the block).
    """

    table: pd.DataFrame | None
    problems: list[DataProblem]
    warnings: list[DataProblem]


def solve_block(df: pd.DataFrame, *, on_error: Literal["raise", "record"] = "raise",
                table: str = "input") -> SolvedBlock:
    """Check and solve one block of rows whose columns :func:`_check_columns` accepted.

    What :func:`solve_impact_table` does to a whole table, without raising on
    problems or emitting warnings: :func:`solve_impact_file` calls it once per
    record batch and reports for the whole file.
    """
    problems: list[DataProblem] = []
    arrays = {f: _numeric_column(df, f, table, problems) for f in CONFIG_COLUMNS}
    config = ImpactConfig.from_columns(**arrays)
    columns = config.columns()
    bad_rows = np.zeros(len(df), dtype=bool)
    messages = np.full(len(df), "", dtype=object)
    for field, mask in config_problems(config).items():
        bad_rows |= mask
        for row in np.flatnonzero(mask):
            value = float(columns[field][row])
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
        return SolvedBlock(None, problems, [])
    found = impact_table_warnings(df, config, table)
    if bad_rows.any():
        found = [p for p in found if p.row is None or not bad_rows[p.row]]
    # solve valid rows only; bad rows are filled with a harmless configuration
    bad_pairs = bad_rows[:, None]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        safe = ImpactConfig(*(np.where(bad_pairs if a.ndim == 2 else bad_rows, 0.0, a)
                              for a in config))
        apart = np.where(bad_pairs, [0.0, 1.0], safe.x)  # at rest, apart: no impact
        safe = safe._replace(
            x=apart,
            m=np.where(bad_pairs, 1.0, safe.m), izz=np.where(bad_pairs, 1.0, safe.izz),
            restitution=np.where(bad_rows, 0.0, safe.restitution),
            contact_friction=np.where(bad_rows, 0.0, safe.contact_friction),
        )
        result = solve_impact(safe, stiffness_ratio=stiffness)
    out = df.copy()
    for field in CONFIG_COLUMNS:  # read as text (CSV with a value that is no number): numbers
        if not pd.api.types.is_numeric_dtype(out[field].dtype):
            out[field] = arrays[field]
    impact_type = impact_type_names(result.impact_type).astype(object)
    impact_type[bad_rows] = "error"
    out["impact_type"] = impact_type
    rd = result.columns()
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
    for i in (1, 2):
        dv = out[f"delta_v{i}"].to_numpy(float)
        with np.errstate(invalid="ignore"):
            big = dv > MAX_DELTA_V
        rows = np.flatnonzero(big)
        for row in rows[:20]:
            found.append(DataProblem(
                table, f"delta_v{i}", int(row), df["case_id"].iloc[row],
                f"delta-v {dv[row]:.4g} m/s of vehicle {i} is above the {MAX_DELTA_V:g} m/s of "
                "real crashes: speeds in km/h? (m/s required)"))
        if rows.size > 20:
            found.append(DataProblem(table, f"delta_v{i}", None, None,
                                     f"... and {rows.size - 20} more rows"))
    return SolvedBlock(out, problems, found)


#: Rows read, solved and written at a time by :func:`solve_impact_file`.
BATCH_ROWS = 65536

#: Problems or warnings listed per column for a whole file (the rest are counted).
LISTED_PER_COLUMN = 20


class _Listing:
    """Problems of a whole file, block by block: rows made file-wide, at most
    :data:`LISTED_PER_COLUMN` listed per column and the rest counted.
    """

    def __init__(self, table: str) -> None:
        self.table = table
        self.listed: list[DataProblem] = []
        self.per_column: dict[str, int] = {}
        self.more: dict[str, int] = {}

    def add(self, problems: list[DataProblem], offset: int) -> None:
        for p in problems:
            if p.row is None and p.message.startswith("... and "):
                words = p.message.split()
                self.more[p.column] = self.more.get(p.column, 0) + int(words[2])
                continue
            if self.per_column.get(p.column, 0) >= LISTED_PER_COLUMN:
                self.more[p.column] = self.more.get(p.column, 0) + 1
                continue
            self.per_column[p.column] = self.per_column.get(p.column, 0) + 1
            row = None if p.row is None else p.row + offset
            self.listed.append(DataProblem(p.table, p.column, row, p.case_id, p.message))

    def all(self) -> list[DataProblem]:
        return self.listed + [DataProblem(self.table, column, None, None,
                                          f"... and {n} more rows")
                              for column, n in self.more.items()]

    def __len__(self) -> int:
        return len(self.listed) + sum(self.more.values())


def _batches(path: Path, batch_rows: int, text: bool) -> Iterator[pd.DataFrame]:
    """The rows of a Parquet or CSV table, ``batch_rows`` at a time (the CSV reader's blocks
    hold about as many); ``text``: the impact columns of a CSV file read as text.
    """
    import pyarrow as pa

    suffix = path.suffix.lower()
    if suffix in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        with pq.ParquetFile(path) as file:
            names = file.schema_arrow.names
            if file.metadata.num_rows == 0:
                yield file.schema_arrow.empty_table().to_pandas()
                return
            for batch in file.iter_batches(batch_size=batch_rows):
                yield _frame(batch, names)
        return
    import pyarrow.csv as pacsv

    with open(path, "rb") as head:
        first = head.readline()
    if not first.strip():
        raise pd.errors.EmptyDataError("no header")
    header = next(csv.reader([first.decode("utf-8-sig")]))
    row_bytes = max(64, path.stat().st_size // max(1, _count_estimate(path)))
    kinds = {c: pa.string() for c in CONFIG_COLUMNS} if text else \
        {c: pa.float64() for c in CONFIG_COLUMNS}
    reader = pacsv.open_csv(
        path, read_options=pacsv.ReadOptions(block_size=max(1 << 20, row_bytes * batch_rows)),
        convert_options=pacsv.ConvertOptions(
            column_types={c: t for c, t in kinds.items() if c in header},
            strings_can_be_null=True))
    with reader:
        empty = True
        for batch in reader:
            empty = False
            yield _frame(batch, header)
        if empty:
            yield reader.schema.empty_table().to_pandas()


def _count_estimate(path: Path) -> int:
    """Rows of a CSV file estimated from its first 64 kB."""
    with open(path, "rb") as file:
        head = file.read(1 << 16)
    lines = max(1, head.count(b"\n"))
    return max(1, int(path.stat().st_size / (len(head) / lines)))


def _frame(batch: Any, names: list[str]) -> pd.DataFrame:
    """A record batch as a DataFrame, keeping two columns of one name apart (checked later)."""
    if len(set(names)) == len(names):
        return batch.to_pandas()
    return pd.DataFrame({i: batch.column(i).to_pandas() for i in range(batch.num_columns)}
                        ).set_axis(names, axis=1)


class _AsText(Exception):
    """A CSV value that is no number: read the file again with the impact columns as text."""


def solve_impact_file(source: str | os.PathLike[str], target: str | os.PathLike[str], *,
                      on_error: Literal["raise", "record"] = "raise",
                      batch_rows: int = BATCH_ROWS) -> dict[str, int]:
    """Solve an impact table file into another, record batch by record batch.

    Reads ``batch_rows`` rows at a time (Parquet: :meth:`pyarrow.parquet.ParquetFile.
    iter_batches`; CSV: pyarrow's streaming reader), solves them
    (:func:`solve_block`) and appends them to the output (Parquet:
    :class:`pyarrow.parquet.ParquetWriter`; CSV: text appended), so memory stays
    bounded by one batch whatever the table's length.  The output is written to
    a temporary file and renamed only when the whole table is solved: with
    ``on_error="raise"`` a bad row anywhere leaves no output, and every bad row
    of the file is listed (up to :data:`LISTED_PER_COLUMN` per column) with its
    file-wide row number; warnings are reported once for the file.

    Parameters
    ----------
    source, target : path
        ``.parquet``/``.pq`` or ``.csv`` files.
    on_error : {'raise', 'record'}
        As :func:`solve_impact_table`.
    batch_rows : int
        Rows per batch.

    Returns
    -------
    dict
        Rows per impact type (``full``, ``sliding``, ``none``, ``error``).

    Raises
    ------
    DataError
        Unreadable input, missing or duplicated columns, bad values (``raise``), or
        warnings under ``--strict``.
    """
    from vfs.atomic import write_atomic

    path = _existing_table(source)
    out = Path(target)
    if out.suffix.lower() not in (".parquet", ".pq", ".csv"):
        raise DataError(DataProblem(out.name, "", None, None,
                                    f"unknown table format {out.suffix!r} (use .parquet or "
                                    ".csv)"))
    counts: dict[str, int] = {}

    def write(tmp: Path) -> None:
        try:
            counts.update(_stream(path, tmp, on_error, batch_rows, text=False))
        except _AsText:
            counts.clear()
            counts.update(_stream(path, tmp, on_error, batch_rows, text=True))

    write_atomic(out, write)
    return counts


def _existing_table(source: str | os.PathLike[str]) -> Path:
    p = Path(source)
    if not p.exists():
        raise DataError(DataProblem(p.name, "", None, None, f"file {p} does not exist"))
    if p.suffix.lower() not in (".parquet", ".pq", ".csv"):
        raise DataError(DataProblem(p.name, "", None, None,
                                    f"unknown table format {p.suffix!r}; use .parquet or .csv"))
    return p


def _stream(path: Path, tmp: Path, on_error: Literal["raise", "record"], batch_rows: int,
            *, text: bool) -> dict[str, int]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from vfs.database.checks import settle

    table = path.name
    problems, found = _Listing(table), _Listing(table)
    counts: dict[str, int] = {}
    writer: Any = None
    schema = None
    parquet = tmp.suffix.lower() in (".parquet", ".pq")
    offset = 0
    kind = "Parquet" if path.suffix.lower() in (".parquet", ".pq") else "CSV (UTF-8 text)"
    batches = _batches(path, batch_rows, text)
    try:
        with open(tmp, "w", encoding="utf-8", newline="") if not parquet else \
                contextlib.nullcontext() as csv_out:
            while True:
                try:
                    df = next(batches, None)
                except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
                    if not text and kind.startswith("CSV") and "conversion" in str(exc).lower():
                        raise _AsText from None
                    raise _unreadable(path, kind, exc) from None
                except (UnicodeDecodeError, OSError, ValueError, pa.ArrowException) as exc:
                    if isinstance(exc, pd.errors.EmptyDataError):
                        raise DataError(DataProblem(
                            table, "", None, None,
                            f"file {path} is empty (expected a header row with the columns of "
                            "docs/data-format.md, 'Impact tables')")) from None
                    raise _unreadable(path, kind, exc) from None
                if df is None:
                    break
                if offset == 0:
                    _check_columns(df.columns, table)
                    if df.empty:
                        raise DataError(DataProblem(table, "", None, None,
                                                    f"file {path} has no rows"))
                block = solve_block(df, on_error=on_error, table=table)
                problems.add(block.problems, offset)
                found.add(block.warnings, offset)
                if block.table is not None and not (on_error == "raise" and len(problems)):
                    for name, k in block.table["impact_type"].value_counts().items():
                        counts[str(name)] = counts.get(str(name), 0) + int(k)
                    if parquet:
                        arrow = pa.Table.from_pandas(block.table, schema=schema,
                                                     preserve_index=False)
                        if writer is None:
                            schema = arrow.schema
                            writer = pq.ParquetWriter(tmp, schema)
                        writer.write_table(arrow)
                    else:
                        block.table.to_csv(csv_out, index=False, header=offset == 0)
                offset += len(df)
    finally:
        if writer is not None:
            writer.close()
    if len(problems) and on_error == "raise":
        raise DataError(problems.all(), header=_problems_header(len(problems), table))
    settle([], found.all(), header=_warnings_header(table))
    return counts


def _unreadable(path: Path, kind: str, exc: BaseException) -> DataError:
    first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return DataError(DataProblem(path.name, "", None, None,
                                 f"file {path} is not a readable {kind} table: {first}"))
