"""Calibrate effect parameters against the reconstructions, with cross-validation.

The building blocks of ``vfs diagnose`` and ``vfs calibrate``:

* **Outputs** (:data:`vfs.outcomes.OUTPUT_GROUPS`, values derived by
  :mod:`vfs.outcomes`): the reconstruction outcomes compared with the model
  (delta-v, EES, energy loss, post-impact speed, change of velocity angle,
  PDOF, rest position and yaw, run-out distance, impact type), their
  residuals ``model - reconstruction`` and one scale per output (the RMS of
  the recorded ``<column>_sd`` where the database has them, else the
  standard deviation of the recorded values) so that outputs of different
  units are never mixed: every error is an RMSE of *standardised* residuals.
* **Many model variants in one simulation**
  (:class:`vfs.diagnosis.variants.VariantSimulator`): the cases are stacked
  once per variant and one effect dispatches every hook to the variant a row
  belongs to, so that a grid of parameter values costs one vectorised
  :func:`vfs.simulation.simulate_cases` call; residuals are cached by
  parameter vector.  Simulation results go to residual arrays directly
  (:func:`vfs.outcomes.from_results`), never through a table.
* **Fitting** (:func:`fit_folds`): bounded coordinate search per parameter: a
  coarse grid over the bounds evaluated on *all* cases once (folds only
  change which cases enter the objective), zoom rounds halving the spacing
  around each fold's optimum, and a parabolic polish; all folds are fitted
  in the same simulation calls.
* **Cross-validation** (:func:`cross_validate`): k-fold by case (seeded), each
  fold's parameters fitted on the other folds, the held-out residuals scored.
* **Calibration** (:func:`calibrate`) on all cases; the fitted effects go to
  a model configuration file (:mod:`vfs.analysis.model_config`) that
  ``vfs compare --model`` reads.

All quantities are SI inside (m/s, rad, m, J); reports convert with the
display factors of :mod:`vfs.outcomes`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Generator, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vfs.analysis.model_config import MODEL_CONFIG_FORMAT, read_model_config, write_model_config
from vfs.diagnosis.choices import Fixed, Parameters
from vfs.diagnosis.diagnose_spec import DiagnoseSpec
from vfs.diagnosis.variants import Model, VariantSimulator, stacked_effect
from vfs.effects import Effect, get_effect
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.outcomes import OUTPUT_GROUPS, OutputGroup, difference, from_reconstruction, from_results
from vfs.settings import declared, member
from vfs.simulation import CaseBatch


def parse_outputs(spec: str | Iterable[str] | None) -> tuple[str, ...] | None:
    """Output names (:data:`vfs.outcomes.OUTPUT_GROUPS`) from ``"delta_v,ees"`` or a
    list; None = all available.
    """
    if spec is None:
        return None
    names = [s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec)]
    names = [s for s in names if s and s != "all"]
    if not names:
        return None
    unknown = [s for s in names if s not in OUTPUT_GROUPS]
    if unknown:
        raise ParameterError(f"unknown output(s) {unknown}; known: {', '.join(OUTPUT_GROUPS)}")
    return tuple(dict.fromkeys(names))


def _value_columns(values: Mapping[str, np.ndarray], groups: Iterable[OutputGroup]
                   ) -> np.ndarray:
    """The single values of ``groups`` (columns, vehicle by vehicle) from outcome arrays."""
    cols = []
    for g in groups:
        members = g.members
        for i in range(len(members[0].vehicles)):
            for o in members:
                v = values.get(o.name)
                cols.append(v[:, i] if v is not None else None)
    n = next((c.shape[0] for c in cols if c is not None), 0)
    return np.stack([np.full(n, np.nan) if c is None else c for c in cols], axis=1)


# ----------------------------------------------------------------------------
# Data
# ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CalibrationData:
    """The colliding cases of a database with their reconstruction, ready to compare.

    Build with :meth:`from_database`.  Ground-truth files of synthetic
    databases are never read.

    Attributes
    ----------
    db : Database
    case_ids : ndarray (n,)
        Cases with a reconstruction (database order).
    batch : CaseBatch
        Their simulation batch (restitution and contact friction of the
        reconstruction).
    reconstruction : pandas.DataFrame
        Reconstruction rows aligned with ``case_ids``.
    groups : tuple of OutputGroup
        Compared outputs.
    columns : tuple of str
        Residual columns of all groups, in group order.
    column_group : ndarray of int
        Group index of each column.
    observed : ndarray (n, n_columns)
        Recorded values.
    scales : ndarray (n_groups,)
        Scale of each group [its unit].
    scale_source : tuple of str
        ``"sd"`` or ``"spread"`` per group.
    """

    db: Any
    case_ids: np.ndarray
    batch: CaseBatch
    reconstruction: pd.DataFrame
    groups: tuple[OutputGroup, ...]
    columns: tuple[str, ...]
    column_group: np.ndarray
    observed: np.ndarray
    scales: np.ndarray
    scale_source: tuple[str, ...]

    @property
    def n(self) -> int:
        """Number of cases."""
        return int(self.case_ids.shape[0])

    @property
    def group_names(self) -> tuple[str, ...]:
        """Names of the compared outputs."""
        return tuple(g.name for g in self.groups)

    @classmethod
    def from_database(cls, db: Any, outputs: Iterable[str] | str | None = None,
                      case_ids: Iterable[Any] | None = None) -> CalibrationData:
        """Prepare the cases of a database that have a reconstruction.

        Parameters
        ----------
        db : Database
        outputs : list of str or "a,b", optional
            Output names of :data:`OUTPUT_GROUPS` (default: every output the
            reconstruction table has values for).
        case_ids : iterable, optional
            Restrict to these cases.

        Raises
        ------
        DataError
            If the database has no reconstruction rows or a requested output
            has no recorded values.
        """
        rec = db.reconstruction
        if rec is None or rec.empty:
            raise DataError(DataProblem("reconstruction", "", None, None,
                                        "the database has no reconstruction rows to compare"))
        rec = rec.drop_duplicates("case_id")
        ids = np.asarray([c for c in db.case_ids if c in set(rec["case_id"])])
        if case_ids is not None:
            wanted = set(case_ids)
            ids = np.asarray([c for c in ids if c in wanted])
        if ids.size == 0:
            raise DataError(DataProblem("reconstruction", "case_id", None, None,
                                        "no case with a reconstruction selected"))
        rec = rec.set_index("case_id").loc[ids].reset_index()
        values = from_reconstruction(rec)
        requested = parse_outputs(outputs)
        names = requested or tuple(OUTPUT_GROUPS)
        groups: list[OutputGroup] = []
        for name in names:
            g = OUTPUT_GROUPS[name]
            have = np.isfinite(_value_columns(values, [g])).any(axis=1)
            if have.sum() >= 2:
                groups.append(g)
            elif requested:
                raise DataError(DataProblem("reconstruction", g.value_names[0], None, None,
                                            f"output {name!r} has no recorded values"))
        if not groups:
            raise DataError(DataProblem("reconstruction", "", None, None,
                                        "no output with recorded values"))
        columns = tuple(c for g in groups for c in g.value_names)
        column_group = np.array([k for k, g in enumerate(groups) for _ in g.value_names])
        observed = _value_columns(values, groups)
        scales, sources = [], []
        for k, g in enumerate(groups):
            scale, src = _group_scale(g, rec, observed[:, column_group == k])
            scales.append(scale)
            sources.append(src)
        batch = CaseBatch.from_database(db, ids)
        return cls(db, ids, batch, rec, tuple(groups), columns, column_group, observed,
                   np.asarray(scales, float), tuple(sources))

    # ------------------------------------------------------------ residuals
    def residuals(self, results: Any) -> np.ndarray:
        """Residuals model - reconstruction (m, n_columns) [SI] of simulated cases.

        Parameters
        ----------
        results : CaseResults, DataFrame or mapping of arrays
            Results of the cases in :attr:`case_ids` order, or of ``k`` stacked
            copies of them (m = k n rows): anything
            :func:`vfs.outcomes.from_results` reads.

        Returns
        -------
        ndarray (m, n_columns)
            Angles wrapped to (-pi, pi] where the outcome wraps.
        """
        names = {o.name for g in self.groups for o in g.members}
        model = _value_columns(from_results(results, names), self.groups)
        observed = self.observed[np.arange(model.shape[0]) % self.n]
        out = np.empty_like(model)
        for j in range(model.shape[1]):
            member = self.groups[self.column_group[j]].members[0]
            out[:, j] = difference(member, model[:, j], observed[:, j])
        return out

    def case_errors(self, residuals: np.ndarray) -> np.ndarray:
        """Per-case mean squared standardised residual of each output (n, n_groups);
        NaN where an output has no value for a case.
        """
        z2 = (residuals / self.scales[self.column_group]) ** 2
        out = np.full((residuals.shape[0], len(self.groups)), np.nan)
        for k in range(len(self.groups)):
            block = z2[:, self.column_group == k]
            ok = np.isfinite(block)
            cnt = ok.sum(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                out[:, k] = np.where(cnt > 0, np.where(ok, block, 0.0).sum(axis=1) / cnt,
                                     np.nan)
        return out

    def fingerprint(self) -> str:
        """Short hash of the compared cases, outputs and scales (ledger comparability)."""
        import hashlib

        h = hashlib.sha256()
        h.update(np.asarray(self.case_ids).astype(str).tobytes())
        h.update(np.nan_to_num(self.observed).round(9).tobytes())
        h.update(",".join(self.columns).encode())
        h.update(self.scales.round(12).tobytes())
        return h.hexdigest()[:16]


def _group_scale(group: OutputGroup, rec: pd.DataFrame, observed: np.ndarray
                 ) -> tuple[float, str]:
    """RMS of the recorded standard deviations, else the spread of the recorded values."""
    if group.sd_columns and all(c in rec.columns for c in group.sd_columns):  # SI like rec
        sd = np.concatenate([pd.to_numeric(rec[c], errors="coerce").to_numpy(float)
                             for c in group.sd_columns])
        sd = sd[np.isfinite(sd)]
        if sd.size and np.all(sd >= 0) and np.sqrt(np.mean(sd ** 2)) > 0:
            return float(np.sqrt(np.mean(sd ** 2))), "sd"
    v = observed[np.isfinite(observed)]
    spread = float(np.std(v)) if v.size > 1 else 0.0
    if not spread > 0:
        return 1.0, "unit"
    return spread, "spread"


def group_mse(errors: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
    """Mean of the per-case errors of each output over ``rows`` (all by default)."""
    e = errors if rows is None else errors[rows]
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(e)
        cnt = ok.sum(axis=0)
        return np.where(cnt > 0, np.where(ok, e, 0.0).sum(axis=0) / np.maximum(cnt, 1), np.nan)


def overall_mse(errors: np.ndarray, rows: np.ndarray | None = None,
                weights: np.ndarray | None = None) -> float:
    """Mean over outputs (optionally weighted) of the per-output mean squared error."""
    g = group_mse(errors, rows)
    ok = np.isfinite(g)
    w = np.ones_like(g) if weights is None else np.asarray(weights, float)
    w = np.where(ok, w, 0.0)
    if w.sum() <= 0:
        return float("nan")
    return float(np.sum(np.where(ok, g, 0.0) * w) / w.sum())


# ----------------------------------------------------------------------------
# Parameter spaces and fitting
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class FitSpace:
    """The parameters to fit: effects (their start values) and which parameters are free.

    Attributes
    ----------
    effects : tuple of Effect
        Start instances (their non-free parameters stay fixed).
    free : tuple of (int, int)
        (effect index, parameter index) of each free parameter, in fit order.
    """

    effects: tuple[Effect, ...]
    free: tuple[tuple[int, int], ...]

    @classmethod
    def of(cls, effects: Iterable[Effect | type[Effect] | str],
           parameters: str = Parameters.PRIMARY, fixed: str = Fixed.DEFAULT) -> FitSpace:
        """Space of effects (instances, classes or names); ``parameters`` "primary"
        (the first parameter of each effect) or "all".

        ``fixed`` sets the parameters that are not fitted of the effects given
        as classes or names: "default" (their nominal strengths) or "neutral"
        (their neutral values where they have one: that part of the effect
        switched off, the diagnosis' choice, so that a candidate is not
        penalised for a nominal strength the data do not have).
        """
        parameters = member(Parameters, parameters, owner="FitSpace", name="parameters")
        fixed = member(Fixed, fixed, owner="FitSpace", name="fixed")
        inst: list[Effect] = []
        for e in effects:
            if isinstance(e, str):
                e = get_effect(e)
            if isinstance(e, type) and fixed is Fixed.NEUTRAL and parameters is Parameters.PRIMARY:
                off = {p.name: p.neutral for p in e.parameters[1:] if p.neutral is not None}
                inst.append(e(**off))
                continue
            inst.append(e() if isinstance(e, type) else e)
        free = []
        for i, e in enumerate(inst):
            n_par = len(type(e).parameters)
            free += [(i, j) for j in range(n_par if parameters is Parameters.ALL
                                           else min(n_par, 1))]
        return cls(tuple(inst), tuple(free))

    @classmethod
    def alternatives(cls, effects: Iterable[Effect | type[Effect] | str],
                     parameters: str = Parameters.PRIMARY) -> tuple[FitSpace, ...]:
        """The spaces a diagnosis tries for ``effects``.

        With ``parameters="primary"``: the parameters that are not fitted at
        their neutral values and, where that differs, at their nominal
        strengths (two alternatives; :func:`cross_validate_many` keeps, per
        fold, the one that fits the training cases better).  With "all": one
        space.
        """
        effects = list(effects)
        if member(Parameters, parameters, owner="FitSpace", name="parameters") \
                is not Parameters.PRIMARY:
            return (cls.of(effects, parameters),)
        off = cls.of(effects, parameters, Fixed.NEUTRAL)
        nominal = cls.of(effects, parameters, Fixed.DEFAULT)
        same = all(np.array_equal(a.vector(), b.vector())
                   for a, b in zip(off.effects, nominal.effects, strict=True))
        return (off,) if same else (off, nominal)

    def start(self) -> np.ndarray:
        """Start values of the free parameters."""
        return np.array([self.effects[i].vector()[j] for i, j in self.free], float)

    def bounds(self) -> list[tuple[float, float]]:
        """Bounds of the free parameters."""
        return [type(self.effects[i]).bounds()[j] for i, j in self.free]

    def specials(self, k: int) -> list[float]:
        """Default and neutral value of free parameter k (grid points worth having)."""
        i, j = self.free[k]
        p = type(self.effects[i]).parameters[j]
        return [v for v in (p.default, p.neutral) if v is not None]

    def names(self) -> list[str]:
        """``effect.parameter`` of the free parameters."""
        return [f"{self.effects[i].name}.{type(self.effects[i]).parameters[j].name}"
                for i, j in self.free]

    def model(self, x: Sequence[float] | np.ndarray) -> Model:
        """The effects with the free parameters set to ``x`` (clipped to the bounds);
        no effect at all (the default model) if ``x`` holds NaN ("switched off").
        """
        if np.isnan(np.asarray(x, float)).any():
            return ()
        vecs = [e.vector() for e in self.effects]
        for (i, j), v in zip(self.free, x, strict=True):
            vecs[i][j] = v
        return tuple(type(e).from_vector(v) for e, v in zip(self.effects, vecs, strict=True))


@dataclass
class FitResult:
    """Fitted parameters of each fold.

    Attributes
    ----------
    x : ndarray (n_folds, n_free)
        Fitted free parameters per fold (training rows of that fold).
    train_mse : ndarray (n_folds,)
        Objective (overall mean squared standardised residual) on the
        training rows at ``x``.
    """

    x: np.ndarray
    train_mse: np.ndarray
    variants: int = 0


def _snap(v: float, lo: float, hi: float) -> float:
    span = hi - lo
    return float(np.clip(round(float(v), 12) if span == 0 else
                         lo + round((float(v) - lo) / span, 9) * span, lo, hi))


FitGenerator = Generator[list[Model], list[np.ndarray], FitResult]


def fit_steps(data: CalibrationData, space: FitSpace, train: Sequence[np.ndarray],
              grid_points: int = DiagnoseSpec.grid_points,
              zoom_rounds: int = DiagnoseSpec.zoom_rounds, passes: int | None = None,
              polish: bool = True, weights: np.ndarray | None = None) -> FitGenerator:
    """The search of :func:`fit_folds` as a generator.

    It yields the list of models it needs simulated next and receives their
    residual arrays (``gen.send(residuals)``); its return value
    (``StopIteration.value``) is the :class:`FitResult`.  :func:`run_fits`
    drives several of them so that their requests share simulation calls.
    """
    low = declared(DiagnoseSpec)["grid_points"].lo
    if grid_points < low:
        raise ParameterError(f"grid_points must be >= {low:g}")
    n_free = len(space.free)
    folds = len(train)
    x = np.tile(space.start(), (folds, 1))
    err_cache: dict[tuple[float, ...], np.ndarray] = {}
    count = 0

    def objective(err: np.ndarray, f: int) -> float:
        v = overall_mse(err, train[f], weights)
        return v if math.isfinite(v) else math.inf

    if n_free == 0:
        res0 = yield [space.model([])]
        e = data.case_errors(res0[0])
        return FitResult(x, np.array([objective(e, f) for f in range(folds)]), 1)
    passes = (1 if n_free == 1 else 2) if passes is None else passes
    bounds = space.bounds()
    best = np.full(folds, math.inf)
    for _ in range(passes):
        for k in range(n_free):
            lo, hi = bounds[k]
            if hi <= lo:
                continue
            h = (hi - lo) / (grid_points - 1)
            values = [_snap(v, lo, hi) for v in np.linspace(lo, hi, grid_points)]
            values += [_snap(v, lo, hi) for v in space.specials(k)]
            tried: list[dict[float, float]] = [{} for _ in range(folds)]
            for step in range(zoom_rounds + 2):
                if step == 0:  # coarse grid
                    cands = [sorted(set(values + [_snap(x[f, k], lo, hi)]))
                             for f in range(folds)]
                elif step <= zoom_rounds:  # zoom: half the spacing around each optimum
                    h /= 2.0
                    cands = []
                    for f in range(folds):
                        b = min(tried[f], key=tried[f].__getitem__)
                        cands.append([_snap(b - h, lo, hi), _snap(b + h, lo, hi)])
                elif polish:  # parabola through the best point and its neighbours
                    cands = [_parabola_step(tried[f], lo, hi) for f in range(folds)]
                else:
                    break
                vecs, owners = [], []
                for f in range(folds):
                    for v in cands[f]:
                        if v in tried[f]:
                            continue
                        xv = x[f].copy()
                        xv[k] = v
                        vecs.append(xv)
                        owners.append((f, v))
                keys = [tuple(np.round(v, 10)) for v in vecs]
                missing = {kk: v for kk, v in zip(keys, vecs, strict=True)
                           if kk not in err_cache}
                if missing:
                    count += len(missing)
                    res = yield [space.model(v) for v in missing.values()]
                    for kk, r in zip(missing, res, strict=True):
                        err_cache[kk] = data.case_errors(r)
                for (f, v), kk in zip(owners, keys, strict=True):
                    tried[f][v] = objective(err_cache[kk], f)
            for f in range(folds):
                b = min(tried[f], key=tried[f].__getitem__)
                x[f, k] = b
                best[f] = tried[f][b]
    return FitResult(x, best, count)


def _parabola_step(tried: Mapping[float, float], lo: float, hi: float) -> list[float]:
    """Vertex of the parabola through the best point and its neighbours (if a minimum)."""
    pts = sorted(tried.items())
    xs = np.array([p[0] for p in pts])
    ys = np.array([p[1] for p in pts])
    i = int(np.argmin(ys))
    if not (0 < i < len(xs) - 1 and np.all(np.isfinite(ys[i - 1:i + 2]))):
        return []
    x0, x1, x2 = xs[i - 1:i + 2]
    y0, y1, y2 = ys[i - 1:i + 2]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    b = (x2 ** 2 * (y0 - y1) + x1 ** 2 * (y2 - y0) + x0 ** 2 * (y1 - y2)) / den
    if not a > 0:
        return []
    v = -b / (2 * a)
    return [_snap(v, lo, hi)] if x0 < v < x2 else []


def run_fits(sim: VariantSimulator, gens: Sequence[FitGenerator]) -> list[FitResult]:
    """Drive fit generators round by round; one round's requests share simulation calls."""
    results: list[FitResult | None] = [None] * len(gens)
    reqs: dict[int, list[Model]] = {}
    for i, g in enumerate(gens):
        try:
            reqs[i] = g.send(None)  # type: ignore[arg-type]
        except StopIteration as stop:
            results[i] = stop.value
    while reqs:
        res = sim.residuals([m for models in reqs.values() for m in models])
        nxt: dict[int, list[Model]] = {}
        pos = 0
        for i, models in reqs.items():
            part = res[pos:pos + len(models)]
            pos += len(models)
            try:
                nxt[i] = gens[i].send(part)
            except StopIteration as stop:
                results[i] = stop.value
        reqs = nxt
    return [r for r in results if r is not None]


