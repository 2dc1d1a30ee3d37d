"""The accident-case database schema (version 1.0), as data.

Every table of a database and every column of every table is described once,
here, by a :class:`ColumnSpec`.  Validation (:mod:`vfs.database.validation`),
dtype normalisation after reading (:func:`normalise_table`) and the column
tables of ``docs/data-format.md`` (:func:`schema_markdown`) are all generated
from :data:`TABLES`; nothing else lists columns, units or ranges.

Values in memory are SI (m, s, kg, rad, m/s).  A column may be stored in
files in another unit (:attr:`ColumnSpec.file_unit`: the PDOF and
velocity-angle-change columns are stored in degrees, as in accident
databases); the readers of :mod:`vfs.database.io` convert such columns to SI
once, on loading (:func:`table_from_file_units`), and the writers convert
them back (:func:`table_to_file_units`).  Ranges (:attr:`ColumnSpec.lo`,
:attr:`ColumnSpec.hi`) are SI; the documentation shows them in the file unit.
The vehicle-parameter ranges are those of
:data:`vfs.physics.vehicle.PARAMETER_RANGES`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.errors import ParameterError
from vfs.physics.post_impact import MAX_STEER, MAX_STEER_ONSET, MAX_WHEEL_DRAG
from vfs.physics.runout import WHEEL_NAMES
from vfs.physics.vehicle import PARAMETER_RANGES

#: The schema version written to and expected in ``meta.json``.
SCHEMA_VERSION = "1.0"
#: Schema versions this code can read.
SUPPORTED_SCHEMA_VERSIONS: tuple[str, ...] = (SCHEMA_VERSION,)
#: Suffix of the optional uncertainty (standard deviation) columns of the reconstruction.
UNCERTAINTY_SUFFIX = "_sd"
#: Largest allowed spacing of trajectory samples [s].
MAX_SAMPLE_SPACING = 0.1
#: Smallest number of samples of one trajectory.
MIN_TRAJECTORY_SAMPLES = 2

ColumnKind = Literal["int", "float", "bool", "str"]

#: pandas dtype of each column kind after normalisation.  Strings use the
#: pandas default string dtype (``"str"``, NaN as missing value; a
#: normalised string column never holds missing values, only ``""``).
PANDAS_DTYPES: dict[str, object] = {
    "int": np.dtype("int64"),
    "float": np.dtype("float64"),
    "bool": np.dtype("bool"),
    "str": pd.StringDtype(na_value=np.nan),
}
#: Names of the column kinds in the documentation.
KIND_NAMES: dict[str, str] = {"int": "int64", "float": "float64", "bool": "bool", "str": "string"}

#: Units a file column may use instead of its SI unit:
#: file unit -> (SI unit, file -> SI, SI -> file rounded to the nearest value).
FILE_UNITS: Mapping[str, tuple[str, Callable[[npt.ArrayLike], np.ndarray],
                               Callable[[npt.ArrayLike], np.ndarray]]] = {
    "deg": ("rad", np.radians, np.degrees),
}


def _exact_inverse(values: np.ndarray, to_si: Callable[[npt.ArrayLike], np.ndarray],
                   nearest: np.ndarray) -> np.ndarray:
    """File values that convert back to exactly ``values`` where one exists.

    ``nearest`` (the rounded conversion) misses for about 5 % of the angles;
    one of its neighbours (one unit in the last place either way) then hits
    whenever ``values`` came from a file, so that reading what was written
    gives the same SI values bit for bit.
    """
    out = nearest.copy()
    miss = to_si(out) != values
    for direction in (np.inf, -np.inf):
        if not miss.any():
            break
        step = np.nextafter(nearest, direction)
        hit = miss & (to_si(step) == values)
        out[hit] = step[hit]
        miss &= ~hit
    return out


@dataclass(frozen=True)
class ColumnSpec:
    """Specification of one column of one table.

    Attributes
    ----------
    name : str
        Column name (exact; other modules use it).
    kind : {"int", "float", "bool", "str"}
        Value kind; see :data:`PANDAS_DTYPES` for the pandas dtype.
    unit : str
        SI unit of the values in memory (``"-"`` for dimensionless, ``""``
        for non-numeric).
    description : str
        One-line meaning of the column.
    required : bool
        The column must be present.  An optional column that is absent is
        added with :attr:`default` on normalisation (when it has one).
    nullable : bool
        Missing values (NaN) are allowed.
    lo, hi : float
        Allowed range of numeric values [SI unit] (``-inf``/``inf`` =
        unbounded; finite values are always required).
    lo_open, hi_open : bool
        The bound itself is excluded.
    allowed : tuple
        Allowed values (for categorical columns); empty = any.
    default : object
        Value used for an absent optional column; ``None`` = no default.
    uncertainty : bool
        An optional ``<name>_sd`` column (standard deviation, same unit, >= 0)
        may accompany this column.
    file_unit : str
        Unit of the column in files when it differs from :attr:`unit` (a key
        of :data:`FILE_UNITS`, e.g. ``"deg"``); ``""`` = stored in SI.
    """

    name: str
    kind: ColumnKind
    unit: str
    description: str
    required: bool = True
    nullable: bool = False
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    allowed: tuple[object, ...] = ()
    default: object = None
    uncertainty: bool = False
    file_unit: str = ""

    def __post_init__(self) -> None:
        if self.file_unit and FILE_UNITS[self.file_unit][0] != self.unit:
            raise ParameterError(f"column {self.name}: file unit {self.file_unit!r} does not "
                             f"convert to {self.unit!r}")

    @property
    def stored_unit(self) -> str:
        """Unit of the column in files (the documented unit)."""
        return self.file_unit or self.unit

    def from_file(self, values: npt.ArrayLike) -> np.ndarray:
        """Values as stored in files -> SI values (the identity for SI columns)."""
        if not self.file_unit:
            return np.asarray(values, dtype=float)
        return FILE_UNITS[self.file_unit][1](np.asarray(values, dtype=float))

    def to_file(self, values: npt.ArrayLike) -> np.ndarray:
        """SI values -> values as stored in files (the identity for SI columns).

        ``from_file(to_file(v)) == v`` bit for bit for every ``v`` that
        came from a file or from :meth:`as_stored`, so that writing and
        reading a database changes nothing.
        """
        v = np.asarray(values, dtype=float)
        if not self.file_unit:
            return v
        _, to_si, from_si = FILE_UNITS[self.file_unit]
        return _exact_inverse(v, to_si, from_si(v))

    def as_stored(self, values: npt.ArrayLike) -> np.ndarray:
        """SI values rounded to what the file unit can hold (the identity for SI columns).

        ``v`` converted to the file unit, rounded to the nearest double, and
        back (for degrees: ``radians(degrees(v))``, a change of at most one
        unit in the last place).  A value computed in SI compares exactly
        equal with the same value written to a file in the file unit and read
        back; the result is unchanged by writing and reading.
        """
        v = np.asarray(values, dtype=float)
        if not self.file_unit:
            return v
        _, to_si, from_si = FILE_UNITS[self.file_unit]
        return to_si(from_si(v))

    @property
    def dtype(self) -> object:
        """Pandas dtype of the column after normalisation."""
        return PANDAS_DTYPES[self.kind]

    @property
    def has_range(self) -> bool:
        """True if the column has a finite lower or upper bound."""
        return math.isfinite(self.lo) or math.isfinite(self.hi)

    def allowed_text(self) -> str:
        """Human-readable allowed values in the file unit, e.g. ``"[0.05, 1.5]"`` or
        ``"{dry, wet}"``.
        """
        if self.allowed:
            return "{" + ", ".join(str(v) for v in self.allowed) + "}"
        if self.kind == "bool":
            return "{True, False}"
        if self.kind == "str":
            return "any text"
        if not self.has_range:
            return "any finite value"
        left = "(" if self.lo_open or not math.isfinite(self.lo) else "["
        right = ")" if self.hi_open or not math.isfinite(self.hi) else "]"
        lo, hi = (float(v) for v in self.to_file([self.lo, self.hi]))
        return f"{left}{_fmt(lo)}, {_fmt(hi)}{right}"

    def uncertainty_spec(self) -> ColumnSpec:
        """Specification of the ``<name>_sd`` column of this column."""
        return ColumnSpec(
            name=self.name + UNCERTAINTY_SUFFIX, kind="float", unit=self.unit,
            description=f"standard deviation of {self.name}", required=False,
            nullable=True, lo=0.0, file_unit=self.file_unit,
        )


def _fmt(value: float) -> str:
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:g}"


@dataclass(frozen=True)
class TableSpec:
    """Specification of one table of the database.

    Attributes
    ----------
    name : str
        Table name; the file is ``<name>.parquet`` (or ``<name>.csv``).
    description : str
        What one row is.
    columns : tuple[ColumnSpec, ...]
        The columns, in the order they are written.
    key : tuple[str, ...]
        Columns that identify a row (unique together).
    accepts_uncertainty : bool
        ``<column>_sd`` columns are validated for columns with
        :attr:`ColumnSpec.uncertainty`.
    """

    name: str
    description: str
    columns: tuple[ColumnSpec, ...]
    key: tuple[str, ...]
    accepts_uncertainty: bool = False

    @property
    def column_names(self) -> tuple[str, ...]:
        """Names of the schema columns, in order."""
        return tuple(c.name for c in self.columns)

    def column(self, name: str) -> ColumnSpec:
        """Specification of column ``name`` (including ``<column>_sd`` columns)."""
        for c in self.columns:
            if c.name == name:
                return c
        if self.accepts_uncertainty and name.endswith(UNCERTAINTY_SUFFIX):
            base = self.column(name[: -len(UNCERTAINTY_SUFFIX)])
            if base.uncertainty:
                return base.uncertainty_spec()
        raise KeyError(f"table {self.name!r} has no column {name!r}")

    def known_columns(self, present: list[str] | tuple[str, ...]) -> list[ColumnSpec]:
        """Specs of all schema columns plus the uncertainty columns in ``present``."""
        specs = list(self.columns)
        if self.accepts_uncertainty:
            present_set = set(present)
            specs += [
                c.uncertainty_spec() for c in self.columns
                if c.uncertainty and c.name + UNCERTAINTY_SUFFIX in present_set
            ]
        return specs


# ----------------------------------------------------------------------------
# The tables
# ----------------------------------------------------------------------------


def _vehicle_column(name: str, unit: str, description: str, nullable: bool = False) -> ColumnSpec:
    lo, hi = PARAMETER_RANGES[name]  # one place for the vehicle ranges: vfs.physics.vehicle
    return ColumnSpec(name, "float", unit, description, nullable=nullable, lo=lo, hi=hi)


_CASE_ID = ColumnSpec("case_id", "int", "-", "case identifier (e.g. the database case number)")
_PARTICIPANT = ColumnSpec(
    "participant", "int", "-", "participant number within the case", allowed=(1, 2)
)

CASES = TableSpec(
    name="cases",
    description="one row per accident case",
    key=("case_id",),
    columns=(
        ColumnSpec("case_id", "int", "-", "case identifier, unique"),
        ColumnSpec(
            "accident_type", "int", "-",
            "3-digit code of the German/Austrian accident-type catalogue "
            "(e.g. 241 head-on on a straight road, 242 head-on in a bend, "
            "264 oncoming while overtaking)",
            lo=100, hi=799,
        ),
        ColumnSpec("road_friction", "float", "-", "tyre-road friction coefficient mu",
                   lo=0.05, hi=1.5),
        ColumnSpec("road_surface", "str", "", "road surface condition",
                   allowed=("dry", "wet", "snow", "ice")),
        ColumnSpec("road_curvature", "float", "1/m",
                   "signed path curvature of the road at the collision (0 = straight, "
                   "positive = left bend)", lo=-0.2, hi=0.2),
        ColumnSpec("weight", "float", "-", "case weight (frequency factor)", required=False,
                   lo=0.0, lo_open=True, default=1.0),
        ColumnSpec("collision", "bool", "",
                   "True if the recorded paths collide; False for a near miss "
                   "(which then has no reconstruction row)"),
        ColumnSpec("description", "str", "", "free text", required=False, default=""),
    ),
)

PARTICIPANTS = TableSpec(
    name="participants",
    description="one row per vehicle; every case has exactly participants 1 and 2",
    key=("case_id", "participant"),
    columns=(
        _CASE_ID,
        _PARTICIPANT,
        _vehicle_column("mass", "kg", "mass"),
        _vehicle_column("yaw_inertia", "kg m^2",
                        "yaw moment of inertia about the CG; NaN = unknown (the default "
                        "formula of vfs.physics.vehicle is used)", nullable=True),
        _vehicle_column("length", "m", "overall length of the outline rectangle"),
        _vehicle_column("width", "m", "overall width of the outline rectangle"),
        _vehicle_column("wheelbase", "m", "distance between front and rear axle"),
        _vehicle_column("cg_to_front_axle", "m", "longitudinal distance CG to front axle (L1)"),
        _vehicle_column("front_overhang", "m", "distance front axle to front bumper"),
        _vehicle_column("track_width", "m", "distance between left and right wheels"),
        _vehicle_column("cg_height", "m", "height of the CG above ground"),
        ColumnSpec("vehicle_class", "str", "", "vehicle class, e.g. car, truck",
                   required=False, default="car"),
        ColumnSpec("fixed_object", "bool", "",
                   "True for a rigid fixed object (barrier, wall, pole): infinite mass and "
                   "yaw inertia in the impact (mass and yaw_inertia are then not used), "
                   "no run-out; the outline rectangle is its contact geometry",
                   required=False, default=False),
    ),
)

TRAJECTORIES = TableSpec(
    name="trajectories",
    description=(
        "pre-crash time series (PreCrash-Matrix-like), one row per sample; per "
        f"(case_id, participant) t strictly increasing, at least {MIN_TRAJECTORY_SAMPLES} "
        f"samples, spacing <= {MAX_SAMPLE_SPACING:g} s"
    ),
    key=("case_id", "participant", "t"),
    columns=(
        _CASE_ID,
        _PARTICIPANT,
        ColumnSpec("t", "float", "s", "time"),
        ColumnSpec("x", "float", "m", "CG position, global frame"),
        ColumnSpec("y", "float", "m", "CG position, global frame"),
        ColumnSpec("yaw", "float", "rad", "yaw angle, counter-clockwise from the global x axis"),
        ColumnSpec("speed", "float", "m/s", "magnitude of the CG velocity", lo=0.0),
        ColumnSpec("accel", "float", "m/s^2", "longitudinal acceleration; NaN = unknown",
                   nullable=True),
    ),
)


def _rec(name: str, unit: str, description: str, **kwargs: object) -> ColumnSpec:
    kwargs.setdefault("uncertainty", True)
    return ColumnSpec(name, "float", unit, description, **kwargs)  # type: ignore[arg-type]


def _per_vehicle(stem: str, unit: str, description: str, **kwargs: object) -> list[ColumnSpec]:
    return [
        _rec(f"{stem}{i}", unit, description.format(i=i), **kwargs) for i in (1, 2)
    ]


_CONFIGURATION: list[ColumnSpec] = []
for _i in (1, 2):
    _CONFIGURATION += [
        _rec(f"x{_i}", "m", f"CG x of participant {_i} at impact, global frame"),
        _rec(f"y{_i}", "m", f"CG y of participant {_i} at impact, global frame"),
        _rec(f"yaw{_i}", "rad", f"yaw angle of participant {_i} at impact"),
        _rec(f"vx{_i}", "m/s", f"CG velocity x of participant {_i} at impact, global frame"),
        _rec(f"vy{_i}", "m/s", f"CG velocity y of participant {_i} at impact, global frame"),
        _rec(f"yaw_rate{_i}", "rad/s", f"yaw rate of participant {_i} at impact"),
    ]
_OUTCOMES: list[ColumnSpec] = []
for _i in (1, 2):
    _OUTCOMES += [
        _rec(f"vx{_i}_post", "m/s", f"CG velocity x of participant {_i} after impact, global"),
        _rec(f"vy{_i}_post", "m/s", f"CG velocity y of participant {_i} after impact, global"),
        _rec(f"yaw_rate{_i}_post", "rad/s", f"yaw rate of participant {_i} after impact"),
    ]
_OUTCOMES += _per_vehicle("delta_v", "m/s", "magnitude of the CG velocity change of "
                          "participant {i}", lo=0.0)
_OUTCOMES += _per_vehicle("ees", "m/s", "energy equivalent speed of participant {i}", lo=0.0)
_OUTCOMES.append(_rec("energy_loss", "J", "kinetic energy lost in the impact", lo=0.0))
_OUTCOMES += _per_vehicle(
    "pdof", "rad", "principal direction of force on participant {i} in its vehicle frame "
    "(0 = frontal, clockwise positive seen from above)", lo=-math.pi, hi=math.pi,
    lo_open=True, file_unit="deg",
)
_OUTCOMES += _per_vehicle(
    "velocity_angle_change", "rad", "angle between the CG velocity of participant {i} "
    "before and after impact; NaN if a speed is zero", lo=0.0, hi=math.pi, nullable=True,
    file_unit="deg",
)
for _i in (1, 2):
    _OUTCOMES += [
        _rec(f"rest_x{_i}", "m", f"CG x of participant {_i} at rest, global frame"),
        _rec(f"rest_y{_i}", "m", f"CG y of participant {_i} at rest, global frame"),
        _rec(f"rest_yaw{_i}", "rad", f"yaw angle of participant {_i} at rest"),
    ]

#: The wheels of the per-wheel post-impact columns, in the order of
#: :data:`vfs.physics.runout.WHEEL_NAMES` (FL, FR, RL, RR), as column suffixes.
POST_IMPACT_WHEELS: tuple[str, ...] = tuple(w.lower() for w in WHEEL_NAMES)


def _post_impact_columns() -> list[ColumnSpec]:
    """The optional post-impact inputs of the run-out, per vehicle (``{i}`` = 1, 2).

    Absent columns and NaN values take the defaults of the run-out
    (:class:`vfs.physics.runout.RunoutParams`, :class:`vfs.physics.post_impact.PostImpactInputs`).
    """
    cols: list[ColumnSpec] = []
    for i in (1, 2):
        cols += [
            ColumnSpec(f"post_brake_{w}{i}", "float", "-",
                       f"brake factor of the {w.upper()} wheel of participant {i} after the "
                       "impact: 1 = locked (sliding), b < 1 = rolling, braked with b mu N; "
                       f"NaN or absent = post_driver_brake{i}", required=False,
                       nullable=True, lo=0.0, hi=1.0)
            for w in POST_IMPACT_WHEELS]
        cols.append(ColumnSpec(
            f"post_driver_brake{i}", "float", "-",
            f"driver braking of participant {i} after the crash, as the brake factor of "
            "every wheel without its own post_brake value (0 = no braking, 1 = locked "
            "wheels); NaN or absent = the run-out default (RunoutParams.wheel_brake, 0.8)",
            required=False, nullable=True, lo=0.0, hi=1.0))
        cols += [
            ColumnSpec(f"post_drag_{w}{i}", "float", "-",
                       f"extra rolling drag of the {w.upper()} wheel of participant {i} "
                       "after the impact, as a coefficient of its wheel load (a wheel "
                       "rubbing on the deformed body, the engine in gear), added to the "
                       "rolling resistance; NaN or absent = 0", required=False,
                       nullable=True, lo=0.0, hi=MAX_WHEEL_DRAG)
            for w in POST_IMPACT_WHEELS]
        cols += [
            ColumnSpec(f"post_steer{i}", "float", "rad",
                       f"steer angle of both front wheels of participant {i} after the "
                       "impact, positive = to the left; NaN or absent = 0 (straight)",
                       required=False, nullable=True, lo=-MAX_STEER,
                       hi=MAX_STEER, file_unit="deg"),
            ColumnSpec(f"post_steer_onset{i}", "float", "s",
                       f"time after the separation at which post_steer{i} sets in (before: "
                       "straight); NaN or absent = 0", required=False, nullable=True,
                       lo=0.0, hi=MAX_STEER_ONSET),
        ]
    return cols


#: The optional post-impact input columns of the reconstruction (:func:`_post_impact_columns`).
POST_IMPACT_COLUMNS: tuple[ColumnSpec, ...] = tuple(_post_impact_columns())

#: Values of the reconstruction's ``outcome_source`` column.
OUTCOME_RECONSTRUCTION, OUTCOME_MEASUREMENT = "reconstruction", "measurement"
#: Reconstruction columns a measurement row may leave NaN ("not measured"): the
#: outcomes and the impact parameters (a crash test measures no restitution).
MEASURABLE_COLUMNS: tuple[str, ...] = (
    "restitution", "contact_friction", *(c.name for c in _OUTCOMES))
_OUTCOMES = [replace(c, nullable=True) if not c.nullable else c for c in _OUTCOMES]

RECONSTRUCTION = TableSpec(
    name="reconstruction",
    description=(
        "the expert's reconstruction, one row per colliding case (wide: suffix 1/2 = "
        "participant); optional `<column>_sd` columns (standard deviation, same unit, "
        ">= 0) for any float column; unknown extra columns are kept; NaN in restitution, "
        "contact_friction and the outcome columns (and an empty impact_type) only in "
        "rows with outcome_source = 'measurement', where they mean 'not measured'"
    ),
    key=("case_id",),
    accepts_uncertainty=True,
    columns=(
        ColumnSpec("case_id", "int", "-", "case identifier"),
        _rec("t_impact", "s", "time of the impact on the trajectory time axis"),
        *_CONFIGURATION,
        _rec("poi_x", "m", "point of impact x, global frame"),
        _rec("poi_y", "m", "point of impact y, global frame"),
        _rec("cp_angle", "rad", "tangent direction of the contact plane (orientation "
             "irrelevant)"),
        _rec("restitution", "-", "coefficient of restitution", lo=0.0, hi=1.0,
             nullable=True),
        _rec("contact_friction", "-", "friction coefficient between the vehicles", lo=0.0,
             hi=2.0, nullable=True),
        ColumnSpec("impact_type", "str", "", "impact model ('' = not known, measurement "
                   "rows only)", allowed=("full", "sliding", "")),
        *_OUTCOMES,
        ColumnSpec("outcome_source", "str", "",
                   "where the outcome values come from: 'reconstruction' (an expert's "
                   "reconstruction, every outcome given) or 'measurement' (an instrumented "
                   "test: only measured outcomes are given, NaN = not measured, `_sd` = "
                   "measurement uncertainty; NaN restitution / contact friction = the "
                   "model default)", required=False,
                   allowed=(OUTCOME_RECONSTRUCTION, OUTCOME_MEASUREMENT),
                   default=OUTCOME_RECONSTRUCTION),
        *POST_IMPACT_COLUMNS,
    ),
)

#: All tables of a database, in the order they are documented and written.
TABLES: dict[str, TableSpec] = {
    t.name: t for t in (CASES, PARTICIPANTS, TRAJECTORIES, RECONSTRUCTION)
}
TABLE_NAMES: tuple[str, ...] = tuple(TABLES)

#: Keys of ``meta.json`` and their meaning (documented; only ``schema_version`` is checked).
META_KEYS: dict[str, str] = {
    "schema_version": f'schema version of the files, "{SCHEMA_VERSION}"',
    "name": "short name of the database",
    "created_by": "who or what created it (person, tool and version)",
    "description": "free text: source, selection, remarks",
    "has_reconstruction": (
        "optional, default true; false for databases without expert reconstruction "
        "(e.g. PCM imports): the collision/reconstruction consistency check is skipped"
    ),
    "pcm_import": "optional; written by import_pcm: the defaults it used and skipped cases",
    "equip": ('optional: "1", "2" or "both", the vehicles a study equips unless --equip says '
              'otherwise (the Euro NCAP matrix: "1", the VUT)'),
    "test_protocol": "optional; the test protocol a test-matrix database implements",
    "columns": (
        "optional: unit and description of columns beyond the schema, "
        '{"table": {"column": {"unit": "J", "description": "..."}}}; the Parquet writer '
        "puts them into the field metadata"
    ),
}


# ----------------------------------------------------------------------------
# Dtype normalisation
# ----------------------------------------------------------------------------

_TRUE_STRINGS = frozenset({"true", "1", "yes"})
_FALSE_STRINGS = frozenset({"false", "0", "no"})


def _as_bool(series: pd.Series) -> pd.Series | None:
    """Convert a column to numpy bool if that is lossless, else None."""
    if series.dtype == bool:
        return series
    if series.isna().any():
        return None
    if pd.api.types.is_numeric_dtype(series.dtype):
        values = series.to_numpy(dtype=float)
        if np.isin(values, (0.0, 1.0)).all():
            return pd.Series(values == 1.0, index=series.index, name=series.name)
        return None
    text = series.astype(str).str.strip().str.lower()
    if text.isin(_TRUE_STRINGS | _FALSE_STRINGS).all():
        return text.isin(_TRUE_STRINGS).astype(bool)
    return None


def _normalise_column(series: pd.Series, spec: ColumnSpec) -> pd.Series:
    """Convert one column to the dtype of its spec where that loses nothing."""
    if spec.kind == "str":
        converted = series.astype(object).where(series.notna(), "")
        return converted.map(str).astype(spec.dtype)
    if spec.kind == "bool":
        as_bool = _as_bool(series)
        return series if as_bool is None else as_bool
    if series.dtype == bool or not pd.api.types.is_numeric_dtype(series.dtype):
        numeric = pd.to_numeric(series, errors="coerce")
        if (numeric.isna() & series.notna()).any():
            return series  # non-numeric text: left for validation to report
        series = numeric
    if spec.kind == "float":
        return series.astype(np.float64)
    values = series.to_numpy(dtype=float)
    if np.isfinite(values).all() and (values == np.round(values)).all():
        return series.astype(np.int64)
    return series.astype(np.float64)


def table_column_order(table: str, columns: list[str] | tuple[str, ...]) -> list[str]:
    """Deterministic column order: schema columns, uncertainty columns, then extras sorted."""
    spec = TABLES[table]
    known = [c.name for c in spec.known_columns(list(columns)) if c.name in columns]
    extras = sorted(c for c in columns if c not in set(known))
    return known + extras


def normalise_table(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """Return ``df`` with schema dtypes, defaults for absent optional columns and column order.

    Conversions are lossless only: a value that cannot be converted (text in a
    numeric column, NaN in an integer column) leaves its column as it is, for
    :func:`vfs.database.validation.validate_database` to report.  String
    columns never hold missing values afterwards (missing becomes ``""``).

    Parameters
    ----------
    df : pandas.DataFrame
        Table as read from a file or built in memory.
    table : str
        Table name, a key of :data:`TABLES`.

    Returns
    -------
    pandas.DataFrame
        New frame with a fresh ``RangeIndex``.
    """
    spec = TABLES[table]
    out = df.reset_index(drop=True).copy()
    for col in spec.known_columns(list(out.columns)):
        if col.name not in out.columns:
            if not col.required and col.default is not None:
                out[col.name] = pd.Series([col.default] * len(out), dtype=col.dtype)
            continue
        out[col.name] = _normalise_column(out[col.name], col)
    return out[table_column_order(table, list(out.columns))]


def _convert_units(df: pd.DataFrame, table: str, to_file: bool) -> pd.DataFrame:
    spec = TABLES[table]
    out = df
    for col in spec.known_columns(list(df.columns)):
        if not col.file_unit or col.name not in df.columns:
            continue
        series = df[col.name]
        if series.dtype == bool or not pd.api.types.is_numeric_dtype(series.dtype):
            continue  # not numeric: left for validation to report
        values = series.to_numpy(dtype=float, na_value=np.nan)
        if out is df:
            out = df.copy()
        out[col.name] = col.to_file(values) if to_file else col.from_file(values)
    return out


def table_from_file_units(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """A table as read from a file with every column in SI units.

    Columns with a :attr:`ColumnSpec.file_unit` (and their ``_sd`` columns)
    are converted once (degrees -> rad); non-numeric columns are left for
    validation to report.  Returns ``df`` itself when nothing is converted.

    Parameters
    ----------
    df : pandas.DataFrame
        Normalised table (:func:`normalise_table`) in file units.
    table : str
        Table name, a key of :data:`TABLES`.
    """
    return _convert_units(df, table, to_file=False)


def table_as_stored(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """A table in SI units with every column rounded to what its file unit can hold
    (:meth:`ColumnSpec.as_stored`); writing and reading it changes nothing.
    """
    spec = TABLES[table]
    out = df.copy()
    for col in spec.known_columns(list(df.columns)):
        if col.file_unit and col.name in df.columns:
            out[col.name] = col.as_stored(df[col.name].to_numpy(dtype=float, na_value=np.nan))
    return out


def table_to_file_units(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """A table in SI units with its columns converted to the units of the files.

    The inverse of :func:`table_from_file_units` (rad -> degrees), used by the
    writers so that files keep the documented format.
    """
    return _convert_units(df, table, to_file=True)


def empty_table(table: str) -> pd.DataFrame:
    """An empty table with all schema columns and their dtypes."""
    spec = TABLES[table]
    return pd.DataFrame({c.name: pd.Series([], dtype=c.dtype) for c in spec.columns})


# ----------------------------------------------------------------------------
# Documentation
# ----------------------------------------------------------------------------


def _md_escape(text: str) -> str:
    return text.replace("|", "\\|")


def schema_markdown(tables: Mapping[str, TableSpec] | None = None) -> str:
    """Render the schema as Markdown: one section and one column table per table.

    Parameters
    ----------
    tables : mapping, optional
        Tables to render; default :data:`TABLES`.

    Returns
    -------
    str
        Markdown text (ends with a newline).
    """
    tables = TABLES if tables is None else tables
    lines: list[str] = []
    for spec in tables.values():
        lines += [f"### `{spec.name}.parquet`", "", f"{spec.description[0].upper()}"
                  f"{spec.description[1:]}. Key: {', '.join(spec.key)}.", ""]
        lines.append("| column | type | unit | required | allowed | description |")
        lines.append("|---|---|---|---|---|---|")
        for c in spec.columns:
            required = "yes" if c.required else f"no (default {c.default!r})" if (
                c.default is not None) else "no"
            allowed = c.allowed_text() + (", NaN allowed" if c.nullable else "")
            unit = c.stored_unit
            name = f"`{c.name}`" + (" (+`_sd`)" if c.uncertainty else "")
            lines.append(
                f"| {name} | {KIND_NAMES[c.kind]} | {_md_escape(unit)} | {required} | "
                f"{_md_escape(allowed)} | {_md_escape(c.description)} |"
            )
        lines.append("")
    lines.append("### `meta.json`")
    lines.append("")
    lines.append("| key | meaning |")
    lines.append("|---|---|")
    for key, meaning in META_KEYS.items():
        lines.append(f"| `{key}` | {_md_escape(meaning)} |")
    return "\n".join(lines) + "\n"
