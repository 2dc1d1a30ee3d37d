"""Self-describing tables: units, descriptions and ranges in Parquet field metadata, and
the database schema as JSON or a Frictionless Table Schema.

Every Parquet file vfs writes (database tables, study chunks and runs, report tables)
carries, per column it knows, the field metadata keys ``unit``, ``description`` and
``allowed`` (bytes, UTF-8), so that DuckDB (``parquet_kv_metadata``), pyarrow
(``schema.field(name).metadata``), Polars or R see that ``delta_v1`` is in m/s.
:func:`field_metadata` looks a column up in the schema (:data:`vfs.database.schema.TABLES`,
then the outcome columns of study runs); :func:`schema_json` and
:func:`frictionless_schema` describe the whole database for other tools.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from vfs.database.schema import TABLES, ColumnSpec, TableSpec

#: Study-run columns that are not database columns (results_table): unit, description.
RUN_COLUMNS: dict[str, tuple[str, str]] = {
    "system": ("", "AEB system of the run ('baseline' = no system)"),
    "collided": ("", "the run ends in a collision"),
    "avoided": ("", "the baseline collided and this run did not"),
    "error": ("", "error message of a failed run, else empty"),
    "contact_time": ("s", "first contact of the outlines, record time"),
    "impact_time": ("s", "exchange of momentum (first contact + penetration), record time"),
    "closing_speed": ("m/s", "relative speed of the POIs along the contact normal"),
    "overlap_area": ("m^2", "overlap of the outlines at impact"),
    "energy_loss": ("J", "kinetic energy lost in the impact"),
    "min_distance": ("m", "smallest outline distance of a run without collision"),
    "time_closest": ("s", "time of the smallest outline distance"),
    "secondary_collision": ("", "the outlines overlap again during the run-out"),
    "secondary_collision_time": ("s", "time of the secondary collision from separation"),
    "cp_rule": ("-", "contact-plane rule applied: 0 no contact, 1 line through the two "
                     "intersection points, 2 the two farthest apart, 3 perpendicular to the CG "
                     "line, 4 along the touching edges (vfs.physics.geometry.CP_RULES)"),
}
_PER_VEHICLE_RUN = {
    "impact_speed": ("m/s", "speed of participant {i} at impact"),
    "time_to_rest": ("s", "run-out time of participant {i} to rest"),
    "runout_distance": ("m", "path length of participant {i} from separation to rest"),
    "at_rest": ("", "participant {i} reached rest within the run-out's time limit"),
    "brake_start": ("s", "first braking of participant {i} (record time)"),
    "speed_reduction": ("m/s", "speed reduction of participant {i} by braking before impact"),
    "equipped": ("", "participant {i} carries the system"),
    # braking of the system (vfs.gym.benchmark.ComfortRecorder: gym evaluations)
    "peak_decel": ("m/s^2", "peak deceleration of the system's brake on participant {i} while "
                            "it moves"),
    "peak_jerk": ("m/s^3", "peak rate of change of the system's brake deceleration on "
                           "participant {i} while it moves"),
    "harsh_time": ("s", "time with the system's brake on participant {i} above 4 m/s^2 "
                        "while it moves"),
    "brake_time": ("s", "time with the system's brake on participant {i} at or above 1 m/s^2 "
                        "while it moves"),
    "speed_taken": ("m/s", "speed the system's brake takes from participant {i} (its "
                           "deceleration integrated while it moves)"),
    "start_speed": ("m/s", "speed of participant {i} at the first step of a system run"),
    # AEB events (vfs.adas.controller.EVENT_KEYS); NaN where it never happened
    "warning_time": ("s", "first AEB warning of participant {i} (record time)"),
    "partial_time": ("s", "first partial AEB braking of participant {i} (record time)"),
    "full_time": ("s", "first full AEB braking of participant {i} (record time)"),
    "ttc_at_trigger": ("s", "time to collision measured when the first AEB stage of "
                            "participant {i} triggered"),
    "driver_reaction_time": ("s", "sampled reaction time of the driver of participant {i} "
                                  "(drivers who brake)"),
    "driver_brake_time": ("s", "start of the braking demand of the driver of participant {i} "
                               "(record time)"),
    "driver_deceleration": ("m/s^2", "sampled deceleration of the driver of participant {i} "
                                     "(drivers who brake)"),
}


def _spec_lookup() -> dict[str, ColumnSpec]:
    out: dict[str, ColumnSpec] = {}
    for spec in TABLES.values():
        for col in spec.columns:
            out.setdefault(col.name, col)
            if spec.accepts_uncertainty and getattr(col, "uncertainty", False):
                sd = col.uncertainty_spec()
                out.setdefault(sd.name, sd)
    return out


def extra_column_metadata(meta: Mapping[str, Any], table: str,
                          columns: Iterable[str]) -> dict[str, dict[str, str]]:
    """Field metadata of the columns beyond the schema that ``meta["columns"]`` documents.

    Parameters
    ----------
    meta : mapping
        A database's ``meta`` (``meta.json``); its optional key ``columns`` maps table ->
        column -> ``{"unit": ..., "description": ...}``.
    table : str
        The table.
    columns : iterable of str
        The table's columns; documented columns that are absent are left out.
    """
    documented = meta.get("columns") or {}
    own = documented.get(table) or {} if isinstance(documented, Mapping) else {}
    out: dict[str, dict[str, str]] = {}
    for name in columns:
        doc = own.get(name) if isinstance(own, Mapping) else None
        if isinstance(doc, Mapping):
            out[name] = {k: str(doc[k]) for k in ("unit", "description") if k in doc}
    return out


def field_metadata(columns: Iterable[str], *, table: str | None = None,
                   stored: bool = False) -> dict[str, dict[str, str]]:
    """Field metadata (``unit``, ``description``, ``allowed``) of the known ``columns``.

    Parameters
    ----------
    columns : iterable of str
        Column names; unknown ones are left out.
    table : str, optional
        Database table to look in first (a name of :data:`TABLES`).
    stored : bool
        Units as stored in database files (degrees for the angle columns that keep
        them) instead of SI (study runs and reports are SI).
    """
    first: dict[str, ColumnSpec] = {}
    if table is not None and table in TABLES:
        first = {c.name: c for c in TABLES[table].columns}
    known = _spec_lookup()
    out: dict[str, dict[str, str]] = {}
    for name in columns:
        spec = first.get(name) or known.get(name)
        if spec is not None:
            unit = spec.stored_unit if stored else spec.unit
            allowed = spec.allowed_text() if stored else _allowed_si(spec)
            out[name] = {"unit": unit, "description": spec.description, "allowed": allowed}
            continue
        entry = RUN_COLUMNS.get(name)
        if entry is None and name[-1:] in ("1", "2") and name[:-1] in _PER_VEHICLE_RUN:
            unit, text = _PER_VEHICLE_RUN[name[:-1]]
            entry = (unit, text.format(i=name[-1]))
        if entry is not None:
            out[name] = {"unit": entry[0], "description": entry[1]}
    return out


class ColumnTexts(dict[str, str]):
    """A read-only ``column -> text`` dict: the units and descriptions in ``frame.attrs``.

    pandas deep-copies a frame's ``attrs`` into every frame derived from it (each column
    selection, slice and copy: ``NDFrame.__finalize__``); a ``ColumnTexts`` is its own
    deep copy, so the copies share it instead of copying every key, which cost the
    database checks and the study a quarter of a million ``copy.deepcopy`` calls per
    3,000 cases.  Sharing is safe because it cannot change: its mutating methods raise
    ``TypeError``; to change a frame's units assign a new dict
    (``frame.attrs["units"] = {**frame.attrs["units"], "my_column": "m"}``).  It is a
    ``dict`` otherwise (equal to the plain dict of its items, JSON and pickle as one).
    """

    __slots__ = ()

    def __deepcopy__(self, memo: dict[int, Any]) -> ColumnTexts:
        return self

    def __copy__(self) -> ColumnTexts:
        return self

    def __reduce__(self) -> tuple[type[ColumnTexts], tuple[dict[str, str]]]:
        return type(self), (dict(self),)

    def _read_only(self, *args: Any, **kwargs: Any) -> Any:
        raise TypeError("units and descriptions in frame.attrs are read-only: assign a new "
                        "dict to frame.attrs[...] to change them")

    __setitem__ = __delitem__ = __ior__ = _read_only
    clear = pop = popitem = setdefault = update = _read_only


def with_units(frame: Any, table: str | None = None,
               metadata: Mapping[str, Mapping[str, str]] | None = None) -> Any:
    """``frame`` with its columns' units and descriptions in ``frame.attrs``.

    ``attrs["units"]`` maps column -> unit (SI, "" or "-" for flags, names and ratios) and
    ``attrs["descriptions"]`` column -> description, for every column vfs knows (from
    ``metadata``, e.g. a Parquet file's field metadata, else :func:`field_metadata`), each a
    read-only :class:`ColumnTexts` (shared by the frames pandas derives, not deep-copied
    into each).  The frame is changed in place and returned; pandas keeps ``attrs`` through
    copies and most selections.

    Parameters
    ----------
    frame : pandas.DataFrame
    table : str, optional
        Database table whose columns to prefer (:data:`TABLES`).
    metadata : mapping, optional
        Column -> ``{"unit": ..., "description": ...}`` read with the data.
    """
    known = field_metadata(frame.columns, table=table)
    given = dict(metadata or {})
    units, texts = {}, {}
    for name in frame.columns:
        entry = given.get(name) or known.get(name)
        if entry and ("unit" in entry or "description" in entry):
            units[name] = str(entry.get("unit", ""))
            texts[name] = str(entry.get("description", ""))
    frame.attrs["units"] = ColumnTexts(units)
    frame.attrs["descriptions"] = ColumnTexts(texts)
    return frame


def read_parquet_with_units(path: Any, **options: Any) -> Any:
    """A Parquet file as a DataFrame with the units and descriptions of its field metadata in
    ``attrs`` (:func:`with_units`; columns without metadata looked up in the schema).
    """
    import pandas as pd
    import pyarrow.parquet as pq

    frame = pd.read_parquet(path, **options)
    fields = {f.name: {k.decode(): v.decode() for k, v in (f.metadata or {}).items()}
              for f in pq.read_schema(path)}
    return with_units(frame, metadata={k: v for k, v in fields.items() if v})


def _allowed_si(spec: ColumnSpec) -> str:
    """Allowed values in SI (the file-unit text of :meth:`ColumnSpec.allowed_text` otherwise)."""
    if spec.allowed or spec.kind in ("bool", "str"):
        return spec.allowed_text()
    if not spec.has_range:
        return "any finite value"
    left = "(" if spec.lo_open or not math.isfinite(spec.lo) else "["
    right = ")" if spec.hi_open or not math.isfinite(spec.hi) else "]"
    return f"{left}{spec.lo:g}, {spec.hi:g}{right}"


def _table_json(spec: TableSpec) -> dict[str, Any]:
    cols = []
    for c in spec.columns:
        cols.append({"name": c.name, "type": c.kind, "unit": c.stored_unit,
                     "description": c.description, "required": c.required,
                     "nullable": c.nullable, "allowed": c.allowed_text(),
                     **({"uncertainty_column": c.name + "_sd"} if getattr(c, "uncertainty", False)
                        else {})})
    return {"name": spec.name, "description": spec.description, "key": list(spec.key),
            "columns": cols}


def schema_json() -> dict[str, Any]:
    """The database schema as plain JSON (units as stored in the files)."""
    from vfs.database.schema import SCHEMA_VERSION

    return {"schema_version": SCHEMA_VERSION,
            "tables": [_table_json(spec) for spec in TABLES.values()]}


_FRICTIONLESS_TYPES = {"float": "number", "int": "integer", "bool": "boolean", "str": "string",
                       "id": "any"}


def frictionless_schema() -> dict[str, Any]:
    """A Frictionless Data Package of the four tables (Table Schema per resource).

    Units go into the custom field property ``unit`` (Table Schema has none); numeric
    ranges into ``constraints`` (``minimum``/``maximum`` in the stored unit; open
    bounds are not expressible there and are given as ``allowed``).
    """
    resources = []
    for spec in TABLES.values():
        fields = []
        for c in spec.columns:
            f: dict[str, Any] = {"name": c.name,
                                 "type": _FRICTIONLESS_TYPES.get(str(c.kind), "any"),
                                 "description": c.description, "unit": c.stored_unit,
                                 "allowed": c.allowed_text()}
            cons: dict[str, Any] = {}
            if c.required and not c.nullable:
                cons["required"] = True
            if c.allowed:
                cons["enum"] = list(c.allowed)
            elif c.kind in ("float", "int") and c.has_range:
                lo, hi = (float(v) for v in c.to_file([c.lo, c.hi]))
                if math.isfinite(lo) and not c.lo_open:
                    cons["minimum"] = lo
                if math.isfinite(hi) and not c.hi_open:
                    cons["maximum"] = hi
            if cons:
                f["constraints"] = cons
            fields.append(f)
        schema: dict[str, Any] = {"fields": fields}
        if spec.key:
            schema["primaryKey"] = list(spec.key)
        resources.append({"name": spec.name, "path": f"{spec.name}.parquet",
                          "format": "parquet", "description": spec.description,
                          "schema": schema})
    return {"profile": "data-package", "name": "vfs-database", "resources": resources}


__all__ = ["RUN_COLUMNS", "ColumnTexts", "extra_column_metadata", "field_metadata",
           "frictionless_schema", "read_parquet_with_units", "schema_json", "with_units"]