def fit_folds(sim: VariantSimulator, space: FitSpace, train: Sequence[np.ndarray],
              grid_points: int = DiagnoseSpec.grid_points,
              zoom_rounds: int = DiagnoseSpec.zoom_rounds, passes: int | None = None,
              polish: bool = True, weights: np.ndarray | None = None) -> FitResult:
    """Fit the free parameters of ``space`` for each set of training rows.

    Coordinate search: for each free parameter in turn, a grid of
    ``grid_points`` values over its bounds (plus its default and neutral
    value), then ``zoom_rounds`` rounds testing the points half the previous
    spacing either side of each fold's best value, then a parabolic step
    through the best point and its neighbours.  Every round simulates the new
    points of all folds on all cases in one call (cached), so folds share
    work.  Objective: :func:`overall_mse` on the fold's training rows.

    Parameters
    ----------
    sim : VariantSimulator
    space : FitSpace
    train : sequence of int arrays
        Training rows of each fold (e.g. ``[np.arange(n)]`` for one fit on all
        cases).
    grid_points : int
        Coarse grid size (>= 3).
    zoom_rounds : int
        Refinement rounds (each halves the spacing).
    passes : int, optional
        Sweeps over the parameters (default 1 for one free parameter, 2
        otherwise).
    polish : bool
        Parabolic step after the zoom rounds.
    weights : ndarray, optional
        Weight of each output in the objective (default equal).
    """
    gen = fit_steps(sim.data, space, train, grid_points, zoom_rounds, passes, polish, weights)
    return run_fits(sim, [gen])[0]


