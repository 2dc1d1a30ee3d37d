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
    """A generic AEB system (:class:`vfs.adas.definition.AEBSystem`) as an environment policy.

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
        self.dt = config.simulation.precrash.dt
        self.share = np.zeros(batch.size)  # the held action per case

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:  # noqa: D102
        self.policy.reset(n_cases, rng)
        self.share = np.zeros(n_cases)

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        """Deceleration demand (n, 2) [m/s^2]: the policy is asked every ``action_repeat``
        simulation steps of each case (at its steps 0, R, 2R, ...), as in the environment,
        and its action is held in between.
        """
        from vfs.gym.observation import observe

        repeat = int(self.config.action_repeat)
        rows = obs.rows
        if repeat > 1:
            k = np.rint(np.broadcast_to(np.asarray(obs.t, float), rows.shape) / self.dt)
            ask = (k.astype(np.int64) % repeat) == 0
        else:
            ask = np.ones(rows.shape[0], dtype=bool)
        if ask.any():
            sub = obs if ask.all() else _take_rows(obs, ask)
            o = observe(sub, self.dims, self.config)
            new = np.clip(np.nan_to_num(np.asarray(self.policy.act(o), float).reshape(-1),
                                        nan=0.0), 0.0, 1.0)
            if new.shape[0] != sub.rows.shape[0]:
                raise ParameterError(f"policy {self.policy.name!r} returned {new.shape[0]} "
                                     f"actions for {sub.rows.shape[0]} observations")
            self.share[sub.rows] = new
        share = self.share[rows]
        limit = friction_limited_deceleration(obs.road_friction, self.limit_max)
        d = np.zeros((obs.rows.shape[0], 2))
        d[:, self.config.ego - 1] = share * limit
        return d


def _take_rows(obs: PrecrashObservation, mask: np.ndarray) -> PrecrashObservation:
    """The rows ``mask`` of an observation (per-case arrays sliced, scalars kept)."""
    return obs._replace(**{f: getattr(obs, f)[mask] for f in obs._fields
                           if isinstance(getattr(obs, f), np.ndarray)})


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


#: File beside a saved stable-baselines3 model with the environment settings it was
#: trained with (``{"env_kwargs": {...}}``), written by examples/train_ppo.py.
SB3_SETTINGS_SUFFIX = ".vfs.json"
#: File beside a saved model with its VecNormalize statistics (SB3's ``VecNormalize.save``).
SB3_NORMALIZE_SUFFIX = ".vecnormalize.pkl"


class SB3Policy:
    """A saved stable-baselines3 model as a policy (``sb3:PATH.zip``), deterministic actions.

    The algorithm is read from the zip (PPO, A2C, SAC, TD3, DDPG are tried in turn);
    observation normalisation is applied when ``PATH`` + :data:`SB3_NORMALIZE_SUFFIX`
    exists; the environment settings the model was trained with (action repeat, sensor,
    ...) come from ``PATH`` + :data:`SB3_SETTINGS_SUFFIX` when it exists
    (:attr:`env_kwargs`), so that evaluation matches training.
    """

    def __init__(self, path: str) -> None:
        import json
        import pickle
        from pathlib import Path

        try:
            import stable_baselines3 as sb3
        except ImportError:
            raise ParameterError("sb3: policies need stable-baselines3 (pip install "
                                 "'vfs-accident[rl]')") from None
        file = Path(path)
        stem = file.with_suffix("") if file.suffix == ".zip" else file
        zip_file = stem.with_suffix(".zip")
        if not zip_file.is_file():
            raise ParameterError(f"policy sb3:{path}: no file {zip_file}")
        self.model: Any = None
        errors = []
        for algo in ("PPO", "A2C", "SAC", "TD3", "DDPG"):
            try:
                self.model = getattr(sb3, algo).load(str(zip_file), device="cpu")
                break
            except Exception as exc:  # noqa: BLE001 - the next algorithm may fit
                errors.append(f"{algo}: {exc}")
        if self.model is None:
            raise ParameterError(f"policy sb3:{path}: not a model of "
                                 f"PPO/A2C/SAC/TD3/DDPG ({errors[0]})")
        self.name = f"sb3:{stem.name}"
        self.obs_rms: Any = None
        norm = Path(str(stem) + SB3_NORMALIZE_SUFFIX)
        if norm.is_file():
            with open(norm, "rb") as fh:
                vn = pickle.load(fh)
            if getattr(vn, "norm_obs", False):
                self.obs_rms = (vn.obs_rms.mean, np.sqrt(vn.obs_rms.var + vn.epsilon),
                                vn.clip_obs)
        settings = Path(str(stem) + SB3_SETTINGS_SUFFIX)
        self.env_kwargs: dict[str, Any] = (
            json.loads(settings.read_text()).get("env_kwargs", {}) if settings.is_file()
            else {})

    def reset(self, n: int, rng: np.random.Generator) -> None:  # noqa: D102
        return None

    def act(self, observation: np.ndarray) -> np.ndarray:  # noqa: D102
        o = np.asarray(observation, np.float32)
        if self.obs_rms is not None:
            mean, std, clip = self.obs_rms
            o = np.clip((o - mean) / std, -clip, clip).astype(np.float32)
        action, _ = self.model.predict(o, deterministic=True)
        return np.clip(np.asarray(action, float).reshape(-1), 0.0, 1.0)


def load_policy(spec: str) -> Any:
    """A policy (or an AEB system for ``aeb:NAME``) from a command-line spec.

    ``never-brake``, ``always-brake``, ``aeb:NAME`` (an AEB system of
    :mod:`vfs.adas.systems`), ``sb3:PATH`` (a saved stable-baselines3 model,
    :class:`SB3Policy`), or ``MODULE:ATTRIBUTE`` naming a policy object or a
    callable returning one.
    """
    if spec.startswith("sb3:"):
        return SB3Policy(spec[4:])
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
    raise ParameterError(f"unknown policy {spec!r}; use never-brake, always-brake, aeb:NAME, "
                         "sb3:PATH or MODULE:ATTRIBUTE")
