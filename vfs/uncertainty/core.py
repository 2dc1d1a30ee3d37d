"""Monte-Carlo uncertainty of the collision outcomes (``vfs uncertainty``).

Seed 002 (Krzemien et al., uncertainty of vehicle collision calculations) shows
that impact speeds computed from a Kudlich-Slibar impact and a post-impact
motion carry +-13 % uncertainty even for a documented crash test and up to
+-28 % when the road friction is sampled; it samples the unknowns uniformly by
Monte-Carlo and keeps the combinations consistent with the rest positions.
This module propagates the uncertain inputs of the impact calculation through
the vfs model and reports, per case and outcome, the median, the 5-95 % band
and the relative half-width (p95 - p5) / (2 median), the "+- %" of seed 002.

The model starts from the reconstruction's impact configuration (the
expert's poses, velocities, POI and contact plane, as stored in the database;
docs/data-format.md), not from the pre-crash phase: the full chain
(:func:`vfs.simulation.simulate_cases`, about 2,000 cases/s) is too slow for
10^5-10^6 samples, and an uncertain pre-crash speed is an uncertain speed at
impact.  One sample is

1. the pose moved along the sampled velocities by the change of the
   penetration time (the contact pose is estimated by moving both vehicles
   back along their velocities until the outlines just touch,
   :func:`estimate_penetration`); POI and contact plane move by the change of
   the geometric POI / contact plane (seed 001's Sutherland-Hodgman rule,
   :func:`vfs.physics.geometry.contact_geometry`) between the recorded and the moved
   pose, so that the expert's POI is kept at the nominal penetration;
2. the contact plane turned and the POI shifted along and normal to it;
3. speeds (direction kept; the yaw rate scaled with the speed, i.e. the path
   curvature kept), masses (yaw inertia scaled with the mass: same geometry,
   consistent with I = m L1 L2), restitution and contact friction;
4. the impulse impact (:func:`vfs.physics.impact.solve_impact`, Kudlich-Slibar,
   seed 002 eqs. 6-11) and the run-out of both vehicles to rest
   (:func:`vfs.physics.runout.run_out`) with the sampled road friction and post-crash
   wheel brake factors, at a coarser time step than the simulation (20 ms:
   docs/uncertainty.md gives its accuracy).

All samples of all cases are flattened into one batch of S x N rows and
solved by the vectorised kernels (in memory-bounded chunks).  The input
distributions live in a TOML file (default
``vfs/data/uncertainty_default.toml``; :func:`load_config`).  SI units
inside; km/h and degrees only in reports.
"""

from __future__ import annotations

import math
import time
import tomllib
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy.special import ndtr, ndtri

from vfs.database.source import data_path
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.physics.geometry import AREA_TOLERANCE, contact_geometry, overlap, vehicle_outline
from vfs.physics.impact import (
    IMPACT_FULL,
    IMPACT_NONE,
    IMPACT_SLIDING,
    ImpactConfig,
    ImpactParams,
    solve_impact,
)
from vfs.physics.runout import RunoutParams, RunoutState, run_out
from vfs.physics.vehicle import VehicleArrays
from vfs.units import KMH_PER_MS, wrap_angle

#: The default configuration file.
DEFAULT_CONFIG_PATH = data_path("uncertainty_default.toml")

# ----------------------------------------------------------------------------
# Inputs
# ----------------------------------------------------------------------------

#: Unit names accepted in configuration files -> factor to SI.
UNIT_FACTORS: Mapping[str, float] = MappingProxyType({
    "-": 1.0, "m": 1.0, "s": 1.0, "ms": 1e-3, "rad": 1.0, "deg": math.pi / 180.0,
    "m/s": 1.0, "km/h": 1.0 / KMH_PER_MS, "kg": 1.0,
})

#: Units allowed per quantity (the first is the SI unit).
QUANTITY_UNITS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "dimensionless": ("-",), "length": ("m",), "angle": ("rad", "deg"), "time": ("s", "ms"),
    "speed": ("m/s", "km/h"), "mass": ("kg",),
})


@dataclass(frozen=True)
class InputInfo:
    """One uncertain input of the collision calculation.

    Attributes
    ----------
    name : str
        Key in configuration files and column in sample tables.
    label : str
        Name in reports.
    quantity : str
        Key of :data:`QUANTITY_UNITS` (the value's SI unit follows).
    modes : tuple of str
        Allowed modes (``absolute``, ``offset``, ``factor``).
    bounds : (float, float)
        Physical limits of the value [SI]; sampled values are clipped to them.
    sd_columns : tuple of str
        Reconstruction columns whose ``_sd`` gives the case's standard
        deviation (``database_sd``); empty: not available.
    description : str
        What the value is (for docs and reports).
    """

    name: str
    label: str
    quantity: str
    modes: tuple[str, ...]
    bounds: tuple[float, float]
    sd_columns: tuple[str, ...]
    description: str

    @property
    def unit(self) -> str:
        """SI unit of the value."""
        return QUANTITY_UNITS[self.quantity][0]


_ALL = ("absolute", "offset", "factor")

#: The uncertain inputs, in the column order of every sample table.
INPUTS: tuple[InputInfo, ...] = (
    InputInfo("road_friction", "road friction", "dimensionless", _ALL, (0.05, 1.5), (),
              "tyre-road friction coefficient of the run-out (both vehicles)"),
    InputInfo("restitution", "restitution eps", "dimensionless", _ALL, (0.0, 1.0),
              ("restitution",), "impulse ratio eps = S_R / S_C of the impact"),
    InputInfo("contact_friction", "contact friction mu", "dimensionless", _ALL, (0.0, 2.0),
              ("contact_friction",), "friction between the vehicles at the POI"),
    InputInfo("poi_shift_t", "POI shift along the CP", "length", ("offset",),
              (-math.inf, math.inf), ("poi_x", "poi_y"),
              "shift of the POI along the contact-plane tangent [m]"),
    InputInfo("poi_shift_n", "POI shift normal to the CP", "length", ("offset",),
              (-math.inf, math.inf), ("poi_x", "poi_y"),
              "shift of the POI along the contact-plane normal, positive towards vehicle 1 [m]"),
    InputInfo("cp_angle", "contact-plane angle", "angle", ("offset",),
              (-math.inf, math.inf), ("cp_angle",),
              "rotation of the contact plane from the recorded one [rad]"),
    InputInfo("penetration_time", "penetration time", "time", ("absolute", "offset"),
              (0.001, 0.5), ("t_impact",),
              "time from the estimated first contact to the impact [s]"),
    InputInfo("speed1", "speed 1 at impact", "speed", _ALL, (0.0, 150.0), ("vx1", "vy1"),
              "CG speed of vehicle 1 at impact (direction kept) [m/s]"),
    InputInfo("speed2", "speed 2 at impact", "speed", _ALL, (0.0, 150.0), ("vx2", "vy2"),
              "CG speed of vehicle 2 at impact (direction kept) [m/s]"),
    InputInfo("mass1", "mass 1", "mass", _ALL, (50.0, 60_000.0), (),
              "mass of vehicle 1 (yaw inertia scaled with it) [kg]"),
    InputInfo("mass2", "mass 2", "mass", _ALL, (50.0, 60_000.0), (),
              "mass of vehicle 2 (yaw inertia scaled with it) [kg]"),
    InputInfo("wheel_brake1", "wheel brake 1", "dimensionless", ("absolute", "offset"),
              (0.0, 1.0), (), "post-crash brake factor of the four wheels of vehicle 1"),
    InputInfo("wheel_brake2", "wheel brake 2", "dimensionless", ("absolute", "offset"),
              (0.0, 1.0), (), "post-crash brake factor of the four wheels of vehicle 2"),
)

#: Input names in column order.
INPUT_NAMES: tuple[str, ...] = tuple(i.name for i in INPUTS)
#: Inputs by name.
INPUTS_BY_NAME: Mapping[str, InputInfo] = MappingProxyType({i.name: i for i in INPUTS})
_COL = {name: k for k, name in enumerate(INPUT_NAMES)}

# ----------------------------------------------------------------------------
# Distributions
# ----------------------------------------------------------------------------

#: Distribution families; codes are the positions.
FAMILIES: tuple[str, ...] = ("fixed", "uniform", "normal", "truncnormal", "lognormal")
FIXED, UNIFORM, NORMAL, TRUNCNORMAL, LOGNORMAL = range(5)
#: Modes; codes are the positions.
MODES: tuple[str, ...] = ("absolute", "offset", "factor")
ABSOLUTE, OFFSET, FACTOR = range(3)

_FAMILY_KEYS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "fixed": ("value",), "uniform": ("low", "high"), "normal": ("mean", "sd"),
    "truncnormal": ("mean", "sd", "low", "high"), "lognormal": ("median", "sigma"),
})
_SPEC_KEYS = {"family", "mode", "unit", "database_sd", "surface", "source", "comment",
              "value", "low", "high", "mean", "sd", "median", "sigma"}