# ----------------------------------------------------------------------------
# Cross-validation
# ----------------------------------------------------------------------------


def kfold_indices(n: int, folds: int, seed: int = 0) -> list[np.ndarray]:
    """Held-out rows of each fold: a seeded permutation of the n cases cut in ``folds``."""
    if not 2 <= folds <= n:
        raise ParameterError(f"folds={folds} must be in [2, n_cases={n}]")
    perm = np.random.default_rng(seed).permutation(n)
    return [np.sort(p) for p in np.array_split(perm, folds)]


@dataclass
class CVResult:
    """Cross-validated errors of one model (fitted per fold).

    Attributes
    ----------
    label : str
        Model description (effect names joined with ``+``; ``default``).
    space : FitSpace
    fold_x : ndarray (n_folds, n_free)
        Fitted free parameters per fold.
    fit_x : ndarray (n_free,)
        Parameters fitted on all cases (reported; the CV numbers do not use them).
    residuals : ndarray (n, n_columns)
        Held-out residuals (each case predicted by its fold's fit).
    errors : ndarray (n, n_groups)
        Held-out per-case standardised errors.
    variants : int
        Model variants the parameter search asked for.
    """

    label: str
    space: FitSpace
    fold_x: np.ndarray
    fit_x: np.ndarray
    residuals: np.ndarray
    errors: np.ndarray
    variants: int = 0

    def rmse(self) -> np.ndarray:
        """CV RMSE of standardised residuals per output."""
        return np.sqrt(group_mse(self.errors))

    def overall_rmse(self, weights: np.ndarray | None = None) -> float:
        """CV RMSE over all outputs (root of the mean of the per-output MSE)."""
        return math.sqrt(overall_mse(self.errors, None, weights))

    def fitted_model(self) -> Model:
        """The effects with the parameters fitted on all cases."""
        return self.space.model(self.fit_x)

    def fitted_parameters(self) -> list[dict[str, Any]]:
        """``Effect.to_dict()`` of the effects fitted on all cases."""
        return [e.to_dict() for e in self.fitted_model()]


