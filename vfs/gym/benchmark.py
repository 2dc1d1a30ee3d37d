"""The gym benchmark's measures beside avoided crashes: unnecessary braking, comfort, one score.

Avoided crashes alone reward a policy that brakes early and everywhere: on a database of
conflicts only, braking from the first step avoids nearly every crash.  The benchmark
therefore also measures, on the same study:

- **unnecessary braking**: in the cases where the baseline (the recorded behaviour) does
  not crash (near misses; non-conflict cases where a database has them), the share in which
  the system's brake delivers at least :data:`BRAKE_THRESHOLD` while the ego moves, the
  speed it takes away there [km/h] (also as a share of the ego's speed at the start) and
  the time it brakes at or above the threshold there [s];
- **comfort**, over every case of the split: per case the peak deceleration of the
  system's brake [m/s^2], its peak jerk (rate of change) [m/s^3] and the time above
  :data:`HARSH_DECELERATION` [s], all while the ego moves.

"The system's brake" is the deceleration the brake actuator delivers for the system (the
recorded driver's own braking is part of the record, not of the system; a driver model of
an AEB system, who brakes after a warning, is part of the system).

**The score** (:func:`benchmark_score`, the one place of its formula and weights)::

    score = (avoided - new crashes) / baseline crashes
            - UNNECESSARY_WEIGHT * mean over the no-crash cases of
                  min(1, speed taken by the system's brake / ego speed at the start)
            - HARSH_WEIGHT * mean time per case above HARSH_DECELERATION [s]

A system that does nothing scores 0.  Braking every no-crash case to a stop costs
:data:`UNNECESSARY_WEIGHT`, as much as avoiding every crash gains: a database of accident
cases holds conflicts only, while on the road a system meets far more situations without
a conflict than with one, so each unnecessary brake in the few near misses stands for
many.  The unnecessary term weighs how much speed is taken, not only whether the brake
acts: a short last-moment brake in a close pass costs little, a full stop costs the most.
One second of harsh braking per case costs :data:`HARSH_WEIGHT` (braking hard when it is
needed is right, so this weight is small: it only separates equally effective systems).

The measures come from :class:`ComfortRecorder`, which wraps a system's controller in a
study (:class:`ComfortSystem`) and adds the per-case aggregates to the controller's events
(columns ``peak_decel{i}``, ``peak_jerk{i}``, ``harsh_time{i}``, ``brake_time{i}`` of
``runs.parquet``); it passes the demand on unchanged, so the runs are those without it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from vfs.physics.precrash import PrecrashObservation, PrecrashParams
    from vfs.simulation import CaseBatch

#: Deceleration of the system's brake [m/s^2] from which it counts as braking: 0.1 g, a
#: brake a driver notices (well above the drag of a coasting car, about 0.3 m/s^2), low
#: enough that long gentle braking, which takes as much speed, cannot slip under it.
BRAKE_THRESHOLD = 1.0
#: Deceleration of the system's brake [m/s^2] above which braking counts as harsh.
HARSH_DECELERATION = 4.0
#: Speed [m/s] below which the ego counts as standing (a brake held at standstill is
#: neither felt nor unnecessary).
MOVING_SPEED = 0.1
#: Weight of the unnecessary-braking share in the score (braking in every near miss costs
#: as much as avoiding every crash gains).
UNNECESSARY_WEIGHT = 1.0
#: Weight of the mean time above :data:`HARSH_DECELERATION` per case [1/s] in the score.
HARSH_WEIGHT = 0.1
#: Per-case aggregates the recorder adds to the events (columns ``<key>1``, ``<key>2``).
COMFORT_KEYS = ("peak_decel", "peak_jerk", "harsh_time", "brake_time", "speed_taken",
                "start_speed")


class ComfortRecorder:
    """A controller that passes ``inner``'s demand on and aggregates the delivered braking.

    Per case and participant, over the steps in which the vehicle moves (speed above
    :data:`MOVING_SPEED`): the peak delivered deceleration [m/s^2], the peak of its
    rate of change between consecutive steps [m/s^3], and the time [s] with a delivered
    deceleration above :data:`HARSH_DECELERATION` and above :data:`BRAKE_THRESHOLD`,
    the speed the brake takes away [m/s] (the integral of the delivered deceleration while
    the vehicle moves) and the speed at the case's first step [m/s].

    Parameters
    ----------
    inner : SystemController
        The system's controller.
    n : int
        Number of cases of the batch.
    """

    def __init__(self, inner: Any, n: int) -> None:
        self.inner = inner
        self._clear(n)

    def _clear(self, n: int) -> None:
        self._peak = np.zeros((n, 2))
        self._jerk = np.zeros((n, 2))
        self._harsh = np.zeros((n, 2))
        self._brake = np.zeros((n, 2))
        self._taken = np.zeros((n, 2))
        self._start = np.full((n, 2), np.nan)
        self._last_t = np.full(n, np.nan)
        self._last_decel = np.zeros((n, 2))

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Reset ``inner`` (same ``rng``) and the aggregates."""
        self.inner.reset(n_cases, rng)
        self._clear(n_cases)

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        """``inner``'s demand [m/s^2] (n, 2), unchanged; the step's braking is aggregated."""
        out = self.inner.demand(obs)
        rows = obs.rows
        t = np.broadcast_to(np.asarray(obs.t, float), rows.shape)
        decel = np.asarray(obs.deceleration, float)
        moving = np.asarray(obs.speed, float) > MOVING_SPEED
        step = t - self._last_t[rows]                       # NaN at a case's first step
        known = np.isfinite(step) & (step > 0)
        felt = np.where(moving, decel, 0.0)
        self._peak[rows] = np.maximum(self._peak[rows], felt)
        rate = np.where(known[:, None] & moving,
                        np.abs(decel - self._last_decel[rows])
                        / np.where(known, step, 1.0)[:, None], 0.0)
        self._jerk[rows] = np.maximum(self._jerk[rows], rate)
        # the step that ends now ran with the previous step's deceleration
        held = np.where(known, step, 0.0)[:, None] * moving
        self._harsh[rows] += held * (self._last_decel[rows] > HARSH_DECELERATION)
        self._brake[rows] += held * (self._last_decel[rows] >= BRAKE_THRESHOLD)
        self._taken[rows] += held * self._last_decel[rows]
        first = ~np.isfinite(self._last_t[rows])
        self._start[rows[first]] = np.asarray(obs.speed, float)[first]
        self._last_t[rows] = t
        self._last_decel[rows] = decel
        return out

    def events(self) -> dict[str, np.ndarray]:
        """``inner``'s events and the aggregates of :data:`COMFORT_KEYS`, each (N, 2)."""
        events = getattr(self.inner, "events", None)
        own = dict(events()) if callable(events) else {}
        own.update(zip(COMFORT_KEYS, (self._peak.copy(), self._jerk.copy(),
                                      self._harsh.copy(), self._brake.copy(),
                                      self._taken.copy(), self._start.copy()), strict=True))
        return own