#: Road surfaces of the cases table (schema).
SURFACES: tuple[str, ...] = ("dry", "wet", "snow", "ice")


@dataclass(frozen=True)
class Distribution:
    """Distribution of one input, parameters in SI units (factors for ``mode="factor"``).

    Attributes
    ----------
    family : str
        One of :data:`FAMILIES`.
    mode : str
        ``absolute`` (value = draw), ``offset`` (value = nominal + draw) or
        ``factor`` (value = nominal x draw).
    value : float
        Value of the ``fixed`` family in absolute mode.
    low, high : float
        Support of ``uniform``; truncation of ``truncnormal``.
    mean, sd : float
        ``normal`` and ``truncnormal`` (before truncation).
    median, sigma : float
        ``lognormal``: median and standard deviation of the logarithm.
    unit : str
        Unit the parameters were given in (for reports); the stored values are SI.
    """

    family: str
    mode: str
    value: float = math.nan
    low: float = math.nan
    high: float = math.nan
    mean: float = math.nan
    sd: float = math.nan
    median: float = math.nan
    sigma: float = math.nan
    unit: str = "-"

    def params(self) -> tuple[float, float, float, float]:
        """(a, b, lo, hi) of the vectorised inverse CDF (:func:`distribution_ppf`)."""
        f = self.family
        if f == "fixed":
            neutral = {"absolute": self.value, "offset": 0.0, "factor": 1.0}[self.mode]
            return neutral, 0.0, -math.inf, math.inf
        if f == "uniform":
            return self.low, self.high, -math.inf, math.inf
        if f == "normal":
            return self.mean, self.sd, -math.inf, math.inf
        if f == "truncnormal":
            return self.mean, self.sd, self.low, self.high
        return math.log(self.median), self.sigma, -math.inf, math.inf

    def describe(self) -> str:
        """Short text in the unit of the configuration, e.g. ``uniform [-0.1, 0.1] offset``."""
        k = 1.0 / UNIT_FACTORS.get(self.unit, 1.0)
        u = "" if self.unit == "-" else f" {self.unit}"
        f = self.family
        if f == "fixed":
            body = f"fixed {self.value * k:g}{u}" if self.mode == "absolute" else "fixed (nominal)"
        elif f == "uniform":
            body = f"uniform [{self.low * k:g}, {self.high * k:g}]{u}"
        elif f == "normal":
            body = f"normal (mean {self.mean * k:g}, sd {self.sd * k:g}){u}"
        elif f == "truncnormal":
            body = (f"truncated normal (mean {self.mean * k:g}, sd {self.sd * k:g}, "
                    f"[{self.low * k:g}, {self.high * k:g}]){u}")
        else:
            body = f"lognormal (median {self.median * k:g}{u}, sigma {self.sigma:g})"
        return body if f == "fixed" else f"{body}, {self.mode}"


@dataclass(frozen=True)
class InputSpec:
    """Configured uncertainty of one input.

    Attributes
    ----------
    distribution : Distribution
        The distribution for every case (unless overridden).
    database_sd : bool
        Use the database's ``<column>_sd`` where the case has one (normal
        around the nominal value, truncated at the input's bounds).
    surface : mapping of str to Distribution
        Replacement distributions for cases on the given road surfaces.
    """

    distribution: Distribution
    database_sd: bool = False
    surface: Mapping[str, Distribution] = field(default_factory=dict)


@dataclass(frozen=True)
class UncertaintyConfig:
    """Input distributions and model settings (:func:`load_config`).

    Attributes
    ----------
    inputs : mapping of str to InputSpec
        One entry per name of :data:`INPUT_NAMES`.
    runout_dt : float
        Run-out time step of the Monte-Carlo model [s].
    runout_max_time : float
        Longest run-out [s].
    wheel_brake : float
        Nominal post-crash brake factor of the wheels [-].
    source : str
        Where the configuration came from (file names).
    """

    inputs: Mapping[str, InputSpec]
    runout_dt: float = 0.02
    runout_max_time: float = 30.0
    wheel_brake: float = 0.8
    source: str = ""

    def __post_init__(self) -> None:
        missing = [n for n in INPUT_NAMES if n not in self.inputs]
        if missing:
            raise ParameterError(f"uncertainty configuration lacks inputs {missing}")
        unknown = sorted(set(self.inputs) - set(INPUT_NAMES))
        if unknown:
            raise ParameterError(f"unknown inputs {unknown}; known: {', '.join(INPUT_NAMES)}")
        if not 0.0 < self.runout_dt <= 0.05:
            raise ParameterError(f"model.runout_dt_s = {self.runout_dt:g} outside (0, 0.05]")
        if not self.runout_dt <= self.runout_max_time <= 3600.0:
            raise ParameterError(f"model.runout_max_time_s = {self.runout_max_time:g} outside "
                                 f"[{self.runout_dt:g}, 3600]")
        if not 0.0 <= self.wheel_brake <= 1.0:
            raise ParameterError(f"model.wheel_brake = {self.wheel_brake:g} outside [0, 1]")

    def runout_params(self) -> RunoutParams:
        """Run-out parameters of the Monte-Carlo model (paths sampled only at the end)."""
        steps = max(1, math.ceil(self.runout_max_time / self.runout_dt - 1e-9))
        horizon = steps * self.runout_dt
        return RunoutParams(dt=self.runout_dt, max_time=horizon, path_interval=horizon,
                            wheel_brake=(self.wheel_brake,) * 4)

    def with_inputs(self, **specs: InputSpec | Distribution) -> UncertaintyConfig:
        """Copy with some inputs replaced (a Distribution keeps database_sd / surface off)."""
        new = dict(self.inputs)
        for name, spec in specs.items():
            if name not in INPUTS_BY_NAME:
                raise ParameterError(f"unknown input {name!r}; known: {', '.join(INPUT_NAMES)}")
            new[name] = spec if isinstance(spec, InputSpec) else InputSpec(spec)
        return replace(self, inputs=MappingProxyType(new))