def cross_validate_many(sim: VariantSimulator,
                        spaces: Sequence[FitSpace | Sequence[FitSpace]],
                        folds: Sequence[np.ndarray], labels: Sequence[str | None] | None = None,
                        fit_all: bool = True, allow_off: bool = False,
                        **fit_options: Any) -> list[CVResult]:
    """:func:`cross_validate` of several models; their searches share simulation calls.

    An entry of ``spaces`` may be a sequence of *alternative* spaces with the
    same free parameters but different fixed values (e.g. the secondary
    parameters at their neutral values and at their nominal strengths): each
    fold then keeps the alternative with the lowest training error, so the
    choice is made on the training cases only, like the free parameters.
    """
    n = sim.data.n
    all_rows = np.arange(n)
    train = [np.setdiff1d(all_rows, h) for h in folds]
    if fit_all:
        train = train + [all_rows]
    groups = [(sp,) if isinstance(sp, FitSpace) else tuple(sp) for sp in spaces]
    flat = [sp for g in groups for sp in g]
    gens = [fit_steps(sim.data, sp, train, **fit_options) for sp in flat]
    all_fits = run_fits(sim, gens)
    w = fit_options.get("weights")
    e0 = sim.data.case_errors(sim.residuals([()])[0]) if allow_off else None
    out = []
    labels = list(labels) if labels is not None else [None] * len(groups)
    k = len(folds)
    pos = 0
    for group, label in zip(groups, labels, strict=True):
        fits = all_fits[pos:pos + len(group)]
        pos += len(group)
        # per training set, the alternative with the lowest training error
        mse = np.array([fit.train_mse for fit in fits])
        pick = np.argmin(np.where(np.isfinite(mse), mse, np.inf), axis=0)
        x = np.array([fits[a].x[f] for f, a in enumerate(pick)], float)
        train_mse = mse[pick, np.arange(len(train))]
        chosen = [group[a] for a in pick]
        if e0 is not None and group[0].free:
            for f, t in enumerate(train):
                if not overall_mse(e0, t, w) > train_mse[f]:
                    x[f] = np.nan
        fold_x = x[:k]
        fit_x = x[k] if fit_all else fold_x[0]
        space = chosen[k] if fit_all else chosen[0]
        res = sim.residuals([sp.model(xf) for sp, xf in zip(chosen[:k], fold_x, strict=True)])
        residuals = np.full_like(sim.data.observed, np.nan)
        for h, r in zip(folds, res, strict=True):
            residuals[h] = r[h]
        errors = sim.data.case_errors(residuals)
        name = label or ("+".join(e.name for e in space.effects) or "default")
        out.append(CVResult(name, space, fold_x, fit_x, residuals, errors,
                            sum(fit.variants for fit in fits)))
    return out


