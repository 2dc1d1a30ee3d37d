"""Physical effects as plugins: parameters, hook stages, registry.

An *effect* is a piece of physics the default model leaves out (restitution
that falls with closing speed, tyre forces during the contact phase, wheels
locked by the deformation, ...).  It is a small class with

* a unique :attr:`Effect.name` and a docstring that states the physics and
  its source;
* :attr:`Effect.parameters`, each an :class:`EffectParameter` with a default
  (the nominal strength), bounds, unit and the *neutral* value at which the
  effect does nothing;
* one or more **hooks**, methods named after the simulation stages of
  :data:`STAGES`.  The simulation (:func:`vfs.simulation.simulate_cases`)
  calls every hook an effect overrides, at its stage, in the order the
  effects are listed.  All hooks are vectorised over the colliding cases.

Effects are registered by the :func:`register_effect` decorator or through
the ``vfs.effects`` entry-point group (``[project.entry-points."vfs.effects"]
my_effect = "my_package.module:MyEffect"``), so a user's own package can add
effects; :func:`get_effect` finds both.  The synthetic database generator
(``vfs generate --hidden NAME=VALUE``) and the model use the same classes.

Stages and hook signatures (``ctx`` is an :class:`vfs.effects.context.ImpactContext`
for the impact stages):

====================  ============================================================
stage                 hook
====================  ============================================================
vehicles              ``vehicles(batch) -> batch``: vehicle data before the run
penetration           ``penetration(ctx: ContactContext, t) -> t``: penetration time [s]
impact_configuration  ``impact_configuration(ctx, config) -> config``: POI, contact plane
impact_parameters     ``impact_parameters(ctx, config) -> config``: eps, mu
contact_impulse       ``contact_impulse(ctx, config, result) -> VelocityChange``:
                      external impulses during the contact phase ((n, 2)
                      arrays, vehicle axis 1)
energy_split          ``energy_split(ctx, config, result, e1, e2) -> (e1, e2)``:
                      deformation energies [J] behind the EES
post_impact           ``post_impact(ctx, config, result, inputs) -> inputs``:
                      the run-out inputs of the colliding cases
                      (:class:`vfs.physics.post_impact.PostImpactInputs`: brake
                      factors per wheel, all given; steer angle and onset,
                      extra drag per wheel, NaN = default)
====================  ============================================================

A ``post_impact`` hook of the earlier form ``post_impact(ctx, config, result, b1, b2)
-> (b1, b2)`` (brake factors (N, 4) per vehicle) is still run (:func:`apply_post_impact`
tells the two forms apart by the number of parameters); it cannot steer.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar, NamedTuple, TypeVar

import numpy as np

from vfs.catalog import QUANTITY_UNITS
from vfs.effects.context import ContactContext, ImpactContext
from vfs.errors import ParameterError, SettingProblem, SettingsError
from vfs.physics.impact import ImpactConfig, ImpactResult, add_vehicle_aliases
from vfs.physics.post_impact import PostImpactInputs
from vfs.registry import Registry
from vfs.settings import Setting

#: Simulation stages an effect can hook into, in the order they run.
STAGES: tuple[str, ...] = (
    "vehicles", "penetration", "impact_configuration", "impact_parameters",
    "contact_impulse", "energy_split", "post_impact",
)

#: Entry-point group through which other packages register effects.
ENTRY_POINT_GROUP = "vfs.effects"


#: The quantity (:data:`vfs.catalog.QUANTITY_UNITS`) of a parameter's SI unit label.
_QUANTITY_OF_UNIT = {u.label: q for q, units in QUANTITY_UNITS.items() for u in units
                     if u.to_si(2.0) == 2.0 and q != "degrees"}


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of an effect.

    Attributes
    ----------
    name : str
        Identifier (keyword of the effect's constructor).
    default : float
        Nominal value: the strength a hidden effect has unless told otherwise,
        and the start value of a calibration.
    lo, hi : float
        Bounds (closed) a value must respect; calibrations search inside them.
    unit : str
        Unit of the value ("-" for dimensionless).
    description : str
        One line on the meaning.
    neutral : float or None
        Value at which the effect has no influence (None: none exists).
    """

    name: str
    default: float
    lo: float
    hi: float
    unit: str
    description: str
    neutral: float | None = None

    def __post_init__(self) -> None:
        self.check("EffectParameter", self.default)

    @property
    def setting(self) -> Setting:
        """The parameter as a declared setting (:mod:`vfs.settings`): its checks, its
        allowed range and the tables of the documentation come from it.
        """
        return Setting(_QUANTITY_OF_UNIT.get(self.unit, "ratio"), self.description,
                       lo=self.lo, hi=self.hi, name=self.name, default=self.default)

    def check(self, effect: str, value: object) -> float:
        """Validate a value; return it as float or raise :class:`vfs.errors.SettingsError`
        (``effect.parameter: value is out of range (allowed: [lo, hi] unit)``).
        """
        s = self.setting
        if isinstance(value, str):  # NAME:PARAM=VALUE of a command line
            try:
                value = float(value)
            except ValueError:
                pass  # reported as not a number
        problem = s.problem(value)
        if problem is None and not math.isfinite(float(value)):  # type: ignore[arg-type]
            problem = "is out of range"
        if problem is not None:
            raise SettingsError(SettingProblem(effect, self.name, value, problem, s.allowed()))
        return float(value)  # type: ignore[arg-type]