class SegmentableComfortRecorder(ComfortRecorder):
    """:class:`ComfortRecorder` of a controller that runs several chunks as one batch."""

    def reset_segments(self, sizes: tuple[int, ...],
                       generators: tuple[np.random.Generator, ...]) -> None:
        """``inner.reset_segments`` and fresh aggregates."""
        self.inner.reset_segments(sizes, generators)
        self._clear(int(sum(sizes)))


@dataclass(frozen=True)
class ComfortSystem:
    """``system`` with its controller wrapped in a :class:`ComfortRecorder` (same runs).

    Every other attribute (``aeb``, ``driver``, ``brake``, ...) is ``system``'s, so the
    study describes it as ``system``.
    """

    system: Any

    def __getattr__(self, name: str) -> Any:
        if name == "system" or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.system, name)

    @property
    def name(self) -> str:
        """``system``'s name."""
        return str(self.system.name)

    @property
    def description(self) -> str:
        """``system``'s description."""
        return str(self.system.description)

    def controller(self, batch: CaseBatch, equipped: Any) -> ComfortRecorder | None:
        """``system``'s controller, wrapped (None stays None: no braking of its own)."""
        inner = self.system.controller(batch, equipped)
        if inner is None:
            return None
        cls = (SegmentableComfortRecorder if callable(getattr(inner, "reset_segments", None))
               else ComfortRecorder)
        return cls(inner, batch.size)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``system``'s pre-crash parameters."""
        return self.system.precrash_params(base)


