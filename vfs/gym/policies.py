"""Brake policies for the AEB environments, and their evaluation as a study.

A policy maps observations of the AEB environments (:func:`vfs.gym.env.observe`,
shape (n, d)) to brake demands in [0, 1] (share of the available
deceleration).  Baselines:

``never-brake``
    Always 0: the recorded behaviour (the study's baseline).
``always-brake``
    Always 1: full braking from the first step.
``aeb:NAME``
    A generic AEB system of :mod:`vfs.adas.systems` (e.g. ``aeb:three-stage``) as
    a policy.  It is *privileged*: it runs its own sensor model (field of
    view, cycle, latency) on the simulation's full state, which it reads
    from the environment it is bound to (:meth:`AEBPolicy.bind`).

:class:`PolicySystem` turns a policy into a system for :func:`vfs.study.run_study`:
a controller that computes the same observation from the simulation state
each step and brakes the ego vehicle with the policy's demand through the
same actuator.  ``vfs evaluate-policy`` uses it, so a policy is evaluated
with the study's orchestrator (chunks, resume, executors, errors recorded per
case) and gets the same effectiveness report as a study.
"""

from __future__ import annotations

import dataclasses
import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from vfs.errors import ParameterError
from vfs.physics.precrash import (
    PrecrashObservation,
    PrecrashParams,
    friction_limited_deceleration,
)

if TYPE_CHECKING:
    from vfs.gym.config import EnvConfig
    from vfs.simulation import CaseBatch


@runtime_checkable
class Policy(Protocol):
    """A brake policy: observations (n, d) -> brake demands (n,) in [0, 1]."""

    name: str

    def reset(self, n: int, rng: np.random.Generator) -> None:
        """Prepare for ``n`` episodes run together (an evaluation batch or one episode)."""

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Brake demand per row of ``observation`` (n,) or (n, 1), in [0, 1]."""


@dataclass(frozen=True)
class ConstantBrake:
    """Brake demand ``level`` in every step (0: never brake, 1: always full braking)."""

    level: float = 0.0
    name: str = "never-brake"

    def __post_init__(self) -> None:
        if not 0.0 <= self.level <= 1.0:
            raise ParameterError(f"brake level {self.level} outside [0, 1]")

    def reset(self, n: int, rng: np.random.Generator) -> None:  # noqa: D102
        return None

    def act(self, observation: np.ndarray) -> np.ndarray:  # noqa: D102
        return np.full(np.asarray(observation).shape[0], self.level, dtype=np.float32)


NEVER_BRAKE = ConstantBrake(0.0, "never-brake")
ALWAYS_BRAKE = ConstantBrake(1.0, "always-brake")


class AEBPolicy:
    """A generic AEB system (:class:`vfs.adas.systems.AEBSystem`) as an environment policy.

    Privileged: :meth:`act` ignores the observation and runs the system's
    own sensor, threat assessment, stages and driver model on the state of
    the environment it is bound to (an :class:`vfs.gym.env.AEBEnv` or
    :class:`vfs.gym.env.AEBVectorEnv` whose episodes all started
    together).  Call :meth:`bind` once and :meth:`reset` at the start of
    every episode (batch); the environment's brake actuator should be the
    system's (``brake=system.brake``) for results equal to a study.
    """

    def __init__(self, system: Any) -> None:
        if getattr(system, "aeb", None) is None:
            raise ParameterError(f"AEB system {getattr(system, 'name', system)!r} has no AEB")
        self.system = system
        self.name = f"aeb:{system.name}"
        self._core: Any = None
        self._controller: Any = None

    def bind(self, env: Any) -> AEBPolicy:
        """Use the state of ``env`` (gymnasium env or vector env, wrappers allowed)."""
        core = getattr(getattr(env, "unwrapped", env), "core", None)
        if core is None:
            raise ParameterError("AEBPolicy.bind needs a vfs AEB environment")
        self._core = core
        batch = core.batch.take(core.case_index)
        eq = np.zeros((batch.size, 2), dtype=bool)
        eq[:, core.config.ego - 1] = True
        self._controller = self.system.controller(batch, eq)
        return self

    def reset(self, n: int, rng: np.random.Generator) -> None:
        """Fresh controller state (driver draws from ``rng``) for the episodes now starting."""
        if self._controller is None:
            raise ParameterError("AEBPolicy: call bind(env) first")
        self._controller.reset(self._controller.equipped.shape[0], rng)

    def act(self, observation: np.ndarray) -> np.ndarray:
        """The system's demand for the bound environment's running episodes, as a share of
        the available deceleration (one value per running episode, in slot order).
        """
        core = self._core
        if core is None:
            raise ParameterError("AEBPolicy: call bind(env) first")
        run = core.run
        p = run.observation()
        if not isinstance(p.t, float):
            raise ParameterError("AEBPolicy needs episodes that started together (one clock): "
                                 "use AEBEnv, or AEBVectorEnv without autoreset "
                                 "(evaluate-policy)")
        demand = np.asarray(self._controller.demand(p), float)[:, core.config.ego - 1]
        share = np.clip(demand / run.limit[p.rows, 0], 0.0, 1.0)
        out = np.zeros(core.num_slots)
        out[core.row_slot[p.rows]] = share
        return out

    def events(self) -> dict[str, np.ndarray]:
        """The controller's events (:meth:`vfs.adas.controller.AEBController.events`)."""
        return self._controller.events()