class VelocityChange(NamedTuple):
    """Velocity changes from external impulses, added after the impact.

    Arrays (n, 2) whose axis 1 is the vehicle (vehicle 1 at index 0), as the
    per-vehicle fields of :class:`vfs.physics.impact.ImpactResult`.

    Attributes
    ----------
    dvx, dvy : ndarray (n, 2)
        Change of the CG velocity [m/s], global frame.
    dw : ndarray (n, 2)
        Change of the yaw rate [rad/s].

    Notes
    -----
    The former names ``dvx1``, ``dvy1``, ``dw1``, ``dvx2``, ``dvy2``, ``dw2`` remain as
    read-only, deprecated aliases (``dvx1`` is ``dvx[:, 0]``) for plugins written against
    the one-array-per-vehicle record; vfs itself does not use them.
    """

    dvx: np.ndarray
    dvy: np.ndarray
    dw: np.ndarray

    @classmethod
    def zeros(cls, n: int) -> VelocityChange:
        """No change for n cases."""
        return cls(*(np.zeros((n, 2)) for _ in range(3)))

    def __add__(self, other: object) -> VelocityChange:
        if not isinstance(other, VelocityChange):
            return NotImplemented
        return VelocityChange(*(a + b for a, b in zip(self, other, strict=True)))


add_vehicle_aliases(VelocityChange, ("dvx", "dvy", "dw"))


