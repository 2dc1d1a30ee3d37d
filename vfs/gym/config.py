"""Settings of the AEB environments: :class:`EnvConfig`, the reward, and dict configs.

Every nested setting of :class:`EnvConfig` may be given as a dict (``gymnasium.make(
"vfs/AEB-v0", simulation={"precrash": {"dt": 0.02}}, reward={"comfort_weight": 0})``), at
any depth: :func:`params_from_dict` builds the frozen dataclass from its defaults and the
keys given, and names an unknown key with the keys allowed.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, TypeVar

import numpy as np

from vfs.adas.params import SensorParams
from vfs.analysis.risk import default_risk_curve, get_risk_curve
from vfs.effects.base import parse_effect
from vfs.errors import ParameterError
from vfs.gym.observation import (
    OBSERVATION_HIGH,
    OBSERVATION_LOW,
    OBSERVATION_NAMES,
    PRIVILEGED_HIGH,
    PRIVILEGED_LOW,
    PRIVILEGED_NAMES,
    THREAT_HIGH,
    THREAT_LOW,
    THREAT_NAMES,
)
from vfs.physics.precrash import BrakeActuatorParams
from vfs.simulation import ImpactParameterSource, SimulationParams

T = TypeVar("T")




@dataclass(frozen=True)
class RewardParams:
    """Reward of the AEB environments (docs/gym.md, "Reward").

    Per step the reward is minus

    - ``unnecessary_brake_weight`` x (ego deceleration / g) x dt in a case
      whose recorded paths do not collide (a near miss: any braking is
      unnecessary), [1 / (g s)];
    - ``comfort_weight`` x |change of the ego deceleration| / g per step
      (total variation of the brake, [1 / g]);
    - ``false_activation_weight`` once, at the first step with any ego
      deceleration in a near miss (an unnecessary activation, counted as the
      evaluation counts braking in near misses), [-];

    and at a collision (the terminal step) minus ``injury_weight`` x the
    injury risk of the impact's delta-v by the curve ``risk_curve`` (default:
    the default curve of ``injury_level``, as in ``vfs report
    effectiveness``), summed over both drivers (``risk_of="both"``, the
    expected number of injured drivers) or the ego driver only, and minus
    ``collision_weight`` (a cost of any collision, whatever its severity).

    Attributes
    ----------
    injury_weight : float
        Weight of the injury risk [-], default 1.
    injury_level : str
        Injury level of the default curve, default "MAIS3+".
    risk_curve : str or None
        Name of a registered curve (:mod:`vfs.analysis.risk`); overrides ``injury_level``.
    risk_of : {"both", "ego"}
        Whose risk counts, default "both".
    unnecessary_brake_weight : float
        Default 0.05 per g s: a 1 g stop from 50 km/h in a near miss costs
        about 0.07, a few per cent of a likely MAIS3+ injury.
    comfort_weight : float
        Default 0.01 per g of brake change: applying and releasing a full
        brake costs 0.02.
    false_activation_weight : float
        Cost of braking at all in a near miss, default 0 (none).
    collision_weight : float
        Cost of a collision besides its injury risk [-], default 0 (none).
    """

    injury_weight: float = 1.0
    injury_level: str = "MAIS3+"
    risk_curve: str | None = None
    risk_of: str = "both"
    unnecessary_brake_weight: float = 0.05
    comfort_weight: float = 0.01
    false_activation_weight: float = 0.0
    collision_weight: float = 0.0

    def __post_init__(self) -> None:
        if self.risk_of not in ("both", "ego"):
            raise ParameterError(f"risk_of={self.risk_of!r}; use 'both' or 'ego'")
        for name in ("injury_weight", "unnecessary_brake_weight", "comfort_weight",
                     "false_activation_weight", "collision_weight"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(f"reward {name}={value} must be finite and >= 0")

    def curve(self) -> Any:
        """The risk curve (:class:`vfs.analysis.risk.RiskCurve`)."""
        if self.risk_curve:
            return get_risk_curve(self.risk_curve)
        return default_risk_curve(self.injury_level)


#: Sensor of the environments by default: 150 m, 1.6 rad (about 92 deg: a radar and
#: camera fusion that also sees crossing traffic), every step, no latency.
DEFAULT_SENSOR = SensorParams(field_of_view=1.6, cycle_time=0.0, latency=0.0)

#: Brake actuator by default: the declared defaults (jerk 40 m/s^3, as
#: vfs.adas.systems.THREE_STAGE).
DEFAULT_BRAKE = BrakeActuatorParams()


class Split(StrEnum):
    """The cases of an environment (:attr:`EnvConfig.split`)."""

    TRAIN = "train"
    TEST = "test"
    ALL = "all"


@dataclass(frozen=True)
class EnvConfig:
    """Settings of the AEB environments (the keyword arguments of ``gymnasium.make``).

    Attributes
    ----------
    db : str or Database
        Database folder, "default" (the bundled one) or a loaded Database.
    split : {"train", "test", "all"}
        Which cases: a fixed random share ``test_share`` of the cases
        (permutation seeded with ``split_seed``) is "test", the rest "train".
    test_share : float
        Share of test cases, default 0.2.
    split_seed : int
        Seed of the split, default 0.
    where : str, optional
        SQL filter on the cases table first (duckdb, as ``--where``).
    ego : {1, 2}
        The participant the agent brakes, default 1.
    sensor : SensorParams
        The ego's sensor (field of view, range, mounting); default
        :data:`DEFAULT_SENSOR`.  Its cycle time and latency are not modelled
        here (each step observes the present).
    observe_friction : bool
        Include the road friction coefficient in the observation (else 0);
        default True.
    privileged : bool
        Observe the full state (:data:`PRIVILEGED_NAMES`) instead of the
        sensor (:data:`OBSERVATION_NAMES`); default False.
    threat_features : bool
        Append the threat entries (:data:`THREAT_NAMES`: yaw rates, the
        constant-velocity miss distance and time of closest approach, the
        constant-turn-rate TTC of the outlines) to the observation; default
        False (the observation of earlier versions).
    near_miss_weight : float
        Sampling weight of the near-miss cases (recorded paths do not collide)
        relative to the crashes when episodes draw their case; default 1
        (uniform).  A weight above 1 shows a policy the cases where braking is
        unnecessary more often (training); evaluations play every case once.
    brake : BrakeActuatorParams
        Actuator between the demand and the delivered deceleration; default
        :data:`DEFAULT_BRAKE` (the generic AEB's).
    action_repeat : int
        Simulation steps per environment step (each of ``simulation.precrash.dt``,
        default 10 ms); default 1.
    reward : RewardParams
    simulation : SimulationParams
        Pre-crash and impact settings (its brake is replaced by ``brake``).
    impact_parameters : {"reconstruction", "default"}
        Restitution and contact friction per case from the reconstruction or
        the defaults, as ``vfs study``.
    effects : tuple of str
        Physical effects (:mod:`vfs.effects`, "NAME[:P=V,...]") added to the model.
    """

    db: Any = "default"
    split: str = "train"
    test_share: float = 0.2
    split_seed: int = 0
    where: str | None = None
    ego: int = 1
    sensor: SensorParams = DEFAULT_SENSOR
    observe_friction: bool = True
    privileged: bool = False
    threat_features: bool = False
    near_miss_weight: float = 1.0
    brake: BrakeActuatorParams = DEFAULT_BRAKE
    action_repeat: int = 1
    reward: RewardParams = field(default_factory=RewardParams)
    simulation: SimulationParams = field(default_factory=SimulationParams)
    impact_parameters: str = "reconstruction"
    effects: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.split not in set(Split):
            raise ParameterError(f"split={self.split!r}; use one of {', '.join(Split)}")
        if not 0.0 < self.test_share < 1.0:
            raise ParameterError(f"test_share={self.test_share} outside (0, 1)")
        if self.ego not in (1, 2):
            raise ParameterError(f"ego={self.ego!r}; use 1 or 2")
        if int(self.action_repeat) != self.action_repeat or not 1 <= self.action_repeat <= 100:
            raise ParameterError(f"action_repeat={self.action_repeat} outside 1..100")
        if not (math.isfinite(self.near_miss_weight) and self.near_miss_weight > 0.0):
            raise ParameterError(f"near_miss_weight={self.near_miss_weight} must be finite "
                                 "and > 0")
        if self.impact_parameters not in set(ImpactParameterSource):
            raise ParameterError(f"impact_parameters={self.impact_parameters!r}; use one of "
                                 f"{', '.join(ImpactParameterSource)}")
        if isinstance(self.effects, str):
            object.__setattr__(self, "effects", (self.effects,))

    @property
    def observation_dim(self) -> int:
        """Length of the observation vector."""
        return len(self.observation_names)

    @property
    def observation_names(self) -> tuple[str, ...]:
        """Names of the observation's entries, in order."""
        base = PRIVILEGED_NAMES if self.privileged else OBSERVATION_NAMES
        return base + (THREAT_NAMES if self.threat_features else ())

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation Box (float32)."""
        low, high = (PRIVILEGED_LOW, PRIVILEGED_HIGH) if self.privileged else \
            (OBSERVATION_LOW, OBSERVATION_HIGH)
        if self.threat_features:
            low, high = np.concatenate([low, THREAT_LOW]), np.concatenate([high, THREAT_HIGH])
        return low.astype(np.float32), high.astype(np.float32)


def params_from_dict(cls: type[T], value: Any, where: str = "") -> T:
    """A frozen parameter dataclass ``cls`` from a dict (nested dicts for nested dataclasses).

    Parameters
    ----------
    cls : type
        The dataclass (e.g. :class:`vfs.simulation.SimulationParams`).
    value : Mapping or cls
        Keys are field names; absent fields keep their defaults.  An instance of
        ``cls`` is returned unchanged.  In ``SimulationParams.effects``, strings
        ``"NAME[:P=V,...]"`` are parsed as effects.
    where : str
        Dotted path of ``value`` for error messages.

    Raises
    ------
    ParameterError
        An unknown key (the message lists the allowed ones) or a value the
        dataclass rejects.
    """
    if isinstance(value, cls):
        return value
    if not isinstance(value, Mapping):
        raise ParameterError(f"{where or cls.__name__}: expected a dict or {cls.__name__}, "
                             f"got {type(value).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(value) - set(fields))
    if unknown:
        raise ParameterError(f"{where or cls.__name__}: unknown setting(s) {unknown}; "
                             f"allowed: {', '.join(sorted(fields))}")
    hints = typing.get_type_hints(cls)
    kwargs: dict[str, Any] = {}
    for name, v in value.items():
        path = f"{where}.{name}" if where else name
        hint = hints.get(name)
        if isinstance(hint, type) and dataclasses.is_dataclass(hint):
            kwargs[name] = params_from_dict(hint, v, path)
        elif name == "effects" and cls is SimulationParams:
            items = (v,) if isinstance(v, str) else tuple(v)
            kwargs[name] = tuple(parse_effect(e) if isinstance(e, str) else e for e in items)
        else:
            kwargs[name] = v
    try:
        return cls(**kwargs)
    except TypeError as err:  # a wrong type deep inside
        raise ParameterError(f"{where or cls.__name__}: {err}") from None


def make_config(**kwargs: Any) -> EnvConfig:
    """An :class:`EnvConfig` from keyword arguments; every nested setting may be a dict.

    Examples
    --------
    >>> cfg = make_config(simulation={"precrash": {"dt": 0.02}}, reward={"risk_of": "ego"})
    >>> cfg.simulation.precrash.dt, cfg.reward.risk_of
    (0.02, 'ego')
    """
    if "effects" in kwargs and kwargs["effects"] is not None:
        eff = kwargs["effects"]
        kwargs["effects"] = (eff,) if isinstance(eff, str) else tuple(eff)
    known = {f.name for f in dataclasses.fields(EnvConfig)}
    unknown = sorted(set(kwargs) - known)
    if unknown:
        raise ParameterError(f"unknown AEB environment setting(s) {unknown}; known: "
                             f"{', '.join(sorted(known))}")
    return params_from_dict(EnvConfig, kwargs, "")


__all__ = [
    "DEFAULT_BRAKE", "DEFAULT_SENSOR", "EnvConfig", "RewardParams", "make_config",
    "params_from_dict",
]