#: Generator preset of the benchmark's cases without a conflict (``scenarios/presets``).
PASSING_PRESET = "passing"
#: Seed of the generated passes evaluated by the benchmark (training uses others).
PASSING_SEED = 1
#: Number of generated passes the benchmark evaluates (as many as the test split's cases).
PASSING_CASES = 120
#: Offset added to the case ids of the generated passes in a combined database.
PASSING_ID_OFFSET = 1_000_000


def with_passes(db: Any, n_cases: int = PASSING_CASES, seed: int = PASSING_SEED,
                id_offset: int = PASSING_ID_OFFSET) -> Any:
    """``db`` and ``n_cases`` generated passes without a conflict, as one database.

    The passes are ``vfs generate --preset passing --seed SEED`` (recorded paths that
    clear each other by 1.5 to 5 m); their case ids get ``id_offset`` added, so they
    cannot collide with ``db``'s (an error if they would).

    Parameters
    ----------
    db : Database
    n_cases : int
    seed : int
    id_offset : int

    Returns
    -------
    Database
        With ``db``'s meta; its description names the added passes.
    """
    import dataclasses

    import pandas as pd

    from vfs.errors import ParameterError
    from vfs.scenarios.generator import generate_database

    passes, _ = generate_database(PASSING_PRESET, n_cases, seed=seed)
    tables = {}
    for name, own in db.tables().items():
        extra = passes.tables()[name].copy()
        if "case_id" in extra.columns:
            extra["case_id"] = extra["case_id"].astype("int64") + id_offset
        tables[name] = pd.concat([own, extra], ignore_index=True) if len(extra) else own
    ids = tables["cases"]["case_id"]
    if ids.duplicated().any():
        raise ParameterError(f"with_passes: case ids of the database reach {id_offset}; "
                             "pass a larger id_offset")
    meta = dict(db.meta)
    meta["description"] = (f"{meta.get('description', '')} + {n_cases} generated passes "
                           f"without a conflict (preset {PASSING_PRESET!r}, seed {seed})")
    return dataclasses.replace(db, **tables, meta=meta).normalised()


def benchmark_score(net_avoided_share: float, unnecessary_speed_share: float,
                    harsh_time: float) -> float:
    """The benchmark's combined score (module docstring; higher is better, nothing = 0).

    Parameters
    ----------
    net_avoided_share : float
        (crashes avoided - new crashes) / crashes of the baseline, in [-1, 1].
    unnecessary_speed_share : float
        Mean over the no-crash cases of min(1, speed taken by the system's brake / speed
        at the start), in [0, 1].
    harsh_time : float
        Mean time per case with the system's brake above :data:`HARSH_DECELERATION` [s].
    """
    return (net_avoided_share - UNNECESSARY_WEIGHT * unnecessary_speed_share
            - HARSH_WEIGHT * harsh_time)


