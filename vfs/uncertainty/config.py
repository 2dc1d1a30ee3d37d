"""Input distributions of the uncertainty analysis and their TOML configuration files.

The uncertain inputs of the impact calculation (:data:`INPUTS`: road friction,
restitution, contact friction, POI shift, contact-plane angle, penetration
time, speeds at impact, masses, post-crash wheel brakes), the distribution
families and modes (:class:`Distribution`), the configured uncertainty of
each input (:class:`InputSpec`) and the whole configuration with the model
settings (:class:`UncertaintyConfig`).  The documented defaults are the
package file ``vfs/data/uncertainty_default.toml``, read with
:mod:`importlib.resources` (:func:`default_config`); :func:`load_config` reads
a user's TOML file on top of them.  Parameters are converted to SI units when
read; km/h and degrees exist only in the files.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from types import MappingProxyType
from typing import Any

from vfs.errors import DataError, DataProblem, ParameterError
from vfs.physics.post_impact import MAX_STEER
from vfs.physics.runout import RunoutParams
from vfs.settings import (
    Rule,
    build,
    declared,
    fields_of,
    raise_problems,
    read_table,
    setting,
    validate,
)
from vfs.units import KMH_PER_MS

#: The default configuration file (package data, read with :mod:`importlib.resources`).
DEFAULT_CONFIG_PATH: Traversable = resources.files("vfs").joinpath(
    "data", "uncertainty_default.toml")

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
    InputInfo("corner_brake1", "corner brake 1", "dimensionless", ("absolute", "offset"),
              (-1.0, 1.0), (),
              "post-crash brake factor of the impact-corner wheel of vehicle 1 over its "
              "vehicle's factor (its wheel = clip(wheel brake 1 + this, 0, 1))"),
    InputInfo("corner_brake2", "corner brake 2", "dimensionless", ("absolute", "offset"),
              (-1.0, 1.0), (),
              "post-crash brake factor of the impact-corner wheel of vehicle 2 over its "
              "vehicle's factor (its wheel = clip(wheel brake 2 + this, 0, 1))"),
    InputInfo("steer1", "steer angle 1", "angle", ("absolute", "offset"),
              (-MAX_STEER, MAX_STEER), (),
              "post-crash front-wheel steer angle of vehicle 1, positive to the left [rad]"),
    InputInfo("steer2", "steer angle 2", "angle", ("absolute", "offset"),
              (-MAX_STEER, MAX_STEER), (),
              "post-crash front-wheel steer angle of vehicle 2, positive to the left [rad]"),
)

#: Input names in column order.
INPUT_NAMES: tuple[str, ...] = tuple(i.name for i in INPUTS)
#: Inputs by name.
INPUTS_BY_NAME: Mapping[str, InputInfo] = MappingProxyType({i.name: i for i in INPUTS})

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
    runout_dt: float = setting(0.02, "time", "run-out time step of the Monte-Carlo model",
                               lo=0.0, lo_open=True, hi=0.05)
    runout_max_time: float = setting(30.0, "time", "longest run-out of the Monte-Carlo model; "
                                     ">= runout_dt", lo=0.0, lo_open=True, hi=3600.0)
    wheel_brake: float = setting(0.8, "ratio", "nominal post-crash brake factor of the wheels "
                                 "(0 free rolling, 1 locked)", lo=0.0, hi=1.0)
    source: str = ""

    #: Rules between the settings.
    RULES = (Rule(("runout_dt", "runout_max_time"),
                  lambda c: c.runout_dt <= c.runout_max_time, "runout_dt <= runout_max_time"),)

    def __post_init__(self) -> None:
        missing = [n for n in INPUT_NAMES if n not in self.inputs]
        if missing:
            raise ParameterError(f"uncertainty configuration lacks inputs {missing}")
        unknown = sorted(set(self.inputs) - set(INPUT_NAMES))
        if unknown:
            raise ParameterError(f"unknown inputs {unknown}; known: {', '.join(INPUT_NAMES)}")
        validate(self)

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
    fields = fields_of(UncertaintyConfig)  # the [model] keys: the declared settings
    keys = [k for f in fields for k in f.keys()]
    bad = sorted(set(model) - set(keys))
    if bad:
        raise ParameterError(f"model: unknown keys {bad}; allowed: {', '.join(keys)}")
    settings = {name: getattr(base, name) if base else s.default
                for name, s in declared(UncertaintyConfig).items()}
    values, problems = read_table(model, fields, path=source or "uncertainty configuration",
                                  where="model.")
    raise_problems(problems)
    settings |= values
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
    problems = []
    config = build(UncertaintyConfig, {"inputs": MappingProxyType(inputs), "source": source,
                                       **settings},
                   path=source or "uncertainty configuration", where="model.",
                   problems=problems, labels={f.name: f.keys()[0] for f in fields})
    raise_problems(problems)
    return config


def _read_toml(path: Path | Traversable) -> dict[str, Any]:
    """The parsed TOML document of a file (a path or package data)."""
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


__all__ = [
    "ABSOLUTE", "DEFAULT_CONFIG_PATH", "FACTOR", "FAMILIES", "FIXED", "INPUTS", "INPUTS_BY_NAME",
    "INPUT_NAMES", "LOGNORMAL", "MODES", "NORMAL", "OFFSET", "QUANTITY_UNITS", "SURFACES",
    "TRUNCNORMAL", "UNIFORM", "UNIT_FACTORS", "Distribution", "InputInfo", "InputSpec",
    "UncertaintyConfig", "config_from_dict", "default_config", "load_config",
    "parse_distribution",
]