class Effect:
    """Base class of physical effects (see the module docstring).

    Subclasses set :attr:`name`, :attr:`parameters` and optionally
    :attr:`summary` and :attr:`outputs`, and override one or more hooks of
    :data:`STAGES`.  Instances are immutable; parameter values are read with
    ``self["name"]`` or :attr:`values`.

    Parameters
    ----------
    **values : float
        Parameter values; missing ones take their defaults.
    """

    _values: Mapping[str, float]

    #: Unique name, used on the command line (``--hidden NAME=VALUE``).
    name: ClassVar[str] = ""
    #: The parameters, first = primary (set by ``NAME=VALUE``).
    parameters: ClassVar[tuple[EffectParameter, ...]] = ()
    #: One-line summary for tables and reports.
    summary: ClassVar[str] = ""
    #: Outcome columns the effect can change (documentation and diagnosis).
    outputs: ClassVar[tuple[str, ...]] = ()

    __slots__ = ("_values",)

    def __init__(self, **values: float) -> None:
        known = {p.name: p for p in self.parameters}
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ParameterError(
                f"effect {self.name}: unknown parameter(s) {unknown}; known: {sorted(known)}")
        checked = {p.name: p.check(self.name, values.get(p.name, p.default))
                   for p in self.parameters}
        object.__setattr__(self, "_values", MappingProxyType(checked))

    def __setattr__(self, key: str, value: object) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable")

    def __getitem__(self, key: str) -> float:
        return self._values[key]

    @property
    def values(self) -> Mapping[str, float]:
        """Parameter values by name."""
        return self._values

    @classmethod
    def primary(cls) -> str | None:
        """Name of the primary parameter (the first), None if there are none."""
        return cls.parameters[0].name if cls.parameters else None

    @classmethod
    def stages(cls) -> tuple[str, ...]:
        """Stages whose hook this effect overrides, in :data:`STAGES` order."""
        return tuple(s for s in STAGES if getattr(cls, s) is not getattr(Effect, s))

    def active_stages(self) -> tuple[str, ...]:
        """Stages whose hook this instance runs (:meth:`stages`; an effect that
        dispatches to other effects may run fewer).
        """
        return type(self).stages()

    def replace(self, **values: float) -> Effect:
        """A copy with some parameter values changed."""
        return type(self)(**{**self._values, **values})

    # --------------------------------------------------------- calibration
    @classmethod
    def bounds(cls) -> list[tuple[float, float]]:
        """(lo, hi) of every parameter, in :attr:`parameters` order."""
        return [(p.lo, p.hi) for p in cls.parameters]

    def vector(self) -> np.ndarray:
        """Parameter values as an array (for optimisers)."""
        return np.array([self._values[p.name] for p in self.parameters], float)

    @classmethod
    def from_vector(cls, x: Iterable[float]) -> Effect:
        """Effect with the parameters of :meth:`vector` order (clipped to the bounds)."""
        values = {p.name: float(np.clip(v, p.lo, p.hi))
                  for p, v in zip(cls.parameters, x, strict=True)}
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description: name and parameter values."""
        return {"name": self.name, "parameters": dict(self._values)}

    # ------------------------------------------------------------- dunder
    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v:g}" for k, v in self._values.items())
        return f"{type(self).__name__}({args})"

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Effect) and type(other) is type(self)
                and dict(other.values) == dict(self._values))

    def __hash__(self) -> int:
        return hash((type(self), tuple(self._values.items())))

    # --------------------------------------------------------------- hooks
    # Defaults do nothing; the simulation calls only overridden hooks.
    def vehicles(self, batch: Any) -> Any:
        """Stage ``vehicles``: return the case batch (``vfs.simulation.CaseBatch``) with changed
        vehicle data.
        """
        return batch

    def penetration(self, ctx: ContactContext, penetration_time: np.ndarray) -> np.ndarray:
        """Stage ``penetration``: penetration time [s] per case at first contact."""
        return penetration_time

    def impact_configuration(self, ctx: ImpactContext, config: ImpactConfig) -> ImpactConfig:
        """Stage ``impact_configuration``: POI and contact plane (ImpactConfig)."""
        return config

    def impact_parameters(self, ctx: ImpactContext, config: ImpactConfig) -> ImpactConfig:
        """Stage ``impact_parameters``: restitution and contact friction (ImpactConfig)."""
        return config

    def contact_impulse(self, ctx: ImpactContext, config: ImpactConfig,
                        result: ImpactResult) -> VelocityChange:
        """Stage ``contact_impulse``: velocity changes by external impulses."""
        return VelocityChange.zeros(config.size)

    def energy_split(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                     e1: np.ndarray, e2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stage ``energy_split``: deformation energies [J] of vehicles 1 and 2."""
        return e1, e2

    def post_impact(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                    inputs: PostImpactInputs) -> PostImpactInputs:
        """Stage ``post_impact``: the run-out inputs of the n colliding cases (brake factors
        (n, 2, 4) [-] of the wheels FL, FR, RL, RR, every one given; front-wheel steer
        angles (n, 2) [rad] and onsets [s], extra drag (n, 2, 4) [-], NaN = default).
        """
        return inputs


# ----------------------------------------------------------------------------
# Registry
# ----------------------------------------------------------------------------

def _check_effect_class(name: str, cls: type[Effect]) -> None:
    if not (isinstance(cls, type) and issubclass(cls, Effect)):
        raise ParameterError(f"{cls!r} is not an Effect subclass")
    if not cls.name or not cls.name.replace("_", "").isalnum():
        raise ParameterError(f"effect class {cls.__name__} needs a name of letters, digits, _")
    if name != cls.name:
        raise ParameterError(f"effect class {cls.__name__} is named {cls.name!r}, not {name!r}")
    if not cls.stages():
        raise ParameterError(f"effect {cls.name} overrides no stage hook of {STAGES}")


def _same_effect_class(old: type[Effect], new: type[Effect]) -> bool:
    # the same class, or the same class of a reloaded module
    return old is new or (old.__module__, old.__qualname__) == (new.__module__,
                                                                new.__qualname__)


#: Effect classes by name: built-in, decorated with :func:`register_effect`, and those of
#: the ``vfs.effects`` entry-point group (loaded when the registry is first read).
EFFECTS: Registry[type[Effect]] = Registry("effect", entry_point_group=ENTRY_POINT_GROUP,
                                           check=_check_effect_class, same=_same_effect_class)
E = TypeVar("E", bound=type[Effect])


def register_effect(cls: E) -> E:
    """Class decorator: add an :class:`Effect` subclass to :data:`EFFECTS`.

    Raises
    ------
    ParameterError
        If the class has no name, hooks nothing, or its name is taken by
        another class.
    """
    if not (isinstance(cls, type) and issubclass(cls, Effect)):
        raise ParameterError(f"{cls!r} is not an Effect subclass")
    EFFECTS.add(cls.name, cls)
    return cls