def benchmark_measures(runs: Any, system: str, ego: int = 1,
                       baseline: str = "baseline") -> dict[str, float]:
    """The benchmark's measures of ``system`` from a study's runs table.

    Parameters
    ----------
    runs : pandas.DataFrame
        ``runs.parquet`` of a study whose systems ran as :class:`ComfortSystem`.
    system : str
    ego : int
        The braked vehicle (1 or 2).
    baseline : str
        Name of the baseline rows.

    Returns
    -------
    dict
        ``crashes`` (baseline), ``avoided``, ``new_crashes``, ``net_avoided_share``;
        ``no_crash_cases``, ``unnecessary`` (count), ``unnecessary_share``,
        ``unnecessary_speed_loss_kmh``, ``unnecessary_speed_share`` and
        ``unnecessary_brake_time`` (means over the no-crash cases); ``brakes_share``
        (all cases), ``peak_decel`` [m/s^2] and
        ``peak_jerk`` [m/s^3] (means over the cases where it brakes), ``peak_decel_max``,
        ``harsh_time`` [s] (mean per case); ``score`` (:func:`benchmark_score`).
    """
    from vfs.errors import ParameterError
    from vfs.units import KMH_PER_MS

    base = runs[runs["system"] == baseline].set_index("case_id")
    mine = runs[runs["system"] == system].set_index("case_id").reindex(base.index)
    column = f"peak_decel{ego}"
    if column not in mine.columns or mine[column].isna().all():
        raise ParameterError(f"runs of {system!r} have no column {column!r}: evaluate with "
                             "vfs.gym.evaluate.evaluate_policy (its systems record comfort)")
    crashed = base["collided"].astype("boolean").fillna(False).to_numpy(bool)
    now = mine["collided"].astype("boolean").fillna(True).to_numpy(bool)
    peak = mine[column].fillna(0.0).to_numpy(float)
    jerk = mine[f"peak_jerk{ego}"].fillna(0.0).to_numpy(float)
    harsh = mine[f"harsh_time{ego}"].fillna(0.0).to_numpy(float)
    brake_time = mine[f"brake_time{ego}"].fillna(0.0).to_numpy(float)
    lost = mine[f"speed_taken{ego}"].fillna(0.0).to_numpy(float)
    start = mine[f"start_speed{ego}"].to_numpy(float)
    lost_share = np.where(start > MOVING_SPEED, np.minimum(1.0, lost / np.where(
        start > MOVING_SPEED, start, 1.0)), 0.0)
    brakes = peak >= BRAKE_THRESHOLD
    n_crash, n_free = int(crashed.sum()), int((~crashed).sum())
    avoided = int((crashed & ~now).sum())
    new = int((~crashed & now).sum())
    free = ~crashed

    def mean(values: np.ndarray, where: np.ndarray) -> float:
        return float(values[where].mean()) if where.any() else 0.0

    out = {
        "crashes": float(n_crash), "avoided": float(avoided), "new_crashes": float(new),
        "net_avoided_share": (avoided - new) / n_crash if n_crash else 0.0,
        "no_crash_cases": float(n_free), "unnecessary": float((brakes & free).sum()),
        "unnecessary_share": mean(brakes.astype(float), free),
        "unnecessary_speed_loss_kmh": mean(lost, free) * KMH_PER_MS,
        "unnecessary_speed_share": mean(lost_share, free),
        "unnecessary_brake_time": mean(brake_time, free),
        "brakes_share": float(brakes.mean()) if brakes.size else 0.0,
        "peak_decel": mean(peak, brakes), "peak_jerk": mean(jerk, brakes),
        "peak_decel_max": float(peak.max()) if peak.size else 0.0,
        "harsh_time": float(harsh.mean()) if harsh.size else 0.0,
    }
    out["score"] = benchmark_score(out["net_avoided_share"], out["unnecessary_speed_share"],
                                   out["harsh_time"])
    return out


def score_formula() -> str:
    """The score's formula with its weights and thresholds, as reports print it."""
    return (f"score = (avoided - new crashes) / baseline crashes - {UNNECESSARY_WEIGHT:g} x "
            "mean share of the ego's speed taken by the system's brake in the no-crash cases "
            f"- {HARSH_WEIGHT:g}/s x mean time per case above {HARSH_DECELERATION:g} m/s^2")


__all__ = ["PASSING_CASES", "PASSING_ID_OFFSET", "PASSING_PRESET", "PASSING_SEED",
           "with_passes", "BRAKE_THRESHOLD", "COMFORT_KEYS", "HARSH_DECELERATION", "HARSH_WEIGHT",
           "MOVING_SPEED", "UNNECESSARY_WEIGHT", "ComfortRecorder", "ComfortSystem",
           "SegmentableComfortRecorder", "benchmark_measures", "benchmark_score",
           "score_formula"]
