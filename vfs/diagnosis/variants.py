"""Many model variants in one vectorised simulation.

A model variant is a tuple of effects.  To simulate ``g`` variants of ``n``
cases, the cases are stacked ``g`` times and one effect
(:class:`StackedVariants`) dispatches every hook to the variant a row belongs
to (row // n): a grid of parameter values then costs one
:func:`vfs.simulation.simulate_cases` call instead of ``g``.
:class:`VariantSimulator` does this for a calibration (:mod:`vfs.diagnosis.calibrate`),
with a cache by parameter vector; it hands out outcome arrays, never tables.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from vfs.effects import STAGES, Effect, VelocityChange, call_post_impact, hooks
from vfs.errors import ParameterError
from vfs.physics.post_impact import POST_IMPACT_FIELDS, PostImpactInputs
from vfs.physics.precrash import UNUSED_VEHICLE_FIELDS, PrecrashParams, PrecrashResult
from vfs.physics.runout import RunoutMemo
from vfs.physics.vehicle import VehicleArrays
from vfs.simulation import (
    CaseBatch,
    CaseResults,
    SimulationParams,
    open_cases,
    precrash_stage,
    simulate_cases,
)

#: A model variant: the effects added to the base model, in order.
Model = tuple[Effect, ...]


def model_key(model: Model) -> tuple[Any, ...]:
    """Hashable key of a model variant (effect names and parameters to 1e-10)."""
    return tuple((e.name, tuple(round(float(v), 10) for v in e.vector())) for e in model)


def merge_rows(old: Any, new: Any, sel: np.ndarray) -> Any:
    """Rows ``sel`` (bool, one per case) from ``new``, the others from ``old``.

    Works on arrays of n or 2 n rows (stacked vehicles) and on NamedTuples of
    them (CaseBatch, ImpactConfig, VelocityChange ...).

    Raises
    ------
    ParameterError
        For values of another shape or type.
    """
    if old is new:
        return old
    if isinstance(old, tuple) and hasattr(old, "_fields"):
        return type(old)(*(merge_rows(a, b, sel) for a, b in zip(old, new, strict=True)))
    if isinstance(old, PostImpactInputs) and isinstance(new, PostImpactInputs):
        return PostImpactInputs(*(merge_rows(getattr(old, f), getattr(new, f), sel)
                                  for f in POST_IMPACT_FIELDS))
    if isinstance(old, np.ndarray):
        m = sel.shape[0]
        if old.shape[:1] == (m,):
            s = sel
        elif old.shape[:1] == (2 * m,):
            s = np.concatenate([sel, sel])
        else:
            raise ParameterError(f"cannot merge an effect's output of shape {old.shape}")
        return np.where(s.reshape(s.shape + (1,) * (old.ndim - 1)), new, old)
    if old is None and new is None:
        return None
    raise ParameterError(f"cannot merge an effect's output of type {type(old).__name__}")


class StackedVariants(Effect):
    """Runs several model variants on a batch stacked as many times.

    Row ``r`` belongs to variant ``r // n``; each hook applies that
    variant's hooks (in its order) to all rows and keeps the variant's rows.
    Hooks must be row-wise (the output of a row depends only on that row), as
    every vectorised effect is.  The effect runs only the stages some variant
    uses (:meth:`active_stages`), so the simulation takes the same paths as
    with the variants' own effects.

    Parameters
    ----------
    models : sequence of Model
        The variants.
    n : int
        Cases per variant.
    penetration_time : float
        Penetration time [s] of rows whose variant gives none (NaN).
    """

    name = "stacked_variants"
    summary = "internal: several model variants in one simulation"
    __slots__ = ("_models", "_n", "_stages", "_t_pen")
    _models: tuple[tuple[Effect, ...], ...]
    _n: int
    _stages: tuple[str, ...]
    _t_pen: float

    def __init__(self, models: Sequence[Model], n: int,
                 penetration_time: float = PrecrashParams.penetration_time) -> None:
        super().__init__()
        object.__setattr__(self, "_models", tuple(tuple(m) for m in models))
        object.__setattr__(self, "_n", int(n))
        object.__setattr__(self, "_t_pen", float(penetration_time))
        object.__setattr__(self, "_stages", tuple(
            s for s in STAGES if any(hooks(m, s) for m in self._models)))

    def active_stages(self) -> tuple[str, ...]:
        """The stages some variant has a hook for."""
        return self._stages

    def _active(self, stage: str) -> list[tuple[int, list[Any]]]:
        return [(g, h) for g, model in enumerate(self._models) if (h := hooks(model, stage))]

    def _variant(self, rows: np.ndarray) -> np.ndarray:
        return np.asarray(rows) // self._n

    def vehicles(self, batch: CaseBatch) -> CaseBatch:
        """Stage ``vehicles`` of each variant on its rows."""
        rep = self._variant(np.arange(batch.size))
        out = batch
        for g, hs in self._active("vehicles"):
            b = batch
            for h in hs:
                b = h(b)
            out = merge_rows(out, b, rep == g)
        return out

    def penetration(self, ctx: Any, t: np.ndarray) -> np.ndarray:
        """Stage ``penetration`` of each variant; the default time where a variant has none."""
        rep = self._variant(ctx.rows)
        out = np.where(np.isnan(t), self._t_pen, t)
        for g, hs in self._active("penetration"):
            tt = np.array(t, float, copy=True)
            for h in hs:
                tt = np.asarray(h(ctx, tt), float)
            sel = rep == g
            out[sel] = tt[sel]
        return out

    def _config(self, stage: str, ctx: Any, config: Any) -> Any:
        rep = self._variant(ctx.rows)
        out = config
        for g, hs in self._active(stage):
            c = config
            for h in hs:
                c = h(ctx, c)
            out = merge_rows(out, c, rep == g)
        return out

    def impact_configuration(self, ctx: Any, config: Any) -> Any:
        """Stage ``impact_configuration`` of each variant on its rows."""
        return self._config("impact_configuration", ctx, config)

    def impact_parameters(self, ctx: Any, config: Any) -> Any:
        """Stage ``impact_parameters`` of each variant on its rows."""
        return self._config("impact_parameters", ctx, config)

    def contact_impulse(self, ctx: Any, config: Any, result: Any) -> VelocityChange:
        """Stage ``contact_impulse``: the sum of each variant's changes on its rows."""
        rep = self._variant(ctx.rows)
        out = VelocityChange.zeros(config.size)
        for g, hs in self._active("contact_impulse"):
            ch = VelocityChange.zeros(config.size)
            for h in hs:
                ch = ch + h(ctx, config, result)
            out = merge_rows(out, ch, rep == g)
        return out

    def _pair(self, stage: str, ctx: Any, config: Any, result: Any, v1: np.ndarray,
              v2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rep = self._variant(ctx.rows)
        o1, o2 = np.array(v1, float, copy=True), np.array(v2, float, copy=True)
        for g, hs in self._active(stage):
            a, b = v1, v2
            for h in hs:
                a, b = h(ctx, config, result, a, b)
            sel = rep == g
            o1[sel], o2[sel] = np.asarray(a)[sel], np.asarray(b)[sel]
        return o1, o2

    def energy_split(self, ctx: Any, config: Any, result: Any, e1: np.ndarray,
                     e2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stage ``energy_split`` of each variant on its rows [J]."""
        return self._pair("energy_split", ctx, config, result, e1, e2)

    def post_impact(self, ctx: Any, config: Any, result: Any,
                    inputs: PostImpactInputs) -> PostImpactInputs:
        """Stage ``post_impact`` of each variant on its rows (run-out inputs: wheel brake
        factors, steer angles).
        """
        rep = self._variant(ctx.rows)
        out = inputs
        for g, hs in self._active("post_impact"):
            a = inputs
            for h in hs:
                a = call_post_impact(h, ctx, config, result, a)
            out = merge_rows(out, a, rep == g)
        return out


def stacked_effect(models: Sequence[Model], n: int,
                   penetration_time: float = PrecrashParams.penetration_time
                   ) -> Effect | None:
    """One effect running ``len(models)`` variants on a batch stacked as many times
    (:class:`StackedVariants`); None if no variant has effects.

    Parameters
    ----------
    models : sequence of Model
    n : int
        Cases per variant.
    penetration_time : float
        Penetration time [s] where a variant gives none (default: that of
        :class:`vfs.physics.precrash.PrecrashParams`).
    """
    eff = StackedVariants(models, n, penetration_time)
    return eff if eff.active_stages() else None


def leaves_precrash(model: Model) -> bool:
    """True if the effects of ``model`` leave the pre-crash phase as it is: none has a
    ``vehicles`` hook (vehicle data) or a ``penetration`` hook (penetration time),
    the only stages that act before the impact configuration.
    """
    return not hooks(model, "vehicles") and not hooks(model, "penetration")


class VariantData(Protocol):
    """What :class:`VariantSimulator` needs of the compared cases."""

    @property
    def n(self) -> int:
        """Number of cases."""

    @property
    def batch(self) -> CaseBatch:
        """Their simulation batch."""

    def residuals(self, results: Any) -> np.ndarray:
        """Residuals (rows, n_columns) of simulated results of the cases."""


class VariantSimulator:
    """Simulate model variants of the cases of a calibration, with a cache.

    Parameters
    ----------
    data : VariantData
        The cases (:class:`vfs.diagnosis.calibrate.CalibrationData`).
    params : SimulationParams, optional
        Base parameters (their effects are prepended to every variant).
    max_cases : int
        Cases per :func:`simulate_cases` call (variants x n); larger calls
        amortise the Python overhead better but need more memory.

    Attributes
    ----------
    n_variants : int
        Variants simulated so far (cache misses).
    n_case_runs : int
        Case simulations so far (variants x cases).
    seconds : float
        Time spent simulating.
    """

    def __init__(self, data: Any, params: SimulationParams | None = None,
                 max_cases: int = 6000) -> None:
        self.data = data
        self.params = params or SimulationParams()
        self.max_cases = max(int(max_cases), data.n)
        self._cache: dict[tuple[Any, ...], np.ndarray] = {}
        self._precrash: PrecrashResult | None = None
        self._opened: CaseBatch | None = None
        #: rest results of every vehicle run out so far (variants repeat most of them)
        self.runout_memo = RunoutMemo()
        self.n_variants = 0
        self.n_case_runs = 0
        self.n_calls = 0
        self.seconds = 0.0

    def residuals(self, models: Sequence[Model]) -> list[np.ndarray]:
        """Residual arrays (n, n_columns) of each model (cached)."""
        keys = [model_key(m) for m in models]
        todo: dict[tuple[Any, ...], Model] = {}
        for k, m in zip(keys, models, strict=True):
            if k not in self._cache and k not in todo:
                todo[k] = tuple(m)
        items = list(todo.items())
        for chunk in self._calls(items):
            for (k, _), r in zip(chunk, self._simulate([m for _, m in chunk]), strict=True):
                self._cache[k] = r
        return [self._cache[k] for k in keys]

    def _calls(self, items: Sequence[tuple[Any, Model]]) -> list[list[tuple[Any, Model]]]:
        """``(key, model)`` items in stacked calls of at most ``max_cases`` cases: those whose model
        keeps the base model's pre-crash phase (:meth:`keeps_precrash`), those that continue
        it (:meth:`continues_precrash`) and the others apart, so that their calls share the
        base model's pre-crash run.
        """
        per_call = max(1, self.max_cases // self.data.n)
        out: list[list[tuple[Any, Model]]] = []
        kinds = [0 if self.keeps_precrash(m) else 1 if self.continues_precrash(m) else 2
                 for _, m in items]
        for kind in (0, 1, 2):
            group = [it for it, k in zip(items, kinds, strict=True) if k == kind]
            out += [group[i:i + per_call] for i in range(0, len(group), per_call)]
        return out

    def uncached_residuals(self, models: Sequence[Model]) -> list[np.ndarray]:
        """Residual arrays (n, n_columns) of each model, simulated without the cache
        (for models whose parameters do not describe them, e.g. values per case);
        stacked calls of at most ``max_cases`` cases, counted in the statistics.
        """
        got: dict[int, np.ndarray] = {}
        for chunk in self._calls(list(enumerate(models))):
            got.update(zip((i for i, _ in chunk), self._simulate([m for _, m in chunk]),
                           strict=True))
        return [got[i] for i in range(len(models))]

    def simulate(self, models: Sequence[Model]) -> CaseResults:
        """Results of the variants, stacked (variant-major: rows g n .. (g + 1) n - 1)."""
        data = self.data
        n, g = data.n, len(models)
        base = tuple(self.params.effects)
        full = [base + tuple(m) for m in models]
        batch = data.batch if g == 1 else data.batch.take(np.tile(np.arange(n), g))
        if g == 1:
            effects: tuple[Effect, ...] = full[0]
        else:
            st = stacked_effect(full, n, self.params.precrash.penetration_time)
            effects = () if st is None else (st,)
        # the outcomes compared do not include the secondary-collision flag (not checked)
        # nor the run-out paths (not recorded)
        params = SimulationParams(precrash=self.params.precrash, impact=self.params.impact,
                                  runout=self.params.runout, effects=effects,
                                  secondary_collisions=False, runout_paths=False)
        pre = None
        if all(self.keeps_precrash(m) for m in models):  # one pre-crash run serves them all
            pre = self.base_precrash()
            if g > 1:
                pre = pre.take(np.tile(np.arange(n), g))
        elif all(self.continues_precrash(m) for m in models):
            pre = self._continued_precrash(batch, params, g)
        return simulate_cases(batch, params=params, precrash=pre, runout_memo=self.runout_memo)

    def continues_precrash(self, model: Model) -> bool:
        """True if ``model`` changes the pre-crash phase only after first contact: it has
        a penetration hook, and its ``vehicles`` hooks change no vehicle data the pre-crash
        phase reads (:meth:`keeps_precrash`).  The base model's run then serves it up to
        a few steps before each contact (:meth:`_continued_precrash`).
        """
        return bool(hooks(model, "penetration")) and self._same_precrash_vehicles(model)

    def _continued_precrash(self, batch: CaseBatch, params: SimulationParams,
                            g: int) -> PrecrashResult:
        """The pre-crash results of ``g`` stacked variants that change only the penetration
        time: the base run's, with each colliding case run again from two steps before
        the step of its contact in the base run (a replay follows the record until
        contact, so the contact is the same and only the impact moves; a case without
        contact keeps the base result).  Bit for bit what the whole run gives (tested),
        for the steps around contact and penetration instead of the whole record.
        """
        n = self.data.n
        base = self.base_precrash()
        full = base.take(np.tile(np.arange(n), g))
        hit = np.flatnonzero(base.collided)
        if hit.size == 0:
            return full
        dt = self.params.precrash.dt
        first = np.maximum(np.floor(base.contact_time[hit] / dt).astype(np.int64) - 2, 0)
        rows = (np.arange(g)[:, None] * n + hit[None, :]).reshape(-1)
        part = precrash_stage(open_cases(batch, params), params, case_of=rows,
                              first_step=np.tile(first, g))
        return full.put(rows, part)

    def keeps_precrash(self, model: Model) -> bool:
        """True if the base model's pre-crash run serves ``model``: its effects leave the
        pre-crash phase as it is (:func:`leaves_precrash`), or none has a penetration hook
        and their ``vehicles`` hooks change only vehicle data the pre-crash phase never
        reads (:data:`vfs.physics.precrash.UNUSED_VEHICLE_FIELDS`, e.g. the yaw inertia).
        """
        if leaves_precrash(model):
            return True
        if hooks(model, "penetration"):
            return False
        return self._same_precrash_vehicles(model)

    def _same_precrash_vehicles(self, model: Model) -> bool:
        """The ``vehicles`` hooks of ``model`` leave every vehicle field the pre-crash
        phase reads as in the base model.
        """
        if not hooks(model, "vehicles"):
            return True
        if self._opened is None:
            self._opened = open_cases(self.data.batch, self.params).batch
        base = self._opened
        own = open_cases(self.data.batch, dataclasses.replace(
            self.params, effects=tuple(self.params.effects) + tuple(model))).batch
        return all(
            np.array_equal(getattr(getattr(own, v), f), getattr(getattr(base, v), f))
            for v in ("vehicle1", "vehicle2") for f in VehicleArrays._fields
            if f not in UNUSED_VEHICLE_FIELDS)

    def base_precrash(self) -> PrecrashResult:
        """The pre-crash run of the cases under the base parameters (run once, kept):
        shared by every variant whose effects leave the pre-crash phase as it is
        (:func:`leaves_precrash`).
        """
        if self._precrash is None:
            self._precrash = precrash_stage(open_cases(self.data.batch, self.params), self.params)
        return self._precrash

    def _simulate(self, models: Sequence[Model]) -> list[np.ndarray]:
        t0 = time.perf_counter()
        n, g = self.data.n, len(models)
        stacked = self.data.residuals(self.simulate(models))  # (g n, n_columns)
        out = [stacked[i * n:(i + 1) * n] for i in range(g)]
        self.n_variants += g
        self.n_case_runs += g * n
        self.n_calls += 1
        self.seconds += time.perf_counter() - t0
        return out

    def stats(self) -> dict[str, float]:
        """Simulation counters: variants, case runs, calls, seconds."""
        return {"variants": self.n_variants, "case_runs": self.n_case_runs,
                "calls": self.n_calls, "seconds": round(self.seconds, 3)}


__all__ = [
    "Model",
    "StackedVariants",
    "VariantSimulator",
    "leaves_precrash",
    "merge_rows",
    "model_key",
    "stacked_effect",
]