def cross_validate(sim: VariantSimulator, space: FitSpace, folds: Sequence[np.ndarray],
                   label: str | None = None, fit_all: bool = True, allow_off: bool = False,
                   **fit_options: Any) -> CVResult:
    """K-fold cross-validation of a model whose free parameters are fitted per fold.

    Parameters
    ----------
    sim : VariantSimulator
    space : FitSpace
        The model (no free parameters: the model is only evaluated).
    folds : sequence of int arrays
        Held-out rows of each fold (:func:`kfold_indices`).
    label : str, optional
    fit_all : bool
        Also fit on all cases (in the same simulation calls) for the report.
    allow_off : bool
        Candidate mode: the model class is "the effects, or none of them";
        a fold whose training error is not lower with the fitted effects than
        with the default model predicts with the default model (its
        parameters are NaN).  This keeps a candidate whose parameter line
        does not pass through the default model (non-neutral secondary
        parameters) from being penalised for it.
    **fit_options
        Passed to :func:`fit_folds`.
    """
    return cross_validate_many(sim, [space], folds, [label], fit_all, allow_off,
                               **fit_options)[0]


def rmse_reduction(errors: np.ndarray, base: np.ndarray, group: int | None = None,
                   weights: np.ndarray | None = None) -> float:
    """1 - RMSE(errors) / RMSE(base) of one output (``group``) or overall."""
    if group is None:
        a, b = overall_mse(errors, None, weights), overall_mse(base, None, weights)
    else:
        a, b = group_mse(errors)[group], group_mse(base)[group]
    if not (b > 0):
        return float("nan")
    return 1.0 - math.sqrt(a / b)


