"""Gymnasium environments for testing AEB policies on the accident cases.

``gymnasium.make("vfs/AEB-v0", db="default", split="train")`` gives one
environment, ``gymnasium.make_vec("vfs/AEB-v0", num_envs=4096,
vectorization_mode="vector_entry_point", ...)`` the native batched one
(:class:`AEBVectorEnv`); both are registered when ``vfs`` is imported.
docs/gym.md documents observation, action, reward and episode end.

One episode is one case of the database from the start of its record: the
agent controls the brake of the ego vehicle (participant ``ego``), the other
participant follows its recorded path, and at contact the impact is solved
with the same pre-crash simulation (:class:`vfs.physics.precrash.PrecrashRun`),
impact configuration and impulse model as ``vfs study``.

Both environments are thin layers over :class:`EpisodeBatch`, which runs the
episodes of many sub-environments ("slots") as rows of one vectorised
:class:`~vfs.physics.precrash.PrecrashRun`; every slot runs on its own clock, so a
finished slot restarts with a new case while the others go on.  The single
environment is an :class:`EpisodeBatch` of one slot: the same code, the same
numbers.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from vfs.effects.base import parse_effect
from vfs.errors import ParameterError
from vfs.gym.config import (
    DEFAULT_BRAKE,
    DEFAULT_SENSOR,
    EnvConfig,
    RewardParams,
    make_config,
    params_from_dict,
)
from vfs.gym.observation import (
    OBSERVATION_HIGH,
    OBSERVATION_LOW,
    OBSERVATION_NAMES,
    OBSERVATION_UNITS,
    PRIVILEGED_HIGH,
    PRIVILEGED_LOW,
    PRIVILEGED_NAMES,
    TTC_NONE,
    Dimensions,
    observe,
)
from vfs.gym.render import EpisodeTrace, FrameRenderer, ansi_line, record_step, start_trace
from vfs.physics.impact import impact_type_names
from vfs.physics.precrash import KinematicState, PrecrashObservation, PrecrashRun
from vfs.simulation import (
    CaseBatch,
    ImpactInputs,
    SimulationParams,
    impact_stage,
    open_cases,
)
from vfs.units import KMH_PER_MS, G

#: Below this speed [m/s] a vehicle counts as standing still.
STANDSTILL = 1e-6


# ----------------------------------------------------------------------------
# Cases
# ----------------------------------------------------------------------------


def split_case_ids(case_ids: npt.ArrayLike, split: str, test_share: float = 0.2,
                   seed: int = 0) -> np.ndarray:
    """The case ids of a split, in ascending order.

    The ids are sorted, permuted with ``numpy.random.default_rng(seed)`` and
    the first round(test_share x n) (at least one) are "test"; "all" keeps
    every case.
    """
    ids = np.sort(np.asarray(case_ids))
    if split == "all":
        return ids
    n_test = min(max(1, int(round(test_share * ids.size))), max(ids.size - 1, 1))
    perm = np.random.default_rng(seed).permutation(ids.size)
    test = np.zeros(ids.size, dtype=bool)
    test[perm[:n_test]] = True
    return ids[test] if split == "test" else ids[~test]


def _load(cfg: EnvConfig) -> tuple[Any, np.ndarray]:
    """(database, case ids of the split)."""
    from vfs.database import open_database

    db = open_database(cfg.db, cfg.where)
    ids = split_case_ids(db.case_ids, cfg.split, cfg.test_share, cfg.split_seed)
    if ids.size == 0:
        raise ParameterError(f"no case in split {cfg.split!r}"
                             + (f" of the selection {cfg.where!r}" if cfg.where else ""))
    return db, ids


@dataclasses.dataclass(frozen=True)
class SharedCases:
    """What every environment of one configuration reads and none changes: the split's cases
    ready for simulation and their recorded outcome (the replay without braking).

    Built once per configuration and process (:func:`shared_cases`), so that the second and
    every later environment of a vector or a training script skips loading and checking the
    database and replaying its records (about 1 s of CPU for the bundled database).
    """

    database: Any
    split_ids: np.ndarray
    batch: CaseBatch
    penetration: Callable[[np.ndarray, KinematicState], np.ndarray] | None
    eps: np.ndarray
    mu: np.ndarray
    recorded: np.ndarray


#: Configurations kept by :func:`shared_cases` (the most recently used ones).
SHARED_CACHE_SIZE = 4
_SHARED: dict[tuple[Any, ...], SharedCases] = {}


def _shared_key(cfg: EnvConfig, params: SimulationParams) -> tuple[Any, ...]:
    db = cfg.db if isinstance(cfg.db, str) else ("object", id(cfg.db))
    return (db, cfg.where, cfg.split, cfg.test_share, cfg.split_seed,
            str(cfg.impact_parameters), repr(params))


def shared_cases(cfg: EnvConfig, params: SimulationParams) -> SharedCases:
    """The :class:`SharedCases` of a configuration, built on first use and then reused.

    A database given as an object is shared as long as it is the same object; one given by
    name or folder is read once per process (call :func:`clear_shared_cases` after changing
    its files).
    """
    key = _shared_key(cfg, params)
    hit = _SHARED.pop(key, None)
    if hit is not None and (isinstance(cfg.db, str) or hit.database is cfg.db):
        _SHARED[key] = hit  # most recently used last
        return hit
    db, ids = _load(cfg)
    batch, penetration, eps, mu = open_cases(
        CaseBatch.from_database(db, ids, impact_parameters=cfg.impact_parameters), params)
    replay = PrecrashRun(batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction,
                         params=params.precrash, penetration=penetration)
    while not replay.done:
        replay.advance(None)
    shared = SharedCases(db if not isinstance(cfg.db, str) else None, ids, batch,
                         penetration, eps, mu, replay.result().collided)
    _SHARED[key] = shared
    while len(_SHARED) > SHARED_CACHE_SIZE:
        _SHARED.pop(next(iter(_SHARED)))
    return shared


def clear_shared_cases() -> None:
    """Forget every :class:`SharedCases` (the next environment reads its database again)."""
    _SHARED.clear()


def _rest_from(batch: CaseBatch, column: int) -> np.ndarray:
    """Time [s, record axis] from which participant ``column`` (0/1) of each case stands
    still for good (recorded speed 0 to the end of its record and beyond); inf if never.
    """
    n = batch.size
    p = batch.paths
    rows = np.arange(n) + column * n
    speed = p.knots[:, rows, 6]  # (M, n)
    t = p.knots[:, rows, 0]
    m = np.arange(speed.shape[0])[:, None]
    valid = m < p.count[rows][None, :]
    moving = (speed > STANDSTILL) & valid
    last = np.where(moving.any(axis=0), speed.shape[0] - 1 - np.argmax(moving[::-1], axis=0), -1)
    end_moving = moving[p.count[rows] - 1, np.arange(n)]
    nxt = np.minimum(last + 1, p.count[rows] - 1)
    out = np.where(last < 0, 0.0, t[nxt, np.arange(n)])
    return np.where(end_moving, np.inf, out)


# ----------------------------------------------------------------------------
# The episode engine
# ----------------------------------------------------------------------------


class EpisodeBatch:
    """The episodes of ``num_slots`` sub-environments as rows of one PrecrashRun.

    Rows are case instances: the split's cases, tiled when there are more
    slots than cases so that every slot can always draw a case that no other
    slot is running.  A slot draws its next case uniformly among the idle
    instances (with one slot: uniformly among the split's cases), or in
    proportion to the case weights (``near_miss_weight`` for the near misses,
    1 for the crashes) when they differ.

    Parameters
    ----------
    config : EnvConfig
    num_slots : int
    """

    def __init__(self, config: EnvConfig, num_slots: int) -> None:
        if int(num_slots) != num_slots or num_slots < 1:
            raise ParameterError(f"num_envs={num_slots} must be a positive integer")
        self.config = cfg = config
        self.num_slots = int(num_slots)
        effects = tuple(parse_effect(e) if isinstance(e, str) else e for e in cfg.effects)
        base = cfg.simulation
        self.params = dataclasses.replace(
            base, precrash=dataclasses.replace(base.precrash, brake=cfg.brake), effects=effects)
        # loaded, prepared and replayed once per configuration (shared by every env)
        shared = shared_cases(cfg, self.params)
        self.split_ids = shared.split_ids
        batch, penetration, self.eps, self.mu = (shared.batch, shared.penetration,
                                                 shared.eps, shared.mu)
        n_cases = batch.size
        self.batch = batch
        # recorded outcome of every case: a near miss makes any braking unnecessary
        recorded = shared.recorded
        # sampling weight per case; enough copies that the heaviest case is idle about half
        # the time (uniform weights: twice as many instances as slots)
        weight = np.where(recorded, 1.0, cfg.near_miss_weight)
        share = float(weight.max() / weight.sum())
        copies = 1 if self.num_slots == 1 else max(1, math.ceil(2 * self.num_slots * share))
        self.case_index = np.tile(np.arange(n_cases), copies)  # instance -> case of the split
        ci = self.case_index
        self.weight = weight[ci]
        self.uniform = bool(np.all(weight == weight[0]))
        self.dims = Dimensions.of(batch, cfg.ego).take(ci)
        self.recorded_collision = recorded[ci]
        self.other_rest_from = _rest_from(batch, 2 - cfg.ego)[ci]
        self.curve = cfg.reward.curve()
        self.run = PrecrashRun(batch.vehicle1, batch.vehicle2, batch.paths,
                               batch.road_friction, params=self.params.precrash,
                               penetration=penetration, start=np.zeros(0, np.int64),
                               open_ended=True, case_of=ci)
        n = ci.size
        self.slot_row = np.full(self.num_slots, -1, dtype=np.int64)
        self.row_slot = np.full(n, -1, dtype=np.int64)
        self.busy = np.zeros(n, dtype=bool)
        self.prev_decel = np.zeros(n)  # ego deceleration after the last step
        self.braked = np.zeros(n, dtype=bool)  # the ego has braked in this episode

    # ---------------------------------------------------------------- episodes

    def case_id(self, row: int) -> Any:
        """Case id of instance ``row`` (a Python scalar)."""
        return self.batch.case_id[self.case_index[row]].item()

    @property
    def n_cases(self) -> int:
        """Cases in the split."""
        return int(self.split_ids.size)

    def draw(self, slots: np.ndarray, rng: np.random.Generator,
             case_ids: npt.ArrayLike | None = None) -> np.ndarray:
        """Instances (rows) for new episodes of ``slots``: idle instances drawn uniformly,
        or the given case ids.
        """
        m = slots.shape[0]
        free = ~self.busy
        free[self.slot_row[slots][self.slot_row[slots] >= 0]] = True
        if case_ids is not None:
            want = np.broadcast_to(np.asarray(case_ids), (m,))
            pos = np.searchsorted(self.split_ids, want)
            ok = (pos < self.split_ids.size) & (self.split_ids[np.minimum(
                pos, self.split_ids.size - 1)] == want)
            if not ok.all():
                raise ParameterError(f"case_id {want[~ok][0]!r} is not in split "
                                     f"{self.config.split!r}")
            out = np.empty(m, np.int64)
            for j, c in enumerate(pos):  # m is small: explicit choice of cases
                cand = np.flatnonzero(free & (self.case_index == c))
                if cand.size == 0:
                    raise ParameterError(f"case {want[j]!r} is running in every copy")
                out[j] = cand[0]
                free[cand[0]] = False
            return out
        idle = np.flatnonzero(free)
        if not self.uniform and idle.size:  # near_miss_weight: cases in proportion to weight
            cases = self.case_index[idle]
            w = self.weight[idle] / np.bincount(cases)[cases]  # shared by a case's idle copies
            return idle[rng.choice(idle.size, size=m, replace=self.num_slots == 1,
                                   p=w / w.sum())]
        if self.num_slots == 1:
            return idle[rng.integers(idle.size, size=m)] if idle.size else idle
        pick = rng.choice(idle.size, size=m, replace=False)
        return idle[pick]

    def assign(self, slots: np.ndarray, rows: np.ndarray) -> None:
        """Stop what ``slots`` run and give them instances ``rows`` (started by the next
        :meth:`step_rows` or :meth:`start_now`).
        """
        old = self.slot_row[slots]
        old = old[old >= 0]
        running_old = old[self.run.running[old]]
        if running_old.size:
            self.run.stop(running_old)
        self.busy[old] = False
        self.row_slot[old] = -1
        self.slot_row[slots] = rows
        self.row_slot[rows] = slots
        self.busy[rows] = True
        self.prev_decel[rows] = 0.0
        self.braked[rows] = False

    def start_now(self, rows: np.ndarray) -> None:
        """Start ``rows`` (assigned) now, at their time 0; the running rows do not move."""
        self.run.start(rows)

    def demand(self, actions: np.ndarray) -> np.ndarray:
        """Deceleration demand (n, 2) [m/s^2] of the running rows for slot actions (S,)."""
        run = self.run
        rows = run.rows
        a = actions[self.row_slot[rows]]
        # NaN -> 0, then [0, 1] (numpy.nan_to_num's +-inf -> +-max clip alike; one call less)
        a = np.clip(np.where(np.isnan(a), 0.0, a), 0.0, 1.0)
        d = np.zeros((rows.shape[0], 2))
        d[:, self.config.ego - 1] = a * run.limit[rows, 0]
        return d

    def step_rows(self, actions: np.ndarray,
                  start_rows: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Advance the running episodes ``action_repeat`` simulation steps.

        ``actions`` (S,) are the slots' brake demands; ``start_rows``
        (assigned instances) start at the last of these steps, so that they
        begin at their own time 0.  Returns per-slot arrays "reward",
        "terminated", "truncated", the instances that ended ("ended"), and
        for the collided ones "impact_rows", "impact" and "risk".
        """
        cfg, run = self.config, self.run
        s = self.num_slots
        reward = np.zeros(s)
        ended_rows: list[np.ndarray] = []
        trunc_rows: list[np.ndarray] = []
        rw = cfg.reward
        dt = run.dt
        e = cfg.ego - 1
        last = cfg.action_repeat - 1
        for i in range(cfg.action_repeat):
            start = start_rows if i == last else None
            if run.rows.size == 0 and start is None:
                continue
            run.advance(self.demand(actions) if run.rows.size else None, start=start)
            rows = run.rows
            decel = run.track.decel[:, e]
            cost = rw.comfort_weight * np.abs(decel - self.prev_decel[rows]) / G
            near_miss = ~self.recorded_collision[rows]
            cost = cost + np.where(near_miss, rw.unnecessary_brake_weight * decel / G * dt, 0.0)
            if rw.false_activation_weight:  # the first braking step of a near miss
                onset = near_miss & (decel > 0.0) & ~self.braked[rows]
                cost = cost + np.where(onset, rw.false_activation_weight, 0.0)
            self.braked[rows] |= decel > 0.0
            self.prev_decel[rows] = decel
            reward[self.row_slot[rows]] -= cost
            fin = run.finished
            if fin.size:
                run.finalize(fin)
                ended_rows.append(fin[run.collided[fin]])
                trunc_rows.append(fin[~run.collided[fin]])
            # standstill: ego stopped, the object stopped for good; nothing moves any more
            still = run.state.speed[:, e] <= STANDSTILL
            if still.any():  # the other conditions only where the ego stands still
                tau = run.local_time(rows)
                still &= ~run.pending[rows] & (tau > 0.0) & (tau >= self.other_rest_from[rows])
            if still.any():
                r = rows[still]
                run.stop(r, keep_state=True)
                ended_rows.append(r)
        terminated = np.zeros(s, dtype=bool)
        truncated = np.zeros(s, dtype=bool)
        if not ended_rows and not trunc_rows:  # no episode ended (most steps)
            return {"reward": reward, "terminated": terminated, "truncated": truncated,
                    "ended": np.zeros(0, np.int64)}
        ended = np.concatenate(ended_rows) if ended_rows else np.zeros(0, np.int64)
        trunc = np.concatenate(trunc_rows) if trunc_rows else np.zeros(0, np.int64)
        terminated[self.row_slot[ended]] = True
        truncated[self.row_slot[trunc]] = True
        out: dict[str, Any] = {"reward": reward, "terminated": terminated,
                               "truncated": truncated, "ended": np.concatenate([ended, trunc])}
        collided = ended[run.collided[ended]]
        if collided.size:
            imp = self.impacts(collided)
            risk = self.risk(imp)
            reward[self.row_slot[collided]] -= rw.injury_weight * risk + rw.collision_weight
            out["impact_rows"], out["impact"], out["risk"] = collided, imp, risk
        return out

    # ---------------------------------------------------------------- outcomes

    def impacts(self, rows: np.ndarray) -> Any:
        """Impact results (:class:`vfs.physics.impact.ImpactResult`) of collided instances ``rows``
        (the impact stages of :func:`vfs.simulation.simulate_cases`, effects included).
        """
        run = self.run
        cases = self.case_index[rows]
        pre = ImpactInputs(KinematicState(*(a[rows] for a in run.impact_state)),
                            run.poi[rows], run.cp_angle[rows], run.contact_time[rows],
                            run.impact_time[rows])
        hit = np.arange(rows.shape[0])
        _, result, _, _ = impact_stage(self.batch.take(cases), pre, hit, self.eps[cases],
                                       self.mu[cases], self.params)
        return result

    def risk(self, imp: Any) -> np.ndarray:
        """Injury risk per impact (expected injured drivers, or the ego's risk)."""
        e = self.config.ego
        dv = imp.delta_v
        p = np.nan_to_num(self.curve.probability(np.abs(dv)), nan=0.0)
        if self.config.reward.risk_of == "ego":
            return np.where(imp.impact_type != 0, p[:, e - 1], 0.0)
        return np.where(imp.impact_type != 0, p.sum(axis=1), 0.0)

    def observations(self, rows: np.ndarray | None = None) -> np.ndarray:
        """Observations of the running rows (default) or of ended rows (their final state)."""
        run = self.run
        if rows is None:
            return observe(run.observation(), self.dims, self.config)
        return observe(self._final_observation(rows), self.dims, self.config)

    def _final_observation(self, rows: np.ndarray) -> PrecrashObservation:
        run = self.run
        hit = run.collided[rows]
        st = KinematicState(*(np.where(hit[:, None], a[rows], b[rows]) for a, b in
                              zip(run.impact_state, run.end_state, strict=True)))
        decel = np.zeros((rows.shape[0], 2))
        decel[:, self.config.ego - 1] = self.prev_decel[rows]
        return PrecrashObservation(
            rows=rows, t=run.local_time(rows), x=st.x, y=st.y, yaw=st.yaw,
            heading=np.arctan2(st.vy, st.vx), speed=st.speed,
            accel=-decel, yaw_rate=st.yaw_rate, deceleration=decel,
            road_friction=run.mu[rows], vx=st.vx, vy=st.vy)

    def episode_info(self, rows: np.ndarray, imp: Any | None = None,
                     imp_rows: np.ndarray | None = None,
                     risk: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Outcome of ended episodes (arrays over ``rows``; docs/gym.md, "info")."""
        run = self.run
        e = self.config.ego - 1
        n = rows.shape[0]
        collided = run.collided[rows].copy()
        info = {
            "case_id": self.batch.case_id[self.case_index[rows]],
            "collided": collided,
            "recorded_collision": self.recorded_collision[rows],
            "avoided": self.recorded_collision[rows] & ~collided,
            "impact_speed": np.where(collided, run.impact_state.speed[rows, e], np.nan),
            "impact_speed_other": np.where(collided, run.impact_state.speed[rows, 1 - e],
                                           np.nan),
            "closing_speed": np.full(n, np.nan),
            "delta_v": np.full(n, np.nan),
            "delta_v_other": np.full(n, np.nan),
            "impact_type": np.full(n, "none", dtype=object),
            "injury_risk": np.zeros(n),
            "brake_start": run.brake_start[rows, e],
            "speed_reduction": run.speed_reduction[rows, e],
            "time": run.local_time(rows),
        }
        if imp is not None and imp_rows is not None and imp_rows.size:
            order = np.argsort(rows, kind="stable")
            pos = order[np.searchsorted(rows[order], imp_rows)]
            info["delta_v"][pos] = imp.delta_v[:, e]
            info["delta_v_other"][pos] = imp.delta_v[:, 1 - e]
            info["closing_speed"][pos] = imp.closing_speed
            info["impact_type"][pos] = impact_type_names(imp.impact_type).tolist()
            if risk is not None:
                info["injury_risk"][pos] = risk
        return info


# ----------------------------------------------------------------------------
# The single environment
# ----------------------------------------------------------------------------


class AEBEnv(gym.Env[np.ndarray, np.ndarray]):
    """One AEB test episode per accident case (``gymnasium.make("vfs/AEB-v0", ...)``).

    Keyword arguments are the fields of :class:`EnvConfig`.  Action: Box
    [0, 1] (1,), the brake demand as a share of the available deceleration
    (min(road friction x g, actuator limit)), through the brake actuator.
    Observation: :func:`observe`.  Reward: :class:`RewardParams`.  Episode:
    terminated at the impact (or when ego and object have come to rest for
    good), truncated at the end of the case (its record + the simulation's
    extra time) without collision.  ``reset(options={"case_id": ID})``
    plays a given case.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array", "ansi"], "render_fps": 100}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ParameterError(f"render_mode={render_mode!r}; the AEB environment renders "
                                 f"{self.metadata['render_modes']} (or None)")
        self.config = make_config(**kwargs)
        self.core = EpisodeBatch(self.config, 1)
        low, high = self.config.observation_bounds()
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Box(0.0, 1.0, shape=(1,), dtype=np.float32)
        self.render_mode = render_mode
        # one frame per environment step: action_repeat simulation steps of dt
        step = self.config.simulation.precrash.dt * self.config.action_repeat
        self.metadata = {**self.metadata, "render_fps": round(1.0 / step, 3)}
        self._row = -1
        self._case_id: Any = None
        self._done = True
        self._trace: EpisodeTrace | None = None
        self._frames: FrameRenderer | None = None

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode on a random case of the split (or ``options["case_id"]``)."""
        super().reset(seed=seed)
        case = None if not options else options.get("case_id")
        slots = np.zeros(1, np.int64)
        rows = self.core.draw(slots, self.np_random, None if case is None else [case])
        self.core.assign(slots, rows)
        self.core.start_now(rows)
        self._row = int(rows[0])
        self._case_id = self.core.case_id(self._row)
        self._done = False
        if self.render_mode is not None:
            self._trace = start_trace(self.core, self._row)
            record_step(self._trace, self.core, self._row, 0.0)
        obs = self.core.observations()[0]
        return obs, {"case_id": self._case_id, "t": 0.0}

    def step(self, action: npt.ArrayLike) -> tuple[np.ndarray, float, bool, bool,
                                                   dict[str, Any]]:
        """Brake with ``action`` for one step (``action_repeat`` simulation steps)."""
        if self._done:
            raise ParameterError("step() after the episode ended; call reset()")
        a = np.asarray(action, float).reshape(-1)[:1]
        out = self.core.step_rows(a)
        core = self.core
        term, trunc = bool(out["terminated"][0]), bool(out["truncated"][0])
        info: dict[str, Any] = {"case_id": self._case_id}
        if term or trunc:
            row = np.array([self._row])
            self._done = True
            obs = core.observations(row)[0]
            ep = core.episode_info(row, out.get("impact"), out.get("impact_rows"),
                                   out.get("risk"))
            info.update({k: (v[0].item() if hasattr(v[0], "item") else v[0])
                         for k, v in ep.items()})
            if self._trace is not None:
                self._trace.outcome = (
                    f"impact at {info['impact_speed'] * KMH_PER_MS:.0f} km/h "
                    f"({info['impact_type']}), delta-v {info['delta_v'] * KMH_PER_MS:.0f} km/h"
                    if info.get("collided") else
                    "crash avoided" if info.get("avoided") else "no collision")
        else:
            obs = core.observations()[0]
            run = core.run
            info["t"] = float((run.k - run.k0[self._row]) * run.dt)  # run.local_time
            if self._trace is not None:
                record_step(self._trace, core, self._row, float(np.clip(a[0], 0.0, 1.0)))
        return obs, float(out["reward"][0]), term, trunc, info

    def render(self) -> Any:
        """The current step as an RGB frame (H, W, 3) uint8 (``rgb_array``: a top view with
        both outlines, the recorded and driven paths, the sensor's field of view, TTC,
        speed and brake demand) or a line of text (``ansi``); None without a render mode.
        """
        if self.render_mode is None:
            return None
        if self._trace is None or len(self._trace) == 0:
            raise ParameterError("render() before reset()")
        if self.render_mode == "ansi":
            return ansi_line(self._trace)
        if self._frames is None:
            self._frames = FrameRenderer()
        return self._frames.rgb(self._trace)

    @property
    def trace(self) -> EpisodeTrace | None:
        """The states of the running or last episode (with a render mode; else None)."""
        return self._trace

    @property
    def precrash_observation(self) -> PrecrashObservation:
        """The simulation's full state of the running case (privileged; baseline policies)."""
        return self.core.run.observation()


# ----------------------------------------------------------------------------
# The native vector environment
# ----------------------------------------------------------------------------


class AEBVectorEnv(VectorEnv):
    """``num_envs`` AEB environments as one batched simulation (the vector entry point).

    Same episodes, observations and rewards as :class:`AEBEnv` (one slot per
    sub-environment, each on its own clock); autoreset "next step": the step
    after a sub-environment ended starts its next case (its action is
    ignored) and returns that case's first observation.  ``info`` holds
    "case_id" and "t" for every sub-environment and, where an episode ended,
    the outcome keys of :meth:`EpisodeBatch.episode_info` with gymnasium's
    ``_key`` masks.
    """

    metadata: dict[str, Any] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, render_mode: str | None = None,
                 **kwargs: Any) -> None:
        if render_mode is not None:
            raise ParameterError("the AEB environment has no render modes")
        self.config = make_config(**kwargs)
        self.num_envs = int(num_envs)
        self.core = EpisodeBatch(self.config, self.num_envs)
        low, high = self.config.observation_bounds()
        self.single_observation_space = spaces.Box(low, high, dtype=np.float32)
        self.single_action_space = spaces.Box(0.0, 1.0, shape=(1,), dtype=np.float32)
        self.observation_space = spaces.Box(np.tile(low, (self.num_envs, 1)),
                                            np.tile(high, (self.num_envs, 1)), dtype=np.float32)
        self.action_space = spaces.Box(0.0, 1.0, shape=(self.num_envs, 1), dtype=np.float32)
        self.render_mode = None
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._rng = np.random.default_rng()

    def reset(self, *, seed: int | list[int] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Start new episodes in every sub-environment (``options["case_id"]``: array of ids)."""
        if seed is not None:
            self._rng = np.random.default_rng(seed if isinstance(seed, int) else list(seed))
        slots = np.arange(self.num_envs)
        cases = None if not options else options.get("case_id")
        rows = self.core.draw(slots, self._rng, cases)
        self.core.assign(slots, rows)
        self.core.start_now(rows)
        self._autoreset[:] = False
        obs = self._observations()
        return obs, self._base_info()

    def step(self, actions: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                    np.ndarray, dict[str, Any]]:
        """One step of every sub-environment (see the class docstring for autoreset)."""
        core = self.core
        acts = np.asarray(actions, float).reshape(self.num_envs, -1)[:, 0]
        again = np.flatnonzero(self._autoreset)
        start = None
        if again.size:  # autoreset: these start their next case; their actions are ignored
            start = core.draw(again, self._rng)
            core.assign(again, start)
            acts = acts.copy()
            acts[again] = 0.0
        out = core.step_rows(acts, start)
        self._autoreset = out["terminated"] | out["truncated"]
        obs = self._observations()
        info = self._base_info()
        ended = out["ended"]
        if ended.size:
            slots = core.row_slot[ended]
            obs[slots] = core.observations(ended)
            ep = core.episode_info(ended, out.get("impact"), out.get("impact_rows"),
                                   out.get("risk"))
            for key, values in ep.items():
                full = np.zeros(self.num_envs, dtype=values.dtype) if values.dtype != object \
                    else np.full(self.num_envs, None, dtype=object)
                if values.dtype.kind == "f":
                    full[:] = np.nan
                full[slots] = values
                mask = np.zeros(self.num_envs, dtype=bool)
                mask[slots] = True
                if key in info:
                    info[key][slots] = values
                else:
                    info[key], info[f"_{key}"] = full, mask
        return (obs, out["reward"].astype(np.float64), out["terminated"], out["truncated"],
                info)

    def restart(self, slots: npt.ArrayLike) -> np.ndarray:
        """Start the next case now in sub-environments ``slots`` (same-step autoreset, as
        stable-baselines3 expects) and return their first observations (k, d).
        """
        slots = np.asarray(slots, dtype=np.int64).reshape(-1)
        if slots.size == 0:
            return np.zeros((0, self.core.config.observation_dim), np.float32)
        core = self.core
        rows = core.draw(slots, self._rng)
        core.assign(slots, rows)
        core.start_now(rows)
        self._autoreset[slots] = False
        return self._observations()[slots]

    def _observations(self) -> np.ndarray:
        core = self.core
        run = core.run
        obs = np.zeros((self.num_envs, core.config.observation_dim), np.float32)
        if run.rows.size:
            obs[core.row_slot[run.rows]] = core.observations()
        return obs

    def _base_info(self) -> dict[str, Any]:
        core = self.core
        rows = core.slot_row
        t = np.where(core.run.running[rows], core.run.local_time(rows), np.nan)
        every = np.ones(self.num_envs, bool)
        return {"case_id": core.batch.case_id[core.case_index[rows]], "_case_id": every,
                "t": t, "_t": every.copy()}


__all__ = [
    "DEFAULT_BRAKE", "DEFAULT_SENSOR", "OBSERVATION_HIGH", "OBSERVATION_LOW",
    "OBSERVATION_NAMES", "OBSERVATION_UNITS", "PRIVILEGED_HIGH", "PRIVILEGED_LOW",
    "PRIVILEGED_NAMES", "STANDSTILL", "TTC_NONE", "AEBEnv", "AEBVectorEnv", "Dimensions",
    "EnvConfig", "EpisodeBatch", "RewardParams", "SHARED_CACHE_SIZE", "SharedCases",
    "clear_shared_cases", "make_config", "observe", "params_from_dict", "shared_cases",
    "split_case_ids",
]