def _number(where: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ParameterError(f"{where} = {value!r} must be a number")
    v = float(value)
    if not math.isfinite(v):
        raise ParameterError(f"{where} = {value!r} must be finite")
    return v


def parse_distribution(name: str, table: Mapping[str, Any], where: str) -> Distribution:
    """A :class:`Distribution` from one configuration table (parameters to SI).

    Raises
    ------
    ParameterError
        Naming the key (``where``) and the allowed values or range.
    """
    info = INPUTS_BY_NAME[name]
    family = table.get("family")
    if family not in FAMILIES:
        raise ParameterError(f"{where}.family = {family!r}; allowed: {', '.join(FAMILIES)}")
    if family == "fixed":
        keep = "offset" if "offset" in info.modes else "absolute"
        mode = table.get("mode", "absolute" if "value" in table else keep)
    elif "mode" not in table:
        raise ParameterError(f"{where}.mode is required; allowed for {name}: "
                             f"{', '.join(info.modes)}")
    else:
        mode = table["mode"]
    if mode not in info.modes:
        raise ParameterError(f"{where}.mode = {mode!r}; allowed for {name}: "
                             f"{', '.join(info.modes)}")
    units = ("-",) if mode == "factor" else QUANTITY_UNITS[info.quantity]
    unit = table.get("unit", units[0])
    if unit not in units:
        raise ParameterError(f"{where}.unit = {unit!r}; allowed for {name} in {mode} mode: "
                             f"{', '.join(units)}")
    k = UNIT_FACTORS[unit]
    needed = list(_FAMILY_KEYS[family])
    optional: dict[str, float] = {}
    if family in ("normal", "truncnormal") and mode != "absolute":
        optional["mean"] = 1.0 if mode == "factor" else 0.0
    if family == "lognormal" and mode == "factor":
        optional["median"] = 1.0
    if family == "fixed" and mode != "absolute":
        optional["value"] = math.nan
    for key in needed:
        if key not in table and key not in optional:
            raise ParameterError(f"{where}.{key} is required for family {family!r} "
                                 f"(parameters: {', '.join(_FAMILY_KEYS[family])})")
    extra = sorted(set(table) & {"value", "low", "high", "mean", "sd", "median", "sigma"}
                   - set(needed))
    if extra:
        raise ParameterError(f"{where}: {extra} do not belong to family {family!r} "
                             f"(parameters: {', '.join(_FAMILY_KEYS[family])})")
    vals: dict[str, float] = {}
    for key in needed:
        if key in table:
            v = _number(f"{where}.{key}", table[key])
            vals[key] = v if key == "sigma" else v * k
        else:
            vals[key] = optional[key]
    if family == "fixed" and mode != "absolute" and "value" in table:
        raise ParameterError(f"{where}.value only applies in absolute mode (offset/factor "
                             "keep the nominal value)")
    if "sd" in vals and not vals["sd"] > 0:
        raise ParameterError(f"{where}.sd = {table['sd']!r} must be > 0")
    if "sigma" in vals and not vals["sigma"] > 0:
        raise ParameterError(f"{where}.sigma = {table['sigma']!r} must be > 0")
    if "median" in vals and not vals["median"] > 0:
        raise ParameterError(f"{where}.median must be > 0 (lognormal)")
    if family == "lognormal" and mode == "offset":
        raise ParameterError(f"{where}: family 'lognormal' needs mode 'absolute' or 'factor'")
    if "low" in vals and not vals["low"] < vals["high"]:
        raise ParameterError(f"{where}.low = {table['low']!r} must be < high = {table['high']!r}")
    if family == "truncnormal" and not vals["low"] <= vals["mean"] <= vals["high"]:
        raise ParameterError(f"{where}.mean must lie in [low, high]")
    lo, hi = info.bounds
    if mode == "absolute":
        support = {"fixed": ("value", "value"), "uniform": ("low", "high"),
                   "truncnormal": ("low", "high"), "lognormal": ("median", "median")}
        if family in support:
            a, b = (vals[s] for s in support[family])
            if a < lo or b > hi:
                raise ParameterError(
                    f"{where}: absolute values of {name} must lie in the physical range "
                    f"[{lo:g}, {hi:g}] {info.unit}; got [{a:g}, {b:g}] {info.unit}")
    if mode == "factor":
        support = {"uniform": ("low", "high"), "truncnormal": ("low", "high")}
        if family in support and vals[support[family][0]] < 0:
            raise ParameterError(f"{where}: factors must be >= 0")
    return Distribution(family=family, mode=mode, unit=unit, **vals)


def _parse_spec(name: str, table: Any, base: InputSpec | None) -> InputSpec:
    where = f"inputs.{name}"
    if not isinstance(table, Mapping):
        raise ParameterError(f"{where} must be a table")
    unknown = sorted(set(table) - _SPEC_KEYS)
    if unknown:
        raise ParameterError(f"{where}: unknown keys {unknown}; allowed: "
                             f"{', '.join(sorted(_SPEC_KEYS))}")
    if "family" in table:
        dist = parse_distribution(name, table, where)
    elif base is not None:
        dist = base.distribution
        if set(table) & {"mode", "unit", "value", "low", "high", "mean", "sd", "median",
                         "sigma"}:
            raise ParameterError(f"{where}: give 'family' with the distribution parameters")
    else:
        raise ParameterError(f"{where}.family is required")
    database_sd = table.get("database_sd", base.database_sd if base else False)
    if not isinstance(database_sd, bool):
        raise ParameterError(f"{where}.database_sd = {database_sd!r} must be true or false")
    if database_sd and not INPUTS_BY_NAME[name].sd_columns:
        raise ParameterError(f"{where}.database_sd: the database has no standard deviation "
                             f"column for {name}")
    surface: dict[str, Distribution] = dict(base.surface) if base and "family" not in table \
        else {}
    raw = table.get("surface", {})
    if not isinstance(raw, Mapping):
        raise ParameterError(f"{where}.surface must be a table of road surfaces")
    for surf, sub in raw.items():
        if surf not in SURFACES:
            raise ParameterError(f"{where}.surface.{surf}: unknown road surface; allowed: "
                                 f"{', '.join(SURFACES)}")
        if not isinstance(sub, Mapping):
            raise ParameterError(f"{where}.surface.{surf} must be a table")
        bad = sorted(set(sub) - (_SPEC_KEYS - {"surface", "database_sd"}))
        if bad:
            raise ParameterError(f"{where}.surface.{surf}: unknown keys {bad}")
        surface[surf] = parse_distribution(name, sub, f"{where}.surface.{surf}")
    return InputSpec(dist, database_sd, MappingProxyType(surface))


def config_from_dict(data: Mapping[str, Any], base: UncertaintyConfig | None = None,
                     source: str = "") -> UncertaintyConfig:
    """Build an :class:`UncertaintyConfig` from a parsed TOML document.

    Parameters
    ----------
    data : mapping
        ``{"model": {...}, "inputs": {NAME: {...}}}``.
    base : UncertaintyConfig, optional
        Inputs and settings not given in ``data`` are taken from it; without a
        base every input must be given.
    source : str
        Where ``data`` came from (kept in :attr:`UncertaintyConfig.source`).

    Raises
    ------
    ParameterError
        For an unknown key or input, or a parameter outside its range; the
        message names the key and the allowed values.
    """
    unknown = sorted(set(data) - {"model", "inputs", "description", "comment"})
    if unknown:
        raise ParameterError(f"unknown top-level keys {unknown}; allowed: model, inputs, "
                             "description")
    model = data.get("model", {})
    if not isinstance(model, Mapping):
        raise ParameterError("'model' must be a table")
    bad = sorted(set(model) - {"runout_dt_s", "runout_max_time_s", "wheel_brake"})
    if bad:
        raise ParameterError(f"model: unknown keys {bad}; allowed: runout_dt_s, "
                             "runout_max_time_s, wheel_brake")
    settings = {
        "runout_dt": base.runout_dt if base else 0.02,
        "runout_max_time": base.runout_max_time if base else 30.0,
        "wheel_brake": base.wheel_brake if base else 0.8,
    }
    for key, attr in (("runout_dt_s", "runout_dt"), ("runout_max_time_s", "runout_max_time"),
                      ("wheel_brake", "wheel_brake")):
        if key in model:
            settings[attr] = _number(f"model.{key}", model[key])
    inputs_raw = data.get("inputs", {})
    if not isinstance(inputs_raw, Mapping):
        raise ParameterError("'inputs' must be a table of input names")
    unknown_inputs = sorted(set(inputs_raw) - set(INPUT_NAMES))
    if unknown_inputs:
        raise ParameterError(f"inputs: unknown inputs {unknown_inputs}; known: "
                             f"{', '.join(INPUT_NAMES)}")
    inputs: dict[str, InputSpec] = {}
    for name in INPUT_NAMES:
        prev = base.inputs[name] if base else None
        if name in inputs_raw:
            inputs[name] = _parse_spec(name, inputs_raw[name], prev)
        elif prev is not None:
            inputs[name] = prev
        else:
            raise ParameterError(f"inputs.{name} is missing (a complete configuration lists "
                                 "every input)")
    return UncertaintyConfig(MappingProxyType(inputs), source=source, **settings)


def _read_toml(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise DataError(DataProblem(str(path), "", None, None, "configuration file not found"))
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(DataProblem(str(path), "", None, None, f"invalid TOML: {exc}")) from exc


def default_config() -> UncertaintyConfig:
    """The documented default distributions (``vfs/data/uncertainty_default.toml``)."""
    return config_from_dict(_read_toml(DEFAULT_CONFIG_PATH), source=DEFAULT_CONFIG_PATH.name)


def load_config(path: str | Path | None = None) -> UncertaintyConfig:
    """The configuration of a TOML file on top of the defaults (None: the defaults).

    Inputs the file does not list keep their defaults; ``family = "fixed"``
    switches an input off.
    """
    base = default_config()
    if path is None:
        return base
    p = Path(path)
    return config_from_dict(_read_toml(p), base=base,
                            source=f"{p} (on top of {DEFAULT_CONFIG_PATH.name})")


def distribution_ppf(family: np.ndarray, a: np.ndarray, b: np.ndarray, lo: np.ndarray,
                     hi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Inverse CDF of per-row distributions, vectorised.

    Parameters
    ----------
    family : ndarray of int (M,)
        Family codes (:data:`FIXED` ... :data:`LOGNORMAL`).
    a, b, lo, hi : ndarray (M,)
        Parameters from :meth:`Distribution.params`: uniform (low, high),
        normal (mean, sd), truncated normal (mean, sd, low, high), lognormal
        (log median, sigma), fixed (value).
    u : ndarray (M,)
        Probabilities in (0, 1).

    Returns
    -------
    ndarray (M,)
        The draws (same unit as the parameters).
    """
    u = np.clip(np.asarray(u, float), 1e-12, 1.0 - 1e-12)
    out = np.array(a, dtype=float, copy=True)  # fixed: the value
    m = family == UNIFORM
    out[m] = a[m] + u[m] * (b[m] - a[m])
    m = family == NORMAL
    out[m] = a[m] + b[m] * ndtri(u[m])
    m = family == LOGNORMAL
    out[m] = np.exp(a[m] + b[m] * ndtri(u[m]))
    m = np.flatnonzero(family == TRUNCNORMAL)
    if m.size:
        za = (lo[m] - a[m]) / b[m]
        zb = (hi[m] - a[m]) / b[m]
        # work in the lower tail (reflect when the interval lies above the mean) for accuracy
        flip = za > 0.0
        za, zb = np.where(flip, -zb, za), np.where(flip, -za, zb)
        uu = np.where(flip, 1.0 - u[m], u[m])
        pa, pb = ndtr(za), ndtr(zb)
        z = ndtri(np.clip(pa + uu * (pb - pa), 1e-300, 1.0 - 1e-16))
        z = np.clip(z, za, zb)
        out[m] = a[m] + b[m] * np.where(flip, -z, z)
    return out


# ----------------------------------------------------------------------------
# Cases
# ----------------------------------------------------------------------------

#: Penetration time assumed where it cannot be estimated [s] (seed 001).
DEFAULT_PENETRATION = ImpactParams().penetration_time
#: Largest penetration time the estimate searches [s].
MAX_PENETRATION = 0.25


class CaseSet(NamedTuple):
    """The reconstructed cases of a database, ready for sampling.

    Attributes
    ----------
    case_id : ndarray (N,)
    vehicle1, vehicle2 : VehicleArrays
    config : ImpactConfig
        Nominal impact configuration of the reconstruction (N,), SI.
    road_friction : ndarray (N,)
        Nominal tyre-road friction [-].
    road_surface : ndarray of str (N,)
    accident_type : ndarray of int (N,)
    penetration : ndarray (N,)
        Penetration time of the recorded pose [s] (:func:`estimate_penetration`;
        :data:`DEFAULT_PENETRATION` where it could not be estimated).
    penetration_estimated : ndarray of bool (N,)
    geo_poi : ndarray (N, 2)
        Geometric POI at the recorded pose [m] (NaN without overlap).
    geo_cp : ndarray (N,)
        Geometric contact-plane angle at the recorded pose [rad].
    sd : mapping of str to ndarray (N,)
        Standard deviation of each input from the database's ``_sd`` columns
        (SI; NaN where the case has none).
    reconstruction : pandas.DataFrame
        The reconstruction rows in case order (observed outcomes, degrees as stored).
    """

    case_id: np.ndarray
    vehicle1: VehicleArrays
    vehicle2: VehicleArrays
    config: ImpactConfig
    road_friction: np.ndarray
    road_surface: np.ndarray
    accident_type: np.ndarray
    penetration: np.ndarray
    penetration_estimated: np.ndarray
    geo_poi: np.ndarray
    geo_cp: np.ndarray
    sd: Mapping[str, np.ndarray]
    reconstruction: pd.DataFrame

    @property
    def size(self) -> int:
        """Number of cases N."""
        return int(self.case_id.shape[0])

    def take(self, index: npt.ArrayLike) -> CaseSet:
        """Cases by position (integer index or mask)."""
        idx = np.arange(self.size)[index]
        return CaseSet(
            self.case_id[idx], self.vehicle1.take(idx), self.vehicle2.take(idx),
            ImpactConfig(*(a[idx] for a in self.config)), self.road_friction[idx],
            self.road_surface[idx], self.accident_type[idx], self.penetration[idx],
            self.penetration_estimated[idx], self.geo_poi[idx], self.geo_cp[idx],
            MappingProxyType({k: v[idx] for k, v in self.sd.items()}),
            self.reconstruction.iloc[idx].reset_index(drop=True))

    def index_of(self, case_ids: Sequence[object]) -> np.ndarray:
        """Positions of the given case ids (DataError naming unknown ones)."""
        text = {str(c): k for k, c in enumerate(self.case_id.tolist())}
        missing = [c for c in case_ids if str(c) not in text]
        if missing:
            raise DataError([DataProblem("reconstruction", "case_id", None, c,
                                         "no reconstructed (colliding) case with this id")
                             for c in missing])
        return np.array([text[str(c)] for c in case_ids], dtype=int)

    @classmethod
    def from_database(cls, db: Any, case_ids: Sequence[object] | None = None) -> CaseSet:
        """The cases of a :class:`vfs.database.Database` that have a reconstruction.

        Parameters
        ----------
        db : Database
        case_ids : sequence, optional
            Cases in the wanted order (default: every reconstructed case in
            database order).

        Raises
        ------
        DataError
            If the database has no reconstruction rows or a case id has none.
        """
        rec = db.reconstruction
        if rec is None or rec.empty:
            raise DataError(DataProblem("reconstruction", "", None, None,
                                        "the database has no reconstruction rows (the "
                                        "uncertainty analysis starts from the impact "
                                        "configuration)"))
        rec = rec.drop_duplicates("case_id")
        have = set(rec["case_id"].tolist())
        if case_ids is None:
            ids = np.array([c for c in db.case_ids if c in have])
        else:
            text = {str(c): c for c in rec["case_id"].tolist()}
            missing = [c for c in case_ids if str(c) not in text]
            if missing:
                raise DataError([DataProblem("reconstruction", "case_id", None, c,
                                             "no reconstruction for this case (unknown case or "
                                             "a near miss)") for c in missing])
            ids = np.array([text[str(c)] for c in case_ids])
        if ids.size == 0:
            raise DataError(DataProblem("reconstruction", "case_id", None, None,
                                        "no case with a reconstruction selected"))
        sub = db.subset(ids)
        v1, v2 = sub.vehicles()
        order = pd.Index(sub.case_ids).get_indexer(ids)
        v1, v2 = v1.take(order), v2.take(order)
        r = rec.set_index("case_id").loc[ids]
        cases = sub.cases.set_index("case_id").loc[ids]

        def col(name: str) -> np.ndarray:
            return r[name].to_numpy(float)

        defaults = ImpactParams()
        eps = col("restitution")
        mu = col("contact_friction")
        config = ImpactConfig.from_arrays(
            m1=v1.mass, izz1=v1.yaw_inertia, m2=v2.mass, izz2=v2.yaw_inertia,
            **{k: col(k) for k in ("x1", "y1", "yaw1", "vx1", "vy1", "yaw_rate1", "x2", "y2",
                                   "yaw2", "vx2", "vy2", "yaw_rate2", "poi_x", "poi_y",
                                   "cp_angle")},
            restitution=np.where(np.isnan(eps), defaults.restitution, eps),
            contact_friction=np.where(np.isnan(mu), defaults.contact_friction, mu))
        pen, ok = estimate_penetration(v1, v2, config)
        o1 = vehicle_outline(v1, config.x1, config.y1, config.yaw1)
        o2 = vehicle_outline(v2, config.x2, config.y2, config.yaw2)
        geo = contact_geometry(o1, o2, np.stack([config.x1, config.y1], 1),
                               np.stack([config.x2, config.y2], 1))
        sd = _database_sd(r, config)
        return cls(ids, v1, v2, config, cases["road_friction"].to_numpy(float),
                   cases["road_surface"].astype(str).to_numpy(),
                   cases["accident_type"].to_numpy(), pen, ok, geo.poi, geo.cp_angle,
                   MappingProxyType(sd), r.reset_index())


def _database_sd(r: pd.DataFrame, c: ImpactConfig) -> dict[str, np.ndarray]:
    """Standard deviations of the inputs from the reconstruction's ``_sd`` columns (SI)."""
    n = c.size

    def sd(name: str) -> np.ndarray:
        key = f"{name}_sd"
        return r[key].to_numpy(float) if key in r.columns else np.full(n, np.nan)

    out = {name: np.full(n, np.nan) for name in INPUT_NAMES}
    out["restitution"] = sd("restitution")
    out["contact_friction"] = sd("contact_friction")
    out["cp_angle"] = sd("cp_angle")
    out["penetration_time"] = sd("t_impact")
    sx, sy = sd("poi_x"), sd("poi_y")
    ct, st = np.cos(c.cp_angle), np.sin(c.cp_angle)
    out["poi_shift_t"] = np.hypot(sx * ct, sy * st)
    out["poi_shift_n"] = np.hypot(sx * st, sy * ct)
    for i in (1, 2):
        vx, vy = getattr(c, f"vx{i}"), getattr(c, f"vy{i}")
        speed = np.hypot(vx, vy)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[f"speed{i}"] = np.where(speed > 1e-6,
                                        np.hypot(vx * sd(f"vx{i}"), vy * sd(f"vy{i}")) / speed,
                                        np.hypot(sd(f"vx{i}"), sd(f"vy{i}")))
    return out


def _shifted_outlines(v1: VehicleArrays, v2: VehicleArrays, c: ImpactConfig,
                      tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outlines with both vehicles moved kinematically by ``tau`` [s] (negative: back)."""
    o1 = vehicle_outline(v1, c.x1 + tau * c.vx1, c.y1 + tau * c.vy1,
                         c.yaw1 + tau * c.yaw_rate1)
    o2 = vehicle_outline(v2, c.x2 + tau * c.vx2, c.y2 + tau * c.vy2,
                         c.yaw2 + tau * c.yaw_rate2)
    return o1, o2


def estimate_penetration(v1: VehicleArrays, v2: VehicleArrays, config: ImpactConfig,
                         iterations: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Penetration time of recorded impact poses [s], by moving the vehicles back.

    Both vehicles move back along their CG velocities and yaw rates (straight
    kinematic motion, the same approximation the sampling uses to vary the
    penetration) until the overlap area falls to
    :data:`vfs.physics.geometry.AREA_TOLERANCE`; bisection on [0, MAX_PENETRATION]
    to 0.25 s / 2^24 = 15 ns.

    Returns
    -------
    penetration : ndarray (N,)
        Time since the first contact [s]; :data:`DEFAULT_PENETRATION` where the
        recorded outlines do not overlap or still overlap after
        :data:`MAX_PENETRATION`.
    estimated : ndarray of bool (N,)
        False where the default was used.
    """
    n = config.size
    lo = np.zeros(n)
    hi = np.full(n, MAX_PENETRATION)
    area0 = overlap(*_shifted_outlines(v1, v2, config, lo)).area
    area_max = overlap(*_shifted_outlines(v1, v2, config, -hi)).area
    ok = (area0 > AREA_TOLERANCE) & (area_max <= AREA_TOLERANCE)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        inside = overlap(*_shifted_outlines(v1, v2, config, -mid)).area > AREA_TOLERANCE
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return np.where(ok, hi, DEFAULT_PENETRATION), ok


# ----------------------------------------------------------------------------
# Resolved distributions and sampling
# ----------------------------------------------------------------------------


class ResolvedInputs(NamedTuple):
    """The distribution of every input for every case, as arrays (d inputs, N cases).

    Attributes
    ----------
    family, mode : ndarray of int (d, N)
    a, b, lo, hi : ndarray (d, N)
        Parameters of :func:`distribution_ppf` (SI, or factors).
    nominal : ndarray (d, N)
        Nominal values [SI].
    bounds : ndarray (d, 2)
        Physical limits (:attr:`InputInfo.bounds`).
    from_database : ndarray of bool (d, N)
        True where the database's standard deviation was used.
    """

    family: np.ndarray
    mode: np.ndarray
    a: np.ndarray
    b: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    nominal: np.ndarray
    bounds: np.ndarray
    from_database: np.ndarray

    @property
    def varied(self) -> np.ndarray:
        """(d,) True for inputs that vary in at least one case."""
        return np.any(self.family != FIXED, axis=1)

    @property
    def varied_names(self) -> tuple[str, ...]:
        """Names of the varied inputs."""
        return tuple(n for n, v in zip(INPUT_NAMES, self.varied, strict=True) if v)


def nominal_inputs(cases: CaseSet, config: UncertaintyConfig) -> np.ndarray:
    """Nominal input values (d, N) [SI]: the database's values, no shifts."""
    c = cases.config
    n = cases.size
    rows = {
        "road_friction": cases.road_friction,
        "restitution": c.restitution,
        "contact_friction": c.contact_friction,
        "poi_shift_t": np.zeros(n), "poi_shift_n": np.zeros(n), "cp_angle": np.zeros(n),
        "penetration_time": cases.penetration,
        "speed1": np.hypot(c.vx1, c.vy1), "speed2": np.hypot(c.vx2, c.vy2),
        "mass1": c.m1, "mass2": c.m2,
        "wheel_brake1": np.full(n, config.wheel_brake),
        "wheel_brake2": np.full(n, config.wheel_brake),
    }
    return np.stack([np.asarray(rows[name], float) for name in INPUT_NAMES])


def resolve_inputs(cases: CaseSet, config: UncertaintyConfig) -> ResolvedInputs:
    """Per-case distributions of every input: the configured one, the road-surface
    override, or normal with the database's sd (``database_sd``)."""
    d, n = len(INPUT_NAMES), cases.size
    family = np.zeros((d, n), dtype=int)
    mode = np.zeros((d, n), dtype=int)
    a, b = np.zeros((d, n)), np.zeros((d, n))
    lo, hi = np.full((d, n), -np.inf), np.full((d, n), np.inf)
    nominal = nominal_inputs(cases, config)
    bounds = np.array([info.bounds for info in INPUTS], float)
    from_db = np.zeros((d, n), dtype=bool)
    for k, name in enumerate(INPUT_NAMES):
        spec = config.inputs[name]
        dists = [spec.distribution] + [spec.surface.get(s, spec.distribution)
                                       for s in SURFACES]
        which = np.zeros(n, dtype=int)  # 0: default, 1 + j: surface j
        for j, s in enumerate(SURFACES):
            if s in spec.surface:
                which[cases.road_surface == s] = 1 + j
        for j, dist in enumerate(dists):
            m = which == j
            if not m.any():
                continue
            family[k, m] = FAMILIES.index(dist.family)
            mode[k, m] = MODES.index(dist.mode)
            pa, pb, plo, phi = dist.params()
            a[k, m], b[k, m], lo[k, m], hi[k, m] = pa, pb, plo, phi
        if spec.database_sd:
            sd = cases.sd.get(name, np.full(n, np.nan))
            m = np.isfinite(sd) & (sd > 0)
            family[k, m], mode[k, m] = NORMAL, OFFSET
            a[k, m], b[k, m] = 0.0, sd[m]
            from_db[k, m] = True
        _truncate_to_bounds(family[k], mode[k], a[k], b[k], lo[k], hi[k], nominal[k],
                            bounds[k])
    return ResolvedInputs(family, mode, a, b, lo, hi, nominal, bounds, from_db)


def _truncate_to_bounds(family: np.ndarray, mode: np.ndarray, a: np.ndarray, b: np.ndarray,
                        lo: np.ndarray, hi: np.ndarray, nominal: np.ndarray,
                        bounds: np.ndarray) -> None:
    """Condition each case's distribution on the input's physical bounds (in place).

    The bounds of the value become bounds of the draw (offset: minus the nominal
    value; factor: divided by it); uniform supports are intersected with them,
    normal distributions become truncated normals.  So no probability piles up
    at a bound (as clipping would do); :func:`values_from_unit` clips only
    rounding and lognormal tails.
    """
    blo = np.full(nominal.shape, bounds[0])
    bhi = np.full(nominal.shape, bounds[1])
    off = mode == OFFSET
    blo[off], bhi[off] = blo[off] - nominal[off], bhi[off] - nominal[off]
    fac = (mode == FACTOR) & (nominal > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        blo[fac], bhi[fac] = blo[fac] / nominal[fac], bhi[fac] / nominal[fac]
    free = (mode == FACTOR) & ~(nominal > 0)  # zero nominal: the factor cannot matter
    blo[free], bhi[free] = -np.inf, np.inf
    u = family == UNIFORM
    a[u], b[u] = np.maximum(a[u], blo[u]), np.minimum(b[u], bhi[u])
    empty = u & ~(a < b)  # support entirely outside the bounds: the nearest bound
    family[empty] = FIXED
    a[empty] = np.clip(np.where(a[empty] >= bhi[empty], bhi[empty], blo[empty]),
                       blo[empty], bhi[empty])
    nrm = (family == NORMAL) & (np.isfinite(blo) | np.isfinite(bhi))
    family[nrm] = TRUNCNORMAL
    lo[nrm], hi[nrm] = blo[nrm], bhi[nrm]
    t = family == TRUNCNORMAL
    lo[t], hi[t] = np.maximum(lo[t], blo[t]), np.minimum(hi[t], bhi[t])
    bad = t & ~(lo < hi)
    family[bad] = FIXED
    a[bad] = np.clip(a[bad], blo[bad], bhi[bad])


class SampledInputs(NamedTuple):
    """Input values of M model runs.

    Attributes
    ----------
    rows : ndarray of int (M,)
        Case position of each run.
    values : ndarray (M, d)
        Input values [SI], columns :data:`INPUT_NAMES`.
    clipped : ndarray of int (d,)
        Number of values clipped to the physical bounds per input.
    """

    rows: np.ndarray
    values: np.ndarray
    clipped: np.ndarray


def values_from_unit(resolved: ResolvedInputs, u: np.ndarray, rows: np.ndarray,
                     columns: Sequence[int] | None = None) -> SampledInputs:
    """Input values for probabilities ``u`` (inverse-CDF transform).

    Parameters
    ----------
    resolved : ResolvedInputs
    u : ndarray (M, k)
        Probabilities in (0, 1) of the inputs ``columns``.
    rows : ndarray of int (M,)
        Case position of each run.
    columns : sequence of int, optional
        Input indices (into :data:`INPUT_NAMES`) of the columns of ``u``
        (default: all inputs).  The other inputs take their fixed value
        (their median where they are not fixed).

    Returns
    -------
    SampledInputs
    """
    rows = np.asarray(rows, dtype=int)
    d = len(INPUT_NAMES)
    cols = list(range(d)) if columns is None else list(columns)
    u = np.asarray(u, float).reshape(rows.shape[0], len(cols))
    full = np.full((rows.shape[0], d), 0.5)
    full[:, cols] = u
    values = np.empty((rows.shape[0], d))
    clipped = np.zeros(d, dtype=int)
    for k in range(d):
        fam = resolved.family[k, rows]
        draw = distribution_ppf(fam, resolved.a[k, rows], resolved.b[k, rows],
                                resolved.lo[k, rows], resolved.hi[k, rows], full[:, k])
        mode = resolved.mode[k, rows]
        nom = resolved.nominal[k, rows]
        x = np.where(mode == OFFSET, nom + draw, np.where(mode == FACTOR, nom * draw, draw))
        lo, hi = resolved.bounds[k]
        bad = (x < lo) | (x > hi)
        clipped[k] = int(np.count_nonzero(bad))
        values[:, k] = np.clip(x, lo, hi)
    return SampledInputs(rows, values, clipped)


def sample_inputs(resolved: ResolvedInputs, n_samples: int, rng: np.random.Generator
                  ) -> SampledInputs:
    """S independent random samples of every case: M = S x N runs, sample-major
    (row s N + j is sample s of case j)."""
    if n_samples < 1:
        raise ParameterError(f"samples = {n_samples} must be >= 1")
    d, n = resolved.family.shape
    rows = np.tile(np.arange(n), n_samples)
    u = rng.random((rows.shape[0], d))
    return values_from_unit(resolved, u, rows)


# ----------------------------------------------------------------------------
# The model
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class OutcomeInfo:
    """An outcome of one model run.

    Attributes
    ----------
    name, label : str
    quantity : str
        ``speed``, ``angle``, ``length``, ``energy`` or ``probability``.
    kind : str
        ``ratio`` (non-negative magnitude: the relative half-width is
        reported), ``signed`` (coordinates, accumulated angles: absolute
        half-width only), ``circular`` (directions: quantiles after
        unwrapping around the nominal value) or ``indicator`` (0/1; the mean
        is a probability).
    reconstruction : str
        How the recorded value is read from the reconstruction table.
    """

    name: str
    label: str
    quantity: str
    kind: str
    reconstruction: str


#: Display units of reports: quantity -> (unit, factor from SI).
DISPLAY_UNITS: Mapping[str, tuple[str, float]] = MappingProxyType({
    "speed": ("km/h", KMH_PER_MS), "angle": ("deg", 180.0 / math.pi), "length": ("m", 1.0),
    "energy": ("kJ", 1e-3), "probability": ("%", 100.0),
})
#: SI unit of each quantity.
SI_UNITS: Mapping[str, str] = MappingProxyType({
    "speed": "m/s", "angle": "rad", "length": "m", "energy": "J", "probability": "-",
})


def _vehicle_outcomes() -> list[OutcomeInfo]:
    out = []
    for stem, label, quantity, kind in (
        ("delta_v", "delta-v", "speed", "ratio"),
        ("ees", "EES", "speed", "ratio"),
        ("velocity_angle_change", "change of velocity angle", "angle", "ratio"),
        ("post_speed", "post-impact speed", "speed", "ratio"),
        ("post_direction", "post-impact direction", "angle", "circular"),
        ("pdof", "PDOF", "angle", "circular"),
        ("rest_x", "rest x", "length", "signed"),
        ("rest_y", "rest y", "length", "signed"),
        ("rest_yaw", "rest yaw", "angle", "signed"),
        ("rest_distance", "impact-to-rest distance", "length", "ratio"),
    ):
        for i in (1, 2):
            out.append(OutcomeInfo(f"{stem}{i}", f"{label} {i}", quantity, kind, stem))
    return out


#: Every outcome, in report order.
OUTCOMES: tuple[OutcomeInfo, ...] = (
    *_vehicle_outcomes(),
    OutcomeInfo("energy_loss", "energy loss", "energy", "ratio", "energy_loss"),
    OutcomeInfo("closing_speed", "closing speed", "speed", "ratio", ""),
    OutcomeInfo("sliding", "sliding impact", "probability", "indicator", "impact_type"),
)
#: Outcome names in order.
OUTCOME_NAMES: tuple[str, ...] = tuple(o.name for o in OUTCOMES)
#: Outcomes by name.
OUTCOMES_BY_NAME: Mapping[str, OutcomeInfo] = MappingProxyType({o.name: o for o in OUTCOMES})


class ModelRuns(NamedTuple):
    """Outcomes of M model runs (arrays (M,), SI units).

    Attributes
    ----------
    outcomes : mapping of str to ndarray
        One array per name of :data:`OUTCOME_NAMES`.
    impact_type : ndarray of int
        0 none (separating), 1 full, 2 sliding.
    at_rest : ndarray of bool (M, 2)
        Both vehicles came to rest within the run-out time.
    geometry_fallback : ndarray of bool
        The moved pose had no overlap; POI / contact plane kept unmoved.
    """

    outcomes: Mapping[str, np.ndarray]
    impact_type: np.ndarray
    at_rest: np.ndarray
    geometry_fallback: np.ndarray


#: Runs solved per chunk (bounds the memory of the run-out).
CHUNK_ROWS = 25_000


def _half_turn(angle: np.ndarray) -> np.ndarray:
    """Wrap a contact-plane angle difference to [-pi/2, pi/2) (orientation irrelevant)."""
    return np.mod(angle + 0.5 * np.pi, np.pi) - 0.5 * np.pi


def evaluate(cases: CaseSet, inputs: SampledInputs, config: UncertaintyConfig,
             chunk: int = CHUNK_ROWS) -> ModelRuns:
    """Run the impact and run-out model for M sampled input sets (vectorised).

    Parameters
    ----------
    cases : CaseSet
    inputs : SampledInputs
        Case positions and input values (SI) of the runs.
    config : UncertaintyConfig
        Model settings (run-out time step, horizon).
    chunk : int
        Runs per vectorised block.

    Returns
    -------
    ModelRuns
    """
    m = inputs.rows.shape[0]
    params = config.runout_params()
    parts = [_evaluate_block(cases, inputs.rows[s:s + chunk], inputs.values[s:s + chunk],
                             params) for s in range(0, m, max(1, chunk))]
    if not parts:
        raise ParameterError("no model runs to evaluate")
    outcomes = {k: np.concatenate([p.outcomes[k] for p in parts]) for k in OUTCOME_NAMES}
    return ModelRuns(MappingProxyType(outcomes),
                     np.concatenate([p.impact_type for p in parts]),
                     np.concatenate([p.at_rest for p in parts]),
                     np.concatenate([p.geometry_fallback for p in parts]))


def _evaluate_block(cases: CaseSet, rows: np.ndarray, x: np.ndarray,
                    params: RunoutParams) -> ModelRuns:
    c0 = ImpactConfig(*(a[rows] for a in cases.config))
    v1, v2 = cases.vehicle1.take(rows), cases.vehicle2.take(rows)
    col = {name: x[:, k] for k, name in enumerate(INPUT_NAMES)}
    # speeds: direction kept, yaw rate scaled with the speed (path curvature kept)
    vel = {}
    for i in (1, 2):
        vx, vy = getattr(c0, f"vx{i}"), getattr(c0, f"vy{i}")
        speed = np.hypot(vx, vy)
        yaw = getattr(c0, f"yaw{i}")
        moving = speed > 1e-3
        dx = np.where(moving, vx / np.where(moving, speed, 1.0), np.cos(yaw))
        dy = np.where(moving, vy / np.where(moving, speed, 1.0), np.sin(yaw))
        s = col[f"speed{i}"]
        scale = np.where(speed > 0.5, s / np.where(speed > 0.5, speed, 1.0), 1.0)
        vel[i] = (dx * s, dy * s, getattr(c0, f"yaw_rate{i}") * scale)
    # penetration: move the poses along the sampled velocities by the change of time
    tau = col["penetration_time"] - cases.penetration[rows]
    pose = {}
    for i in (1, 2):
        vx, vy, w = vel[i]
        pose[i] = (getattr(c0, f"x{i}") + tau * vx, getattr(c0, f"y{i}") + tau * vy,
                   getattr(c0, f"yaw{i}") + tau * w)
    poi_x, poi_y, cp = c0.poi_x.copy(), c0.poi_y.copy(), c0.cp_angle.copy()
    fallback = np.zeros(rows.shape[0], dtype=bool)
    moved = np.flatnonzero(np.abs(tau) > 1e-12)
    if moved.size:
        o1 = vehicle_outline(v1.take(moved), pose[1][0][moved], pose[1][1][moved],
                             pose[1][2][moved])
        o2 = vehicle_outline(v2.take(moved), pose[2][0][moved], pose[2][1][moved],
                             pose[2][2][moved])
        geo = contact_geometry(o1, o2, np.stack([pose[1][0][moved], pose[1][1][moved]], 1),
                               np.stack([pose[2][0][moved], pose[2][1][moved]], 1))
        base_poi = cases.geo_poi[rows[moved]]
        base_cp = cases.geo_cp[rows[moved]]
        dpx, dpy = geo.poi[:, 0] - base_poi[:, 0], geo.poi[:, 1] - base_poi[:, 1]
        dcp = _half_turn(geo.cp_angle - base_cp)
        bad = ~(np.isfinite(dpx) & np.isfinite(dpy) & np.isfinite(dcp))
        fallback[moved] = bad
        poi_x[moved] += np.where(bad, 0.0, dpx)
        poi_y[moved] += np.where(bad, 0.0, dpy)
        cp[moved] += np.where(bad, 0.0, dcp)
    cp = cp + col["cp_angle"]
    # POI shift in the (turned) contact-plane frame; n points from vehicle 2 to vehicle 1
    tx, ty = np.cos(cp), np.sin(cp)
    nx, ny = -ty, tx
    side = nx * (pose[1][0] - pose[2][0]) + ny * (pose[1][1] - pose[2][1])
    sgn = np.where(side < 0.0, -1.0, 1.0)
    poi_x = poi_x + col["poi_shift_t"] * tx + col["poi_shift_n"] * sgn * nx
    poi_y = poi_y + col["poi_shift_t"] * ty + col["poi_shift_n"] * sgn * ny
    # masses; the yaw inertia keeps its radius of gyration
    m1, m2 = col["mass1"], col["mass2"]
    izz1, izz2 = c0.izz1 * m1 / c0.m1, c0.izz2 * m2 / c0.m2
    config = ImpactConfig(
        m1, izz1, pose[1][0], pose[1][1], pose[1][2], vel[1][0], vel[1][1], vel[1][2],
        m2, izz2, pose[2][0], pose[2][1], pose[2][2], vel[2][0], vel[2][1], vel[2][2],
        poi_x, poi_y, cp, col["restitution"], col["contact_friction"])
    res = solve_impact(config)
    veh = VehicleArrays(*(np.concatenate([a, b]) for a, b in zip(
        v1._replace(mass=m1, yaw_inertia=izz1), v2._replace(mass=m2, yaw_inertia=izz2),
        strict=True)))
    state = RunoutState(
        np.concatenate([pose[1][0], pose[2][0]]), np.concatenate([pose[1][1], pose[2][1]]),
        np.concatenate([pose[1][2], pose[2][2]]),
        np.concatenate([res.vx1_post, res.vx2_post]),
        np.concatenate([res.vy1_post, res.vy2_post]),
        np.concatenate([res.yaw_rate1_post, res.yaw_rate2_post]))
    mu = np.concatenate([col["road_friction"], col["road_friction"]])
    brake = np.repeat(np.concatenate([col["wheel_brake1"], col["wheel_brake2"]])[:, None], 4,
                      axis=1)
    ro = run_out(veh, state, mu, params, wheel_brake=brake)
    k = rows.shape[0]
    out: dict[str, np.ndarray] = {}
    for i in (1, 2):
        part = slice(0, k) if i == 1 else slice(k, 2 * k)
        out[f"delta_v{i}"] = getattr(res, f"delta_v{i}")
        out[f"ees{i}"] = getattr(res, f"ees{i}")
        out[f"velocity_angle_change{i}"] = getattr(res, f"velocity_angle_change{i}")
        out[f"post_speed{i}"] = np.hypot(getattr(res, f"vx{i}_post"),
                                         getattr(res, f"vy{i}_post"))
        out[f"post_direction{i}"] = _direction(getattr(res, f"vx{i}_post"),
                                               getattr(res, f"vy{i}_post"))
        out[f"pdof{i}"] = getattr(res, f"pdof{i}")
        out[f"rest_x{i}"] = ro.rest_x[part]
        out[f"rest_y{i}"] = ro.rest_y[part]
        out[f"rest_yaw{i}"] = ro.rest_yaw[part]
        out[f"rest_distance{i}"] = np.hypot(ro.rest_x[part] - pose[i][0],
                                            ro.rest_y[part] - pose[i][1])
    out["energy_loss"] = res.energy_loss
    out["closing_speed"] = res.closing_speed
    out["sliding"] = (res.impact_type == IMPACT_SLIDING).astype(float)
    ordered = {name: out[name] for name in OUTCOME_NAMES}
    at_rest = np.stack([ro.at_rest[:k], ro.at_rest[k:]], axis=1)
    return ModelRuns(ordered, res.impact_type, at_rest, fallback)


def _direction(vx: np.ndarray, vy: np.ndarray) -> np.ndarray:
    """Direction of motion [rad] of a velocity; NaN below 1 mm/s (as the velocity angle)."""
    return np.where(vx * vx + vy * vy < 1e-6, np.nan, np.arctan2(vy, vx))


def nominal_runs(cases: CaseSet, config: UncertaintyConfig) -> ModelRuns:
    """The model at the nominal inputs of every case (one run per case)."""
    res = resolve_inputs(cases, config)
    rows = np.arange(cases.size)
    x = SampledInputs(rows, res.nominal.T.copy(), np.zeros(len(INPUT_NAMES), dtype=int))
    return evaluate(cases, x, config)


def recorded_outcomes(cases: CaseSet) -> dict[str, np.ndarray]:
    """The reconstruction's values of the outcomes (SI; NaN where not recorded)."""
    r = cases.reconstruction
    n = cases.size
    c = cases.config

    def col(name: str) -> np.ndarray:
        return r[name].to_numpy(float) if name in r.columns else np.full(n, np.nan)

    out: dict[str, np.ndarray] = {}
    for i in (1, 2):
        out[f"delta_v{i}"] = col(f"delta_v{i}")
        out[f"ees{i}"] = col(f"ees{i}")
        out[f"velocity_angle_change{i}"] = np.radians(col(f"velocity_angle_change{i}"))
        out[f"post_speed{i}"] = np.hypot(col(f"vx{i}_post"), col(f"vy{i}_post"))
        out[f"post_direction{i}"] = _direction(col(f"vx{i}_post"), col(f"vy{i}_post"))
        out[f"pdof{i}"] = np.radians(col(f"pdof{i}"))
        out[f"rest_x{i}"] = col(f"rest_x{i}")
        out[f"rest_y{i}"] = col(f"rest_y{i}")
        out[f"rest_yaw{i}"] = col(f"rest_yaw{i}")
        out[f"rest_distance{i}"] = np.hypot(col(f"rest_x{i}") - getattr(c, f"x{i}"),
                                            col(f"rest_y{i}") - getattr(c, f"y{i}"))
    out["energy_loss"] = col("energy_loss")
    out["closing_speed"] = np.full(n, np.nan)
    if "impact_type" in r.columns:
        kind = r["impact_type"].astype(str).to_numpy()
        out["sliding"] = np.where(np.isin(kind, ("full", "sliding")),
                                  (kind == "sliding").astype(float), np.nan)
    else:
        out["sliding"] = np.full(n, np.nan)
    return {name: out[name] for name in OUTCOME_NAMES}


def unwrap_circular(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Directions [rad] unwrapped to within pi of the reference (broadcast)."""
    return reference + wrap_angle(values - reference)


# ----------------------------------------------------------------------------
# Monte-Carlo uncertainty
# ----------------------------------------------------------------------------

#: Quantiles of the band.
BAND = (0.05, 0.50, 0.95)


class UncertaintyResult(NamedTuple):
    """Result of :func:`run_uncertainty`.

    Attributes
    ----------
    bands : pandas.DataFrame
        One row per case and outcome (SI units): ``case_id``, ``outcome``,
        ``unit``, ``kind``, ``nominal_type``, ``nominal`` (the model at the
        nominal inputs), ``recorded`` (the reconstruction), ``mean``, ``sd``,
        ``p5``, ``p50``, ``p95``, ``half_width`` = (p95 - p5) / 2,
        ``rel_half_width`` = (p95 - p5) / (2 p50) (ratio outcomes only),
        ``n`` (finite samples), ``recorded_in_band``.
    cases : pandas.DataFrame
        One row per case: ``case_id``, ``accident_type``, ``road_surface``,
        ``recorded_type``, ``nominal_type``, ``p_full``, ``p_sliding``,
        ``p_none``, ``p_not_at_rest``, ``p_geometry_fallback``,
        ``penetration_nominal`` [s], ``penetration_estimated``.
    inputs : pandas.DataFrame
        The distribution of each input (text), how many cases use the
        database's sd, the share of clipped values.
    samples : pandas.DataFrame or None
        Every run (``sample``, ``case_id``, the inputs, the outcomes,
        ``impact_type``), when requested.
    n_samples : int
    seed : int or None
    seconds : float
        Wall time of sampling, model and statistics.
    config : UncertaintyConfig
    """

    bands: pd.DataFrame
    cases: pd.DataFrame
    inputs: pd.DataFrame
    samples: pd.DataFrame | None
    n_samples: int
    seed: int | None
    seconds: float
    config: UncertaintyConfig

    def summary(self, by: str = "nominal_type") -> pd.DataFrame:
        """Relative half-widths over the cases (:func:`band_summary`)."""
        return band_summary(self.bands, by=by)


def _rng(seed: int | np.random.Generator | None) -> tuple[np.random.Generator, int | None]:
    if isinstance(seed, np.random.Generator):
        return seed, None
    if seed is None:
        raise ParameterError("a seed (int) or numpy.random.Generator is required "
                             "(runs must be reproducible)")
    return np.random.default_rng(int(seed)), int(seed)


def input_table(resolved: ResolvedInputs, config: UncertaintyConfig,
                clipped: np.ndarray | None = None, n_runs: int = 0) -> pd.DataFrame:
    """Description of the input distributions actually used (for reports)."""
    rows = []
    for k, info in enumerate(INPUTS):
        spec = config.inputs[info.name]
        text = spec.distribution.describe()
        if spec.surface:
            text += "; " + "; ".join(f"{s}: {d.describe()}" for s, d in spec.surface.items())
        rows.append({
            "input": info.name, "label": info.label, "unit": info.unit,
            "distribution": text, "varied": bool(resolved.varied[k]),
            "database_sd_cases": int(resolved.from_database[k].sum()),
            "clipped_share": (float(clipped[k]) / n_runs) if clipped is not None and n_runs
            else 0.0,
            "description": info.description,
        })
    return pd.DataFrame(rows)


def _quantiles(values: np.ndarray, kind: str) -> dict[str, np.ndarray]:
    """Band statistics along axis 0 of (S, N) arrays (NaN-aware)."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices are reported as NaN
        q = np.nanquantile(values, BAND, axis=0)
        mean = np.nanmean(values, axis=0)
        sd = np.nanstd(values, axis=0, ddof=1) if values.shape[0] > 1 else \
            np.full(values.shape[1:], np.nan)
    p5, p50, p95 = q
    half = 0.5 * (p95 - p5)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where((kind == "ratio") & (p50 > 0), half / np.where(p50 > 0, p50, 1.0),
                       np.nan)
    return {"mean": mean, "sd": sd, "p5": p5, "p50": p50, "p95": p95, "half_width": half,
            "rel_half_width": rel, "n": np.isfinite(values).sum(axis=0)}


_TYPE_NAMES = np.array(["none", "full", "sliding"])


def run_uncertainty(cases: CaseSet, config: UncertaintyConfig | None = None,
                    n_samples: int = 1000, seed: int | np.random.Generator | None = 0,
                    keep_samples: bool = False) -> UncertaintyResult:
    """Monte-Carlo bands of every outcome for every case.

    Parameters
    ----------
    cases : CaseSet
    config : UncertaintyConfig, optional
        Input distributions (default :func:`default_config`).
    n_samples : int
        Samples S per case (M = S x N model runs, solved as one vectorised batch).
    seed : int or numpy.random.Generator
        Source of all randomness (reproducible for an int seed).
    keep_samples : bool
        Also return every run as :attr:`UncertaintyResult.samples`.

    Returns
    -------
    UncertaintyResult
    """
    t0 = time.perf_counter()
    config = config or default_config()
    rng, seed_int = _rng(seed)
    resolved = resolve_inputs(cases, config)
    x = sample_inputs(resolved, int(n_samples), rng)
    runs = evaluate(cases, x, config)
    nom = nominal_runs(cases, config)
    rec = recorded_outcomes(cases)
    n, s = cases.size, int(n_samples)
    nominal_type = _TYPE_NAMES[nom.impact_type]
    frames = []
    for o in OUTCOMES:
        vals = runs.outcomes[o.name].reshape(s, n)
        nominal = nom.outcomes[o.name]
        recorded = rec[o.name]
        if o.kind == "circular":
            ref = np.where(np.isfinite(nominal), nominal, 0.0)
            vals = unwrap_circular(vals, ref[None, :])
            recorded = unwrap_circular(recorded, ref)
        q = _quantiles(vals, o.kind)
        frames.append(pd.DataFrame({
            "case_id": cases.case_id, "outcome": o.name, "unit": SI_UNITS[o.quantity],
            "kind": o.kind, "nominal_type": nominal_type, "nominal": nominal,
            "recorded": recorded, **q,
            "recorded_in_band": np.where(np.isfinite(recorded) & np.isfinite(q["p5"]),
                                         (recorded >= q["p5"]) & (recorded <= q["p95"]),
                                         np.nan),
        }))
    bands = pd.concat(frames, ignore_index=True)
    kind = runs.impact_type.reshape(s, n)
    rest = runs.at_rest.reshape(s, n, 2).all(axis=2)
    rtype = cases.reconstruction["impact_type"].astype(str).to_numpy() \
        if "impact_type" in cases.reconstruction.columns else np.full(n, "")
    case_table = pd.DataFrame({
        "case_id": cases.case_id, "accident_type": cases.accident_type,
        "road_surface": cases.road_surface, "recorded_type": rtype,
        "nominal_type": nominal_type,
        "p_full": (kind == IMPACT_FULL).mean(axis=0),
        "p_sliding": (kind == IMPACT_SLIDING).mean(axis=0),
        "p_none": (kind == IMPACT_NONE).mean(axis=0),
        "p_not_at_rest": (~rest).mean(axis=0),
        "p_geometry_fallback": runs.geometry_fallback.reshape(s, n).mean(axis=0),
        "penetration_nominal": cases.penetration,
        "penetration_estimated": cases.penetration_estimated,
    })
    samples = None
    if keep_samples:
        samples = pd.DataFrame(x.values, columns=list(INPUT_NAMES))
        samples.insert(0, "case_id", cases.case_id[x.rows])
        samples.insert(0, "sample", np.repeat(np.arange(s), n))
        for name in OUTCOME_NAMES:
            samples[name] = runs.outcomes[name]
        samples["impact_type"] = _TYPE_NAMES[runs.impact_type]
    inputs = input_table(resolved, config, x.clipped, x.rows.shape[0])
    return UncertaintyResult(bands, case_table, inputs, samples, s, seed_int,
                             time.perf_counter() - t0, config)


def band_summary(bands: pd.DataFrame, by: str | None = "nominal_type") -> pd.DataFrame:
    """Relative half-widths of the ratio outcomes summarised over the cases.

    Columns: ``outcome``, the group (``by``; ``all`` for every case),
    ``n_cases``, ``median_rel_half_width``, ``p90_rel_half_width``,
    ``max_rel_half_width``, ``median_half_width`` [SI], and the share of
    cases whose recorded value lies in the band (``recorded_in_band``).
    """
    data = bands[bands["kind"] != "indicator"]
    groups = [("all", data)]
    if by:
        groups += [(str(k), g) for k, g in data.groupby(by, sort=True)]
    rows = []
    for label, g in groups:
        for name, h in g.groupby("outcome", sort=False):
            rel = h["rel_half_width"].to_numpy(float)
            rel = rel[np.isfinite(rel)]
            inband = h["recorded_in_band"].to_numpy(float)
            inband = inband[np.isfinite(inband)]
            rows.append({
                "outcome": name, "group": label, "n_cases": len(h),
                "median_rel_half_width": float(np.median(rel)) if rel.size else np.nan,
                "p90_rel_half_width": float(np.quantile(rel, 0.9)) if rel.size else np.nan,
                "max_rel_half_width": float(rel.max()) if rel.size else np.nan,
                "median_half_width": float(np.nanmedian(h["half_width"])) if len(h) else np.nan,
                "recorded_in_band": float(inband.mean()) if inband.size else np.nan,
            })
    order = {name: k for k, name in enumerate(OUTCOME_NAMES)}
    out = pd.DataFrame(rows)
    out["_o"] = out["outcome"].map(order)
    return out.sort_values(["group", "_o"], kind="stable").drop(columns="_o").reset_index(
        drop=True)


def coverage(bands: pd.DataFrame, outcomes: Sequence[str] | None = None) -> pd.DataFrame:
    """Share of cases whose recorded value lies inside the 5-95 % band, per outcome.

    With a database whose reconstruction is the truth this is the coverage of
    the band (nominal 90 % when the input distributions describe the truth's
    deviation from the nominal values).
    """
    data = bands if outcomes is None else bands[bands["outcome"].isin(list(outcomes))]
    data = data[np.isfinite(data["recorded_in_band"].to_numpy(float))]
    return data.groupby("outcome", sort=False)["recorded_in_band"].agg(["mean", "count"]) \
        .rename(columns={"mean": "coverage", "count": "n_cases"}).reset_index()


__all__ = [
    "BAND", "CaseSet", "DEFAULT_CONFIG_PATH", "Distribution", "FAMILIES", "INPUTS",
    "INPUT_NAMES", "InputInfo", "InputSpec", "MODES", "ModelRuns", "OUTCOMES", "OUTCOME_NAMES",
    "OutcomeInfo", "ResolvedInputs", "SampledInputs", "UncertaintyConfig", "UncertaintyResult",
    "band_summary", "config_from_dict", "coverage", "default_config", "distribution_ppf",
    "estimate_penetration", "evaluate", "load_config", "nominal_inputs", "nominal_runs",
    "parse_distribution", "recorded_outcomes", "resolve_inputs", "run_uncertainty",
    "sample_inputs", "unwrap_circular", "values_from_unit",
]