def _reduction_statistic(group: int | None, weights: np.ndarray | None
                       ) -> Callable[..., np.ndarray | float]:
    """Statistic for :func:`vfs.analysis.stats.bootstrap_ci`: the RMSE reduction of
    :func:`rmse_reduction` from the resampling counts of the cases (a matrix product per
    batch of samples; non-finite errors are left out of their group's mean).
    """

    def stat(e: np.ndarray, b: np.ndarray, counts: np.ndarray) -> np.ndarray:
        def mse(x: np.ndarray) -> np.ndarray:
            ok = np.isfinite(x)
            g = (counts @ np.where(ok, x, 0.0)) / (counts @ ok.astype(float))  # (s, groups)
            if group is not None:
                return g[:, group]
            w = np.ones(g.shape[-1]) if weights is None else np.asarray(weights, float)
            ww = np.where(np.isfinite(g), w, 0.0)
            return (np.where(np.isfinite(g), g, 0.0) * ww).sum(axis=-1) / ww.sum(axis=-1)

        with np.errstate(invalid="ignore", divide="ignore"):
            return 1.0 - np.sqrt(mse(e) / mse(b))

    return stat


def reduction_ci(errors: np.ndarray, base: np.ndarray, rng: np.random.Generator,
                 group: int | None = None, confidence: float = DiagnoseSpec.confidence,
                 n_boot: int = DiagnoseSpec.n_boot,
                 weights: np.ndarray | None = None) -> tuple[float, float, float]:
    """RMSE reduction with a percentile bootstrap CI over cases (paired).

    Returns (estimate, low, high); the cases are resampled jointly for the
    model and the base (:func:`vfs.analysis.stats.bootstrap_ci`).
    """
    from vfs.analysis.stats import bootstrap_ci

    stat = _reduction_statistic(group, weights)
    if not math.isfinite(float(stat(errors, base, np.ones((1, errors.shape[0])))[0])):
        return float("nan"), float("nan"), float("nan")
    if group is not None:
        ok = np.isfinite(errors[:, group]) & np.isfinite(base[:, group])
        errors, base = errors[ok], base[ok]
        if errors.shape[0] < 2:
            return float("nan"), float("nan"), float("nan")
    est, lo, hi = bootstrap_ci(stat, errors, base,
                               n_boot=n_boot, confidence=confidence, rng=rng)
    return est, lo, hi