# ----------------------------------------------------------------------------
# Policies as study systems
# ----------------------------------------------------------------------------


class PolicyController:
    """A :class:`vfs.physics.precrash.BrakeController` that asks a policy.

    See :class:`PolicySystem`.
    """

    def __init__(self, policy: Policy, batch: CaseBatch, config: EnvConfig) -> None:
        from vfs.gym.observation import Dimensions

        self.policy = policy
        self.config = config
        self.dims = Dimensions.of(batch, config.ego)
        self.limit_max = config.brake.max_deceleration

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:  # noqa: D102
        self.policy.reset(n_cases, rng)

    def demand(self, obs: PrecrashObservation) -> np.ndarray:  # noqa: D102
        from vfs.gym.observation import observe

        o = observe(obs, self.dims, self.config)
        share = np.clip(np.nan_to_num(np.asarray(self.policy.act(o), float).reshape(-1),
                                      nan=0.0), 0.0, 1.0)
        if share.shape[0] != obs.rows.shape[0]:
            raise ParameterError(f"policy {self.policy.name!r} returned {share.shape[0]} "
                                 f"actions for {obs.rows.shape[0]} observations")
        limit = friction_limited_deceleration(obs.road_friction, self.limit_max)
        d = np.zeros((obs.rows.shape[0], 2))
        d[:, self.config.ego - 1] = share * limit
        return d


@dataclass(frozen=True)
class PolicySystem:
    """A policy as a system of :func:`vfs.study.run_study` (the ego vehicle brakes).

    Attributes
    ----------
    policy : Policy
    config : EnvConfig
        Observation settings, ego and brake actuator (as the environment's).
    """

    policy: Any
    config: Any

    @property
    def name(self) -> str:
        """System name: the policy's."""
        return str(self.policy.name)

    @property
    def description(self) -> str:
        """One line for reports."""
        return (f"policy {self.policy.name} on vehicle {self.config.ego} "
                f"({'privileged' if self.config.privileged else 'sensor'} observation)")

    @property
    def brake(self) -> Any:
        """The brake actuator."""
        return self.config.brake

    def controller(self, batch: CaseBatch, equipped: np.ndarray) -> PolicyController:
        """A controller for ``batch`` (the ego of the configuration brakes)."""
        return PolicyController(self.policy, batch, self.config)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``base`` with the configuration's brake actuator."""
        return dataclasses.replace(base, brake=self.config.brake)


def load_policy(spec: str) -> Any:
    """A policy (or an AEB system for ``aeb:NAME``) from a command-line spec.

    ``never-brake``, ``always-brake``, ``aeb:NAME`` (an AEB system of
    :mod:`vfs.adas.systems`), or ``MODULE:ATTRIBUTE`` naming a policy object or
    a callable returning one.
    """
    if spec == "never-brake":
        return NEVER_BRAKE
    if spec == "always-brake":
        return ALWAYS_BRAKE
    if spec.startswith("aeb:"):
        from vfs.adas.systems import get_system

        return get_system(spec[4:])
    if ":" in spec:
        module, _, attr = spec.partition(":")
        try:
            obj: Any = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError) as exc:
            raise ParameterError(f"policy {spec!r}: {exc}") from None
        if not isinstance(obj, Policy) and callable(obj):
            obj = obj()
        if not isinstance(obj, Policy):
            raise ParameterError(f"policy {spec!r} has no name/reset/act")
        return obj
    raise ParameterError(f"unknown policy {spec!r}; use never-brake, always-brake, aeb:NAME "
                         "or MODULE:ATTRIBUTE")
