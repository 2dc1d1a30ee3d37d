"""The outcome vocabulary: every outcome of a collision that vfs compares or reports.

One record per quantity (:class:`Outcome`): its name, label, quantity kind
(:class:`Quantity`: SI unit, display unit and factor), level (one value per
vehicle or per case), how its values are distributed (``kind``), whether
differences wrap around (directions), the reconstruction's standard-deviation
columns that scale it, and **one** derivation from columns.  The simulation
results (:func:`from_results`: a :class:`vfs.simulation.CaseResults` or a
:func:`vfs.simulation.results_table`) and the reconstruction rows
(:func:`from_reconstruction`: the SI table of :mod:`vfs.database`) name their
columns alike (``delta_v1``, ``vx1_post``, ``rest_x1``, ``x1`` = CG at
impact, ``impact_type`` ...), so the same derivation serves both and a
model value and a recorded value of an outcome are always formed the same way.

Everything is SI (m/s, rad, m, rad/s, J); :class:`Quantity` converts to the
display units (km/h, deg, kJ, %) of reports and command-line flags.

Effects name the outcomes they change in groups (:data:`OUTPUT_GROUPS`, the
vocabulary of :attr:`vfs.effects.Effect.outputs`): ``rest_position`` is
``rest_x`` and ``rest_y``, ``impact_type`` is ``sliding``.

Note that the run-out outcome :data:`runout_distance <OUTCOMES_BY_NAME>` is the
straight-line distance from the CG at impact to the CG at rest; the
``runout_distance{i}`` column of :func:`vfs.simulation.results_table` is the
length of the CG path and is not used here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from vfs.errors import ParameterError
from vfs.physics.impact import impact_type_names
from vfs.units import KMH_PER_MS, wrap_angle

if TYPE_CHECKING:  # pragma: no cover
    from vfs.simulation import CaseResults

# ----------------------------------------------------------------------------
# Quantities and units
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Quantity:
    """A kind of quantity with its SI unit and its display unit.

    Attributes
    ----------
    name : str
        ``speed``, ``angle``, ``rate``, ``length``, ``energy``,
        ``probability``, ``fraction`` or ``dimensionless``.
    si_unit : str
        Unit of the values inside vfs.
    display_unit : str
        Unit of reports and command-line values.
    display_factor : float
        Value [si_unit] x factor = value [display_unit].
    """

    name: str
    si_unit: str
    display_unit: str
    display_factor: float

    def to_display(self, values: Any) -> np.ndarray:
        """SI values -> display values (array)."""
        return np.asarray(values, dtype=float) * self.display_factor

    def from_display(self, values: Any) -> np.ndarray:
        """Display values -> SI values (array)."""
        return np.asarray(values, dtype=float) / self.display_factor


#: The quantity kinds by name.
QUANTITIES: Mapping[str, Quantity] = MappingProxyType({q.name: q for q in (
    Quantity("speed", "m/s", "km/h", KMH_PER_MS),
    Quantity("angle", "rad", "deg", 180.0 / math.pi),
    Quantity("rate", "rad/s", "deg/s", 180.0 / math.pi),
    Quantity("length", "m", "m", 1.0),
    Quantity("energy", "J", "kJ", 1e-3),
    Quantity("probability", "-", "%", 100.0),
    Quantity("fraction", "-", "%", 100.0),
    Quantity("dimensionless", "-", "-", 1.0),
)})


def unit_factors() -> dict[str, tuple[str, float]]:
    """Units accepted in values typed by users: unit (lower case) -> (quantity, factor to SI).

    Every SI and display unit of :data:`QUANTITIES` whose unit is not shared by
    two quantities, plus ``kmh`` for km/h.
    """
    seen: dict[str, list[tuple[str, float]]] = {}
    for q in QUANTITIES.values():
        for unit, factor in ((q.si_unit, 1.0), (q.display_unit, 1.0 / q.display_factor)):
            entry = (q.name, factor)
            if entry not in seen.setdefault(unit.lower(), []):
                seen[unit.lower()].append(entry)
    out = {u: e[0] for u, e in seen.items() if len(e) == 1 and u not in ("-", "%")}
    out["kmh"] = out["km/h"]
    return out


# ----------------------------------------------------------------------------
# Outcomes
# ----------------------------------------------------------------------------

Level = Literal["vehicle", "case"]
#: How the values of an outcome are distributed: ``ratio`` (non-negative
#: magnitude), ``signed`` (coordinates, accumulated angles), ``circular``
#: (directions) or ``indicator`` (0/1; a mean is a probability).
Kind = Literal["ratio", "signed", "circular", "indicator"]
#: How an outcome is formed from its columns (see :func:`derive`).
Derivation = Literal["value", "hypot", "displacement", "direction", "sliding"]

VEHICLES: tuple[int, int] = (1, 2)


@dataclass(frozen=True)
class Outcome:
    """One outcome quantity.

    Attributes
    ----------
    name : str
        Identifier; per-vehicle values are ``<name>1`` and ``<name>2``.
    label : str
        Name in reports.
    quantity : str
        Key of :data:`QUANTITIES`.
    level : {"vehicle", "case"}
        One value per vehicle or one per case.
    kind : {"ratio", "signed", "circular", "indicator"}
        Distribution of the values (uncertainty bands).
    derivation : {"value", "hypot", "displacement", "direction", "sliding"}
        How the value is formed from :attr:`columns` (:func:`derive`).
    columns : tuple of str
        Columns of the results and reconstruction tables it is formed from
        (``{i}`` = vehicle number).
    sd_columns : tuple of str
        Reconstruction ``_sd`` columns (standard deviations) of those columns.
    wrap : bool
        Differences are wrapped to (-pi, pi] (directions and yaw angles).
    description : str
        One-line meaning.
    """

    name: str
    label: str
    quantity: str
    level: Level
    kind: Kind
    derivation: Derivation
    columns: tuple[str, ...]
    sd_columns: tuple[str, ...]
    wrap: bool
    description: str

    def __post_init__(self) -> None:
        if self.quantity not in QUANTITIES:
            raise ParameterError(f"outcome {self.name}: unknown quantity {self.quantity!r}")

    @property
    def unit(self) -> str:
        """SI unit."""
        return QUANTITIES[self.quantity].si_unit

    @property
    def display_unit(self) -> str:
        """Unit in reports."""
        return QUANTITIES[self.quantity].display_unit

    @property
    def display_factor(self) -> float:
        """Factor from the SI unit to :attr:`display_unit`."""
        return QUANTITIES[self.quantity].display_factor

    @property
    def vehicles(self) -> tuple[int, ...]:
        """Vehicle numbers of the values: (1, 2), or (0,) for a case-level outcome."""
        return VEHICLES if self.level == "vehicle" else (0,)

    @property
    def value_names(self) -> tuple[str, ...]:
        """Names of the single values: ``<name>1``, ``<name>2`` or ``<name>``."""
        if self.level == "vehicle":
            return tuple(f"{self.name}{i}" for i in VEHICLES)
        return (self.name,)

    def columns_of(self, vehicle: int) -> tuple[str, ...]:
        """The columns of one vehicle (0 for a case-level outcome)."""
        return tuple(c.format(i=vehicle) for c in self.columns)

    def sd_columns_of(self, vehicle: int) -> tuple[str, ...]:
        """The ``_sd`` columns of one vehicle (0 for a case-level outcome)."""
        return tuple(c.format(i=vehicle) for c in self.sd_columns)


def _o(name: str, label: str, quantity: str, level: Level, kind: Kind, derivation: Derivation,
       columns: Iterable[str], description: str, wrap: bool = False,
       sd: Iterable[str] | None = None) -> Outcome:
    cols = tuple(columns)
    sd_columns = tuple(f"{c}_sd" for c in cols) if sd is None else tuple(sd)
    return Outcome(name, label, quantity, level, kind, derivation, cols, sd_columns, wrap,
                   description)


#: Every outcome, in report order.
OUTCOMES: tuple[Outcome, ...] = (
    _o("delta_v", "Delta-v", "speed", "vehicle", "ratio", "value", ["delta_v{i}"],
       "magnitude of the CG velocity change in the impact"),
    _o("ees", "EES", "speed", "vehicle", "ratio", "value", ["ees{i}"],
       "energy equivalent speed (deformation energy as a speed)"),
    _o("velocity_angle_change", "Change of velocity angle", "angle", "vehicle", "ratio",
       "value", ["velocity_angle_change{i}"],
       "angle between the CG velocities before and after the impact"),
    _o("post_speed", "Post-impact speed", "speed", "vehicle", "ratio", "hypot",
       ["vx{i}_post", "vy{i}_post"], "CG speed right after the impact"),
    _o("post_direction", "Post-impact direction", "angle", "vehicle", "circular", "direction",
       ["vx{i}_post", "vy{i}_post"],
       "direction of the CG velocity right after the impact, from the global x axis "
       "(NaN below 1 mm/s)", wrap=True),
    _o("runout_distance", "Run-out distance (impact to rest)", "length", "vehicle", "ratio",
       "displacement", ["rest_x{i}", "rest_y{i}", "x{i}", "y{i}"],
       "straight-line distance from the CG at impact to the CG at rest",
       sd=["rest_x{i}_sd", "rest_y{i}_sd"]),
    _o("rest_x", "Rest position x", "length", "vehicle", "signed", "value", ["rest_x{i}"],
       "CG x at rest, global frame"),
    _o("rest_y", "Rest position y", "length", "vehicle", "signed", "value", ["rest_y{i}"],
       "CG y at rest, global frame"),
    _o("pdof", "PDOF", "angle", "vehicle", "circular", "value", ["pdof{i}"],
       "principal direction of force in the vehicle frame (0 = frontal, clockwise positive)",
       wrap=True),
    _o("rest_yaw", "Rest yaw angle", "angle", "vehicle", "signed", "value", ["rest_yaw{i}"],
       "yaw angle at rest (accumulated over the run-out)", wrap=True),
    _o("yaw_rate_post", "Post-impact yaw rate", "rate", "vehicle", "signed", "value",
       ["yaw_rate{i}_post"], "yaw rate right after the impact"),
    _o("energy_loss", "Energy loss", "energy", "case", "ratio", "value", ["energy_loss"],
       "kinetic energy lost in the impact"),
    _o("closing_speed", "Closing speed", "speed", "case", "ratio", "value", ["closing_speed"],
       "normal approach speed of the contact points at impact (not recorded by "
       "reconstructions)", sd=()),
    _o("sliding", "Sliding impact", "probability", "case", "indicator", "sliding",
       ["impact_type"], "1 for a sliding impact, 0 for a full impact, NaN otherwise", sd=()),
)

#: Outcomes by name.
OUTCOMES_BY_NAME: Mapping[str, Outcome] = MappingProxyType({o.name: o for o in OUTCOMES})


def get_outcome(name: str) -> Outcome:
    """The outcome called ``name``.

    Raises
    ------
    ParameterError
        For an unknown name (the message lists the known ones).
    """
    try:
        return OUTCOMES_BY_NAME[name]
    except KeyError:
        raise ParameterError(f"unknown outcome {name!r}; known: "
                             f"{', '.join(OUTCOMES_BY_NAME)}") from None


@dataclass(frozen=True)
class OutputGroup:
    """Outcomes an effect names together in :attr:`vfs.effects.Effect.outputs`.

    Attributes
    ----------
    name : str
        Output name.
    outcomes : tuple of str
        Names of its outcomes (one quantity kind).
    description : str
    """

    name: str
    outcomes: tuple[str, ...]
    description: str

    @property
    def members(self) -> tuple[Outcome, ...]:
        """The outcome records."""
        return tuple(OUTCOMES_BY_NAME[n] for n in self.outcomes)

    @property
    def quantity(self) -> Quantity:
        """The quantity kind of its outcomes."""
        return QUANTITIES[self.members[0].quantity]

    @property
    def value_names(self) -> tuple[str, ...]:
        """Single values, vehicle by vehicle (``rest_x1, rest_y1, rest_x2, rest_y2``)."""
        members = self.members
        if members[0].level == "case":
            return tuple(o.name for o in members)
        return tuple(f"{o.name}{i}" for i in VEHICLES for o in members)

    @property
    def sd_columns(self) -> tuple[str, ...]:
        """Reconstruction ``_sd`` columns of its outcomes, vehicle by vehicle."""
        return tuple(dict.fromkeys(c for i in self.members[0].vehicles for o in self.members
                                   for c in o.sd_columns_of(i)))

    @property
    def wrap(self) -> bool:
        """Differences are wrapped to (-pi, pi]."""
        return self.members[0].wrap


#: The outputs effects name, by name (docs/diagnosis.md).
OUTPUT_GROUPS: Mapping[str, OutputGroup] = MappingProxyType({g.name: g for g in (
    OutputGroup("delta_v", ("delta_v",), "magnitude of the CG velocity change"),
    OutputGroup("ees", ("ees",), "energy equivalent speed"),
    OutputGroup("energy_loss", ("energy_loss",), "kinetic energy lost in the impact"),
    OutputGroup("post_speed", ("post_speed",), "CG speed right after the impact"),
    OutputGroup("velocity_angle_change", ("velocity_angle_change",),
                "angle between the CG velocities before and after the impact"),
    OutputGroup("pdof", ("pdof",), "principal direction of force"),
    OutputGroup("rest_position", ("rest_x", "rest_y"),
                "CG position at rest (x and y of both vehicles)"),
    OutputGroup("rest_yaw", ("rest_yaw",), "yaw angle at rest"),
    OutputGroup("runout_distance", ("runout_distance",),
                "straight-line distance from the impact position to the rest position"),
    OutputGroup("impact_type", ("sliding",),
                "impact type (1 = sliding, 0 = full); residual in {-1, 0, 1}"),
)})

# ----------------------------------------------------------------------------
# Derivation
# ----------------------------------------------------------------------------

#: A column source: column name -> array (n,), or None if the column is absent.
Columns = Callable[[str], "np.ndarray | None"]


def _direction(vx: np.ndarray, vy: np.ndarray) -> np.ndarray:
    """Direction of motion [rad] of a velocity; NaN below 1 mm/s."""
    return np.where(vx * vx + vy * vy < 1e-6, np.nan, np.arctan2(vy, vx))


def _sliding(kind: np.ndarray) -> np.ndarray:
    """1.0 for "sliding", 0.0 for "full", NaN for anything else."""
    return np.where(kind == "sliding", 1.0, np.where(kind == "full", 0.0, np.nan))


def derive(outcome: Outcome, columns: Columns, numeric: Columns) -> np.ndarray | None:
    """Values of an outcome from a column source.

    Parameters
    ----------
    outcome : Outcome
    columns : callable
        Column name -> raw array (labels for ``impact_type``), None if absent.
    numeric : callable
        Column name -> float array [SI], None if absent.

    Returns
    -------
    ndarray or None
        (n, 2) for a vehicle-level outcome (vehicles 1 and 2), (n, 1) for a
        case-level one [SI unit of the outcome]; None if a column is missing.
    """
    out = []
    for i in outcome.vehicles:
        names = outcome.columns_of(i)
        if outcome.derivation == "sliding":
            kind = columns(names[0])
            if kind is None:
                return None
            out.append(_sliding(np.asarray(kind).astype(str)))
            continue
        arrays = [numeric(c) for c in names]
        if any(a is None for a in arrays):
            return None
        a: list[np.ndarray] = arrays  # type: ignore[assignment]
        if outcome.derivation == "value":
            out.append(a[0])
        elif outcome.derivation == "hypot":
            out.append(np.hypot(a[0], a[1]))
        elif outcome.derivation == "direction":
            out.append(_direction(a[0], a[1]))
        else:  # displacement: rest position minus CG at impact
            out.append(np.hypot(a[0] - a[2], a[1] - a[3]))
    return np.stack(out, axis=1)


def _table_source(table: Any) -> tuple[Columns, Columns]:
    """Column sources of a DataFrame or a mapping of arrays."""
    def raw(name: str) -> np.ndarray | None:
        if name not in table:
            return None
        col = table[name]
        return col.to_numpy() if hasattr(col, "to_numpy") else np.asarray(col)

    def numeric(name: str) -> np.ndarray | None:
        if name not in table:
            return None
        col = table[name]
        if hasattr(col, "to_numpy"):  # pandas: text becomes NaN
            import pandas as pd

            return pd.to_numeric(col, errors="coerce").to_numpy(float)
        return np.asarray(col, dtype=float)

    return raw, numeric


def result_columns(res: CaseResults) -> dict[str, np.ndarray]:
    """The columns of :func:`vfs.simulation.results_table` that outcomes use, as arrays.

    No DataFrame is built; the arrays are those of ``res`` (views, SI units;
    ``impact_type`` as labels "none" / "full" / "sliding").
    """
    pre, imp, ro = res.precrash, res.impact, res.runout
    st = pre.impact_state
    cols: dict[str, np.ndarray] = {
        "impact_type": impact_type_names(imp.impact_type).astype(object),
        "energy_loss": imp.energy_loss,
        "closing_speed": imp.closing_speed,
    }
    for i in VEHICLES:
        for name in ("x", "y", "yaw", "vx", "vy", "yaw_rate"):
            cols[f"{name}{i}"] = getattr(st, name)[:, i - 1]
        for name in ("delta_v", "ees", "pdof", "velocity_angle_change"):
            cols[f"{name}{i}"] = getattr(imp, name)[:, i - 1]
        for name in ("vx", "vy", "yaw_rate"):
            cols[f"{name}{i}_post"] = getattr(imp, f"{name}_post")[:, i - 1]
        cols[f"rest_x{i}"], cols[f"rest_y{i}"], cols[f"rest_yaw{i}"] = (
            ro.rest_x[:, i - 1], ro.rest_y[:, i - 1], ro.rest_yaw[:, i - 1])
    return cols


def _values(source: Any, outcomes: Iterable[Outcome | str] | None) -> dict[str, np.ndarray]:
    raw, numeric = _table_source(source)
    out: dict[str, np.ndarray] = {}
    for o in OUTCOMES if outcomes is None else outcomes:
        rec = get_outcome(o) if isinstance(o, str) else o
        values = derive(rec, raw, numeric)
        if values is not None:
            out[rec.name] = values
    return out


def from_results(results: Any, outcomes: Iterable[Outcome | str] | None = None
                 ) -> dict[str, np.ndarray]:
    """Outcome values of simulated cases.

    Parameters
    ----------
    results : CaseResults, pandas.DataFrame or mapping of arrays
        :class:`vfs.simulation.CaseResults` (read without building a table),
        a :func:`vfs.simulation.results_table` (e.g. ``runs.parquet`` of
        ``vfs study``) or its columns.
    outcomes : iterable of Outcome or str, optional
        Default: every outcome of :data:`OUTCOMES`.

    Returns
    -------
    dict
        Outcome name -> (n, 2) or (n, 1) array [SI]; outcomes whose columns
        are missing are left out.
    """
    if hasattr(results, "precrash") and hasattr(results, "runout"):
        results = result_columns(results)
    return _values(results, outcomes)


def from_reconstruction(rows: Any, outcomes: Iterable[Outcome | str] | None = None
                        ) -> dict[str, np.ndarray]:
    """Outcome values recorded by a reconstruction.

    Parameters
    ----------
    rows : pandas.DataFrame or mapping of arrays
        Reconstruction rows in SI units (as :attr:`vfs.database.Database.reconstruction`
        holds them: angles in rad).
    outcomes : iterable of Outcome or str, optional
        Default: every outcome of :data:`OUTCOMES`.

    Returns
    -------
    dict
        Outcome name -> (n, 2) or (n, 1) array [SI]; outcomes whose columns
        are missing (e.g. ``closing_speed``) are left out.
    """
    return _values(rows, outcomes)


def difference(outcome: Outcome, model: Any, reference: Any) -> np.ndarray:
    """``model - reference`` [SI]; the smallest signed angle in (-pi, pi] where
    :attr:`Outcome.wrap` is set.
    """
    d = np.asarray(model, dtype=float) - np.asarray(reference, dtype=float)
    return wrap_angle(d) if outcome.wrap else d


__all__ = [
    "OUTCOMES",
    "OUTCOMES_BY_NAME",
    "OUTPUT_GROUPS",
    "QUANTITIES",
    "Outcome",
    "OutputGroup",
    "Quantity",
    "derive",
    "difference",
    "from_reconstruction",
    "from_results",
    "get_outcome",
    "result_columns",
    "unit_factors",
]