# ----------------------------------------------------------------------------
# Calibration
# ----------------------------------------------------------------------------


@dataclass
class Calibration:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    effects : tuple of Effect
        Effects with the parameters fitted on all cases.
    steps : list of CVResult
        Cross-validated models: default, then each added effect (cumulative;
        the last one is the requested combination); empty if CV was off.
    rmse : dict
        Per output: RMSE of the fitted model on all cases (in-sample).
    train_mse : float
        Objective at the fit.
    stats : dict
        Simulation counters and time.
    """

    effects: tuple[Effect, ...]
    steps: list[CVResult]
    rmse: dict[str, float]
    train_mse: float
    stats: dict[str, Any] = field(default_factory=dict)


def calibrate(data: CalibrationData, effects: Sequence[Effect | type[Effect] | str],
              parameters: str = Parameters.PRIMARY, folds: int = DiagnoseSpec.folds,
              seed: int = DiagnoseSpec.seed,
              cumulative: bool = True, sim: VariantSimulator | None = None,
              **fit_options: Any) -> Calibration:
    """Fit the parameters of ``effects`` jointly on all cases; cross-validate.

    Parameters
    ----------
    data : CalibrationData
    effects : sequence of Effect, class or name
        Start values are the instances' values (defaults for classes/names).
    parameters : {"primary", "all"}
        Which parameters are fitted.
    folds : int
        k of the k-fold CV (0: no CV).
    seed : int
        Seed of the fold assignment.
    cumulative : bool
        Cross-validate every prefix (default, +A, +A+B, ...) for the ledger,
        else only the default and the full combination.
    sim : VariantSimulator, optional
        Reuse a simulator (and its cache).
    **fit_options
        Passed to :func:`fit_folds`.
    """
    t0 = time.perf_counter()
    sim = sim or VariantSimulator(data)
    space = FitSpace.of(effects, parameters)
    if not space.effects:
        raise ParameterError("calibrate needs at least one effect")
    steps: list[CVResult] = []
    if folds:
        held = kfold_indices(data.n, folds, seed)
        steps.append(cross_validate(sim, FitSpace((), ()), held, "default", fit_all=False))
        prefixes = (range(1, len(space.effects) + 1) if cumulative
                    else [len(space.effects)])
        subs = [FitSpace.of(space.effects[:m], parameters) for m in prefixes]
        steps += cross_validate_many(sim, subs, held, fit_all=True, **fit_options)
        x_all = steps[-1].fit_x
    else:
        x_all = fit_folds(sim, space, [np.arange(data.n)], **fit_options).x[0]
    model = space.model(x_all)
    errors = data.case_errors(sim.residuals([model])[0])
    rmse = dict(zip(data.group_names, np.sqrt(group_mse(errors)).tolist(), strict=True))
    stats = {**sim.stats(), "total_seconds": round(time.perf_counter() - t0, 3)}
    return Calibration(model, steps, rmse, overall_mse(errors), stats)


__all__ = [
    "MODEL_CONFIG_FORMAT", "OUTPUT_GROUPS", "CVResult", "Calibration", "CalibrationData",
    "FitResult", "FitSpace", "VariantSimulator", "calibrate",
    "cross_validate", "cross_validate_many", "fit_folds", "fit_steps", "group_mse",
    "kfold_indices", "run_fits",
    "overall_mse", "parse_outputs", "read_model_config", "reduction_ci", "rmse_reduction",
    "stacked_effect", "write_model_config",
]