def unregister_effect(name: str) -> None:
    """Remove an effect from the registry (for tests and interactive use)."""
    EFFECTS.remove(name)


def registered_effects() -> dict[str, type[Effect]]:
    """All registered effect classes by name (built-in, decorated, entry points)."""
    return dict(EFFECTS)


def get_effect(name: str) -> type[Effect]:
    """The effect class registered under ``name``.

    Raises
    ------
    ParameterError
        Naming the known effects if ``name`` is unknown.
    """
    return EFFECTS.get(name)


def parse_effect(spec: str) -> Effect:
    """An effect instance from a command-line spec.

    Forms: ``NAME`` (defaults), ``NAME=VALUE`` (primary parameter),
    ``NAME:PARAM=VALUE,PARAM=VALUE`` (named parameters).
    """
    spec = spec.strip()
    if ":" in spec:
        name, _, rest = spec.partition(":")
        cls = get_effect(name.strip())
        values: dict[str, float] = {}
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, sep, value = item.partition("=")
            if not sep:
                raise ParameterError(f"effect spec {spec!r}: expected PARAM=VALUE, got {item!r}")
            values[key.strip()] = value  # type: ignore[assignment]
        return cls(**values)
    name, sep, value = spec.partition("=")
    cls = get_effect(name.strip())
    if not sep:
        return cls()
    primary = cls.primary()
    if primary is None:
        raise ParameterError(f"effect {cls.name} has no parameter to set")
    return cls(**{primary: value})  # type: ignore[arg-type]


def effects_from_dicts(items: Iterable[Mapping[str, Any]]) -> tuple[Effect, ...]:
    """Effects from :meth:`Effect.to_dict` records (e.g. a model configuration file)."""
    return tuple(get_effect(str(d["name"]))(**dict(d.get("parameters", {})))
                 for d in items)


def check_effects(effects: Iterable[Effect]) -> tuple[Effect, ...]:
    """Validate a sequence of effect instances (no duplicates) and return it as a tuple."""
    out = tuple(effects)
    seen: set[str] = set()
    for e in out:
        if not isinstance(e, Effect):
            raise ParameterError(f"{e!r} is not an Effect instance")
        if e.name in seen:
            raise ParameterError(f"effect {e.name} listed twice")
        seen.add(e.name)
    return out


def call_post_impact(hook: Callable[..., Any], ctx: ImpactContext, config: ImpactConfig,
                     result: ImpactResult, inputs: PostImpactInputs) -> PostImpactInputs:
    """Run one ``post_impact`` hook on the run-out inputs of the colliding cases.

    A hook of the earlier form ``(ctx, config, result, brake1, brake2) -> (brake1,
    brake2)`` (five parameters) gets the brake factors (n, 4) [-] of each vehicle and
    sets them; one of the present form gets and returns the
    :class:`vfs.physics.post_impact.PostImpactInputs`.

    Raises
    ------
    ParameterError
        If the hook returns something else.
    """
    if len(inspect.signature(hook).parameters) == 5:
        b1, b2 = hook(ctx, config, result, np.array(inputs.brake[:, 0]),
                      np.array(inputs.brake[:, 1]))
        return inputs.with_brakes(b1, b2)
    out = hook(ctx, config, result, inputs)
    if not isinstance(out, PostImpactInputs) or out.size != inputs.size:
        raise ParameterError(f"post_impact hook {getattr(hook, '__qualname__', hook)!r} "
                             f"returned {type(out).__name__}, expected PostImpactInputs of "
                             f"{inputs.size} cases")
    return out


def apply_post_impact(effects: Iterable[Effect], ctx: ImpactContext, config: ImpactConfig,
                      result: ImpactResult, inputs: PostImpactInputs) -> PostImpactInputs:
    """The run-out inputs after every ``post_impact`` hook of ``effects``, in order
    (:func:`call_post_impact`).
    """
    for hook in hooks(effects, "post_impact"):
        inputs = call_post_impact(hook, ctx, config, result, inputs)
    return inputs


def hooks(effects: Iterable[Effect], stage: str) -> list[Callable[..., Any]]:
    """Bound hook methods of ``stage`` of the effects that run it
    (:meth:`Effect.active_stages`), in order.
    """
    if stage not in STAGES:
        raise ParameterError(f"unknown stage {stage!r}; stages: {STAGES}")
    return [getattr(e, stage) for e in effects if stage in e.active_stages()]
