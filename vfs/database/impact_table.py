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


def impact_table_warnings(df: pd.DataFrame, config: ImpactConfig, table: str
                          ) -> list[DataProblem]:
    """Values each in range but not from a real impact (units mixed up), per row.

    Masses in tonnes or pounds, a yaw inertia whose radius of gyration no road
    vehicle has, yaw angles in degrees, both centres of gravity at one point, a
    POI far from both vehicles, speeds above any road vehicle's; the limits are
    the constants above, with their sources.  Delta-v is checked after solving
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
        x1, x2, y1, y2 = config.x[:, 0], config.x[:, 1], config.y[:, 0], config.y[:, 1]
        gap = np.hypot(x1 - x2, y1 - y2)
        close = gap < MIN_CG_DISTANCE
        add("x2", close, [f"the centres of gravity of both vehicles are {g:.3g} m apart "
                          f"(below {MIN_CG_DISTANCE:g} m): two vehicles cannot share one point"
                          for g in gap[close]])
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
    duplicated = _duplicated_columns(df, table)
    if missing or duplicated:
        raise DataError(duplicated + [DataProblem(table, c, None, None,
                                                  "required column is missing")
                                      for c in missing])
    df = df.reset_index(drop=True)
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
        raise DataError(problems, header=f"{len(problems)} problem(s) in impact table '{table}' "
                        "(use --on-error record to solve the valid rows):")
    found = impact_table_warnings(df, config, table)
    if bad_rows.any():
        found = [p for p in found if p.row is None or not bad_rows[p.row]]
    # solve valid rows only; bad rows are filled with a harmless configuration
    bad_pairs = bad_rows[:, None]
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
        for row in np.flatnonzero(big)[:20]:
            found.append(DataProblem(
                table, f"delta_v{i}", int(row), df["case_id"].iloc[row],
                f"delta-v {dv[row]:.4g} m/s of vehicle {i} is above the {MAX_DELTA_V:g} m/s of "
                "real crashes: speeds in km/h? (m/s required)"))
    from vfs.database.checks import settle

    settle([], found, header=f"impact table '{table}': plausibility warnings under --strict:")
    return out
