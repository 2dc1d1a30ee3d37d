"""Reconstruction as an inverse problem (``vfs reconstruct``).

Given what an accident scene shows -- the rest positions and headings of both
vehicles, optionally their EES (from the damage) and their directions of
motion just after the impact -- find every set of impact speeds and
uncertain parameters that is consistent with it within the stated
tolerances, and report that *feasible set* and its spread rather than a
single number.

The Collision Calculation Uncertainty paper (Krzemien et al.) samples the pre-impact speeds
uniformly by Monte-Carlo, runs the Kudlich-Slibar impact and the post-impact motion and
keeps the speed pairs that reach the observed rest positions; it shows that the built-in
optimisers of commercial programs combine incomparable quantities (angles, distances, EES)
in one weighted error whose "percentage" means nothing physically.  Here every observation
enters as a *scaled residual* r_k = (model_k - observed_k) / sigma_k, where sigma_k is the
stated standard deviation of that observation (the database's ``<column>_sd``, a
command-line flag or a documented default) combined with a model-error floor; angles are
wrapped to (-pi, pi] before scaling.  Residuals are never summed raw.

1. **Monte-Carlo acceptance.**  The unknowns are the impact speeds (prior:
   uniform, by default 0.5-1.5 times the database's speed, direction kept)
   and every uncertain input of :mod:`vfs.uncertainty.model` with its configured
   distribution.  They are sampled as standard normal scores z (u = Phi(z),
   value = the input's inverse CDF of u), so the prior is N(0, I) whatever
   the distributions.  A sample is *accepted* when every |r_k| <= k
   (``criterion="box"``, default k = 2) or when sum r_k^2 <= the chi-squared
   quantile of the stated level (``criterion="chi2"``).
2. **Local optimisation.**  From the best samples, ``scipy.optimize.
   least_squares`` minimises |r|^2 + |z|^2 (scaled residuals plus the prior
   in normal scores: the most plausible point, well defined although there
   are more unknowns than observations); the Jacobian is a batched forward
   difference (one vectorised model call per iteration).
3. **Exploring the feasible set.**  The feasible set is a thin, often curved region of the
   input space (the Collision Calculation Uncertainty paper, Figs. 10-11: a lower road
   friction with a lower speed reaches the same rest position), which prior samples rarely
   hit.  Parallel random-walk chains, started from the accepted prior samples and the
   accepted samples of Gaussians around the distinct optima (or from accepted optima), move
   inside it (ABC-MCMC, Marjoram et al. 2003): a proposal z' = z + s L e is taken when it is
   feasible and with probability min(1, p(z') / p(z)) (p the prior), which leaves the prior
   restricted to the feasible set invariant -- the distribution plain acceptance sampling
   would give, with far fewer model runs.  Covariance L L^T and scale s adapt during the
   burn-in only (towards a move rate of 0.234); every step is one vectorised model call for
   all chains.

The *feasible set* is the accepted prior samples plus the chain states after
the burn-in; the band of an unknown is its 5-95 % range there.  The optimum
is reported with its scaled residuals.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from scipy.special import ndtr, ndtri

from vfs.blas import one_blas_thread
from vfs.errors import ParameterError
from vfs.physics.impact import impact_type_names
from vfs.uncertainty.cases import CaseSet
from vfs.uncertainty.config import INPUT_NAMES, Distribution, UncertaintyConfig, default_config
from vfs.uncertainty.model import ModelRuns, evaluate
from vfs.uncertainty.sampling import resolve_inputs, values_from_unit
from vfs.units import KMH_PER_MS, wrap_angle

#: Observation groups: name -> (columns per vehicle, quantity).
OBSERVABLES: Mapping[str, tuple[tuple[str, ...], str]] = MappingProxyType({
    "rest_position": (("rest_x{i}", "rest_y{i}"), "length"),
    "rest_yaw": (("rest_yaw{i}",), "angle"),
    "ees": (("ees{i}",), "speed"),
    "post_direction": (("post_direction{i}",), "angle"),
})

#: Default standard deviations where neither a flag nor the database gives one.
DEFAULT_SD: Mapping[str, float] = MappingProxyType({
    "rest_position": 0.3,  # [m] scene survey (synthetic noise model: 0.2 m)
    "rest_yaw": math.radians(5.0),  # [rad]
    "ees": 0.10,  # relative to the observed EES (EES catalogues: about 10 %)
    "post_direction": math.radians(5.0),  # [rad]
})


def _default_speed_prior() -> Distribution:
    return Distribution("uniform", "factor", low=0.5, high=1.5)


@dataclass(frozen=True)
class ObservationSettings:
    """Which observations enter and their standard deviations.

    Attributes
    ----------
    observe : tuple of str
        Keys of :data:`OBSERVABLES`; default rest positions and rest yaw.
    rest_position_sd : float, optional
        sd of each rest coordinate [m]; None: the database's ``rest_x{i}_sd``
        / ``rest_y{i}_sd``, else :data:`DEFAULT_SD`.
    rest_yaw_sd : float, optional
        sd of the rest yaw [rad]; None as above.
    ees_sd : float, optional
        sd of the EES [m/s]; None: ``ees{i}_sd``, else 10 % of the EES.
    direction_sd : float, optional
        sd of the post-impact direction of motion [rad]; None: from the
        database's post-velocity sds (sd_v / |v_post|), else 5 deg.
    model_position_sd, model_angle_sd : float
        Model-error floor combined with every sd, sigma = sqrt(sd^2 +
        floor^2): against the simulation's 5 ms, the 20 ms run-out step moves
        rest positions by 5 cm (99th percentile; 0.44 m at most) and headings
        by 1.0 deg (3.3 deg at most) on the bundled database
        (docs/uncertainty.md); defaults 0.1 m and 2 deg.
    """

    observe: tuple[str, ...] = ("rest_position", "rest_yaw")
    rest_position_sd: float | None = None
    rest_yaw_sd: float | None = None
    ees_sd: float | None = None
    direction_sd: float | None = None
    model_position_sd: float = 0.1
    model_angle_sd: float = math.radians(2.0)

    def __post_init__(self) -> None:
        unknown = [o for o in self.observe if o not in OBSERVABLES]
        if unknown or not self.observe:
            raise ParameterError(f"observe = {list(self.observe)}: unknown {unknown}; allowed: "
                                 f"{', '.join(OBSERVABLES)}")
        for name in ("rest_position_sd", "rest_yaw_sd", "ees_sd", "direction_sd"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} = {v} must be > 0")
        for name in ("model_position_sd", "model_angle_sd"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"{name} = {v} must be >= 0")


@dataclass(frozen=True)
class ReconstructSettings:
    """Settings of the search.

    Attributes
    ----------
    speed1, speed2 : Distribution
        Priors of the impact speeds (default uniform 0.5-1.5 x the database
        speed, ``mode="factor"``; ``mode="absolute"`` for a range in m/s).
    k_sigma : float
        Acceptance bound of the ``box`` criterion: every |r| <= k (default 2).
    criterion : {"box", "chi2"}
    chi2_level : float
        Level of the ``chi2`` criterion (sum r^2 <= chi2.ppf(level, n_obs)).
    n_prior : int
        Samples of the Monte-Carlo acceptance stage.
    n_starts : int
        Local optimisations started from the best prior samples.
    n_local : int
        Samples around the optima that provide feasible, over-dispersed
        starting points for the chains (not part of the feasible set).
    n_chains : int
        Parallel chains exploring the feasible set (0: none).
    n_steps : int
        Steps per chain.
    burn_in : int
        Steps discarded (and used to adapt the proposal) before recording.
    thin : int
        Record every ``thin``-th step after the burn-in.
    """

    speed1: Distribution = field(default_factory=_default_speed_prior)
    speed2: Distribution = field(default_factory=_default_speed_prior)
    k_sigma: float = 2.0
    criterion: str = "box"
    chi2_level: float = 0.95
    n_prior: int = 20_000
    n_starts: int = 6
    n_local: int = 5_000
    n_chains: int = 400
    n_steps: int = 80
    burn_in: int = 40
    thin: int = 4

    def __post_init__(self) -> None:
        if self.criterion not in ("box", "chi2"):
            raise ParameterError(f"criterion = {self.criterion!r}; use 'box' or 'chi2'")
        if not self.k_sigma > 0:
            raise ParameterError(f"k_sigma = {self.k_sigma} must be > 0")
        if not 0.0 < self.chi2_level < 1.0:
            raise ParameterError(f"chi2_level = {self.chi2_level} outside (0, 1)")
        for name in ("n_prior", "n_starts", "thin"):
            if int(getattr(self, name)) < 1:
                raise ParameterError(f"{name} = {getattr(self, name)} must be >= 1")
        for name in ("n_local", "n_chains", "n_steps", "burn_in"):
            if int(getattr(self, name)) < 0:
                raise ParameterError(f"{name} = {getattr(self, name)} must be >= 0")
        if self.n_chains and not 0 <= self.burn_in < self.n_steps:
            raise ParameterError(f"burn_in = {self.burn_in} must be smaller than n_steps = "
                                 f"{self.n_steps}")
        for name in ("speed1", "speed2"):
            dist = getattr(self, name)
            if not isinstance(dist, Distribution):
                raise ParameterError(f"{name} must be a Distribution")
            if dist.family == "fixed":
                raise ParameterError(f"{name}: the impact speeds are unknowns, not fixed")


class Observations(NamedTuple):
    """The observed values of one case.

    Attributes
    ----------
    names : tuple of str
        Outcome names (e.g. ``rest_x1``).
    observed : ndarray (k,)
        Observed values [SI].
    sigma : ndarray (k,)
        Standard deviations used, model floor included [SI].
    source : tuple of str
        Where each sd came from (``flag``, ``database``, ``default``).
    angular : ndarray of bool (k,)
        Residuals wrapped to (-pi, pi].
    missing : tuple of str
        Requested observations the record does not have (NaN: not measured or not
        documented); they are left out, not guessed.
    """

    names: tuple[str, ...]
    observed: np.ndarray
    sigma: np.ndarray
    source: tuple[str, ...]
    angular: np.ndarray
    missing: tuple[str, ...] = ()

    def table(self) -> pd.DataFrame:
        """The observations for reports (SI)."""
        return pd.DataFrame({"observation": self.names, "observed": self.observed,
                             "sigma": self.sigma, "sd_source": self.source,
                             "angular": self.angular})


def observations(cases: CaseSet, position: int, settings: ObservationSettings) -> Observations:
    """Observed values and their standard deviations for the case at ``position``.

    A requested observation that the record does not have (NaN: a crash test that
    did not measure it, a scene that does not show it) is left out and listed in
    :attr:`Observations.missing`.

    Raises
    ------
    ParameterError
        If none of the requested observations is present.
    """
    r = cases.reconstruction.iloc[position]
    names: list[str] = []
    obs: list[float] = []
    sig: list[float] = []
    src: list[str] = []
    ang: list[bool] = []
    missing: list[str] = []

    def get(col: str) -> float:
        return float(r[col]) if col in r.index and pd.notna(r[col]) else math.nan

    for group in settings.observe:
        cols, quantity = OBSERVABLES[group]
        for i in (1, 2):
            for pattern in cols:
                name = pattern.format(i=i)
                if group == "post_direction":
                    vx, vy = get(f"vx{i}_post"), get(f"vy{i}_post")
                    value = math.atan2(vy, vx) if math.hypot(vx, vy) >= 1e-3 else math.nan
                    sd_db = math.hypot(get(f"vx{i}_post_sd"), get(f"vy{i}_post_sd")) / \
                        math.sqrt(2.0) / max(math.hypot(vx, vy), 1e-9)
                else:
                    value = get(name)
                    sd_db = get(f"{name}_sd")
                if not math.isfinite(value):
                    missing.append(name)
                    continue
                flag = {"rest_position": settings.rest_position_sd,
                        "rest_yaw": settings.rest_yaw_sd, "ees": settings.ees_sd,
                        "post_direction": settings.direction_sd}[group]
                if flag is not None:
                    sd, source = flag, "flag"
                elif math.isfinite(sd_db) and sd_db > 0:
                    sd, source = sd_db, "database"
                else:
                    sd = DEFAULT_SD[group] * (abs(value) if group == "ees" else 1.0)
                    sd = max(sd, 0.1) if group == "ees" else sd  # EES near 0: 0.1 m/s floor
                    source = "default"
                floor = settings.model_position_sd if quantity == "length" else \
                    settings.model_angle_sd if quantity == "angle" else 0.0
                names.append(name)
                obs.append(value)
                sig.append(math.hypot(sd, floor))
                src.append(source)
                ang.append(quantity == "angle")
    if not names:
        raise ParameterError(
            f"case {cases.case_id[position]}: none of the observations {missing} is in the "
            f"reconstruction table (NaN = not measured); observe what the scene shows: "
            f"--observe {','.join(OBSERVABLES)}")
    return Observations(tuple(names), np.array(obs), np.array(sig), tuple(src),
                        np.array(ang, dtype=bool), tuple(missing))


def scaled_residuals(runs: ModelRuns, obs: Observations) -> np.ndarray:
    """Scaled residuals (M, k): (model - observed) / sigma, angles wrapped first."""
    out = np.empty((runs.impact_type.shape[0], len(obs.names)))
    for k, name in enumerate(obs.names):
        diff = runs.outcomes[name] - obs.observed[k]
        if obs.angular[k]:
            diff = wrap_angle(diff)
        out[:, k] = diff / obs.sigma[k]
    # a run without the observed quantity (e.g. no post-impact motion) is far off
    return np.where(np.isfinite(out), out, 1e6)




class Optimum(NamedTuple):
    """The best point of the local optimisation.

    Attributes
    ----------
    inputs : dict
        Input values [SI].
    outcomes : dict
        Model outcomes there [SI].
    residuals : dict
        Scaled residual of each observation [-].
    chi2 : float
        Sum of the squared scaled residuals.
    objective : float
        chi2 + |z|^2 (the minimised quantity).
    accepted : bool
        Whether the optimum satisfies the acceptance criterion.
    success : bool
    message : str
    """

    inputs: dict[str, float]
    outcomes: dict[str, float]
    residuals: dict[str, float]
    chi2: float
    objective: float
    accepted: bool
    success: bool
    message: str


class Reconstruction(NamedTuple):
    """Result of :func:`reconstruct`.

    Attributes
    ----------
    case_id : object
    observations : Observations
    samples : pandas.DataFrame
        The Monte-Carlo acceptance stage, every sample: the inputs [SI], the
        outcomes of :data:`KEPT_OUTCOMES`, ``impact_type``, the scaled
        residuals ``r_<observation>``, ``chi2`` and ``accepted``.
    feasible : pandas.DataFrame
        The feasible set, same columns plus ``source`` (``prior``: accepted
        Monte-Carlo sample; ``chain``: chain state after the burn-in),
        ``chain`` and ``step`` (-1 for prior samples).
    band : pandas.DataFrame
        Per unknown and derived outcome (delta-v, EES, closing speed):
        ``nominal`` (database), ``optimum``, ``p5``, ``p50``, ``p95``, ``min``,
        ``max`` over the feasible set [SI].
    optimum : Optimum
    stats : dict
        ``n_prior``, ``n_prior_accepted``, ``acceptance_rate``, ``n_feasible``,
        ``n_model_runs``, ``move_rate``, ``drift`` (speed1, speed2: change of the
        chains' median between the first and last recorded step / band width),
        ``criterion``, ``threshold``, ``unknowns``, ``optima``, ``seconds``.
    settings : ReconstructSettings
    """

    case_id: object
    observations: Observations
    samples: pd.DataFrame
    feasible: pd.DataFrame
    band: pd.DataFrame
    optimum: Optimum
    stats: dict[str, Any]
    settings: ReconstructSettings

    def speed_band(self) -> pd.DataFrame:
        """The band of the impact speeds (rows speed1, speed2)."""
        return self.band[self.band["quantity"].isin(["speed1", "speed2"])].reset_index(drop=True)


#: Outcomes stored with every sample (beyond the inputs).
KEPT_OUTCOMES: tuple[str, ...] = (
    "rest_x1", "rest_y1", "rest_yaw1", "rest_x2", "rest_y2", "rest_yaw2", "ees1", "ees2",
    "post_direction1", "post_direction2", "delta_v1", "delta_v2", "closing_speed",
)
#: Derived outcomes of the band table.
BAND_OUTCOMES: tuple[str, ...] = ("delta_v1", "delta_v2", "ees1", "ees2", "closing_speed")


class _Problem:
    """One case in normal-score space: z (M, d) -> inputs -> model -> residuals."""

    def __init__(self, cases: CaseSet, position: int, config: UncertaintyConfig,
                 obs: Observations, settings: ReconstructSettings) -> None:
        self.cases = cases.take([position])
        self.config = config
        self.obs = obs
        self.settings = settings
        self.resolved = resolve_inputs(self.cases, config)
        self.columns = [k for k, v in enumerate(self.resolved.varied) if v]
        self.names = [INPUT_NAMES[k] for k in self.columns]
        self.d = len(self.columns)
        self.runs = 0

    def run(self, z: np.ndarray) -> _Batch:
        rows = np.zeros(z.shape[0], dtype=int)
        x = values_from_unit(self.resolved, ndtr(z), rows, self.columns)
        runs = evaluate(self.cases, x, self.config)
        self.runs += z.shape[0]
        res = scaled_residuals(runs, self.obs)
        acc, _ = _accept(res, self.settings)
        out = {name: runs.outcomes[name] for name in KEPT_OUTCOMES}
        return _Batch(z, x.values, out, runs.impact_type, res, acc)


class _Batch(NamedTuple):
    """Evaluated samples: normal scores, inputs, kept outcomes, type, residuals, accepted."""

    z: np.ndarray
    x: np.ndarray
    out: dict[str, np.ndarray]
    impact_type: np.ndarray
    res: np.ndarray
    accepted: np.ndarray

    def take(self, index: np.ndarray) -> _Batch:
        return _Batch(self.z[index], self.x[index], {k: v[index] for k, v in self.out.items()},
                      self.impact_type[index], self.res[index], self.accepted[index])

    def where(self, mask: np.ndarray, other: _Batch) -> _Batch:
        """Rows of ``other`` where ``mask``, else of self."""
        def pick(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            m = mask.reshape(mask.shape + (1,) * (a.ndim - 1))
            return np.where(m, b, a)

        return _Batch(pick(self.z, other.z), pick(self.x, other.x),
                      {k: pick(v, other.out[k]) for k, v in self.out.items()},
                      pick(self.impact_type, other.impact_type), pick(self.res, other.res),
                      pick(self.accepted, other.accepted))

    @staticmethod
    def concat(parts: Sequence[_Batch]) -> _Batch:
        return _Batch(np.concatenate([p.z for p in parts]), np.concatenate([p.x for p in parts]),
                      {k: np.concatenate([p.out[k] for p in parts]) for k in parts[0].out},
                      np.concatenate([p.impact_type for p in parts]),
                      np.concatenate([p.res for p in parts]),
                      np.concatenate([p.accepted for p in parts]))

    def table(self, obs: Observations) -> pd.DataFrame:
        df = pd.DataFrame(self.x, columns=list(INPUT_NAMES))
        for name in KEPT_OUTCOMES:
            df[name] = self.out[name]
        df["impact_type"] = impact_type_names(self.impact_type)
        for j, name in enumerate(obs.names):
            df[f"r_{name}"] = self.res[:, j]
        df["chi2"] = np.sum(self.res * self.res, axis=1)
        df["accepted"] = self.accepted
        return df


def _accept(res: np.ndarray, settings: ReconstructSettings) -> tuple[np.ndarray, float]:
    """Acceptance of scaled residuals (M, k) and the threshold used."""
    k = res.shape[1]
    if settings.criterion == "box":
        return np.all(np.abs(res) <= settings.k_sigma, axis=1), settings.k_sigma
    from scipy.stats import chi2  # imported on first use (about 0.5 s)

    limit = float(chi2.ppf(settings.chi2_level, k))
    return np.sum(res * res, axis=1) <= limit, limit


#: Largest number of residual evaluations of one local optimisation.
_MAX_NFEV = 40
#: Forward-difference step of the Jacobian in normal scores (model noise is ~1e-3 of it).
_FD_STEP = 0.02
#: Widenings of the Laplace Gaussians that provide the chains' starting points (along the
#: directions the observations constrain).
_START_WIDEN = (2.0, 0.5)
#: Target move rate of the chains (Roberts, Gelman and Gilks 1997).
_TARGET_MOVE_RATE = 0.234
#: Steps between adaptations of the proposal during the burn-in.
_ADAPT_EVERY = 5


def _optimise(problem: _Problem, starts: np.ndarray
              ) -> list[tuple[np.ndarray, np.ndarray, float, Any]]:
    """least_squares on [r(z), z] from each start; returns (z, J_obs, objective, result)."""
    from scipy import optimize  # imported on first use

    d = problem.d
    k = len(problem.obs.names)
    cache: dict[bytes, np.ndarray] = {}

    def fun(z: np.ndarray) -> np.ndarray:
        key = z.tobytes()
        if key not in cache:
            cache[key] = np.concatenate([problem.run(z[None]).res[0], z])
        return cache[key]

    def jac(z: np.ndarray) -> np.ndarray:
        pts = np.vstack([z[None], z[None] + _FD_STEP * np.eye(d)])
        r = problem.run(pts).res
        cache[z.tobytes()] = np.concatenate([r[0], z])
        return np.vstack([(r[1:] - r[0]).T / _FD_STEP, np.eye(d)])

    out = []
    for z0 in starts:
        res = optimize.least_squares(fun, z0, jac=jac, method="trf", max_nfev=_MAX_NFEV,
                                     xtol=1e-6, ftol=1e-8, gtol=1e-8)
        out.append((res.x, jac(res.x)[:k], float(2.0 * res.cost), res))
    return out


def _starts(problem: _Problem, prior: _Batch, settings: ReconstructSettings) -> np.ndarray:
    """Starting points of the local optimisations: the best prior sample (scaled residuals
    plus a little prior) of each cell of a 3 x 3 grid over the two speed priors, best cells
    first, then the best distinct samples overall.
    """
    score = np.sum(prior.res * prior.res, axis=1) + 1e-3 * np.sum(prior.z**2, axis=1)
    cols = [problem.names.index(n) for n in ("speed1", "speed2") if n in problem.names]
    cell = np.zeros(prior.z.shape[0], dtype=int)
    for c in cols:
        cell = 3 * cell + np.digitize(prior.z[:, c], ndtri(np.array([1 / 3, 2 / 3])))
    order = np.lexsort((score, cell))
    first = order[np.r_[True, cell[order][1:] != cell[order][:-1]]]
    candidates = list(first[np.argsort(score[first], kind="stable")])
    candidates += [i for i in np.argsort(score, kind="stable") if i not in set(candidates)]
    starts: list[np.ndarray] = []
    for i in candidates:
        if len(starts) >= settings.n_starts:
            break
        if all(np.linalg.norm(prior.z[i] - s) > 0.5 for s in starts):
            starts.append(prior.z[i])
    return np.array(starts)


def _drift(records: Sequence[_Batch], column: int) -> float:
    """Change of the ensemble median of one input between the first and the last recorded
    step, relative to the 5-95 % width of all records (0: the ensemble has settled).
    """
    if len(records) < 2:
        return math.nan
    first, last = records[0].x[:, column], records[-1].x[:, column]
    everything = np.concatenate([r.x[:, column] for r in records])
    width = np.quantile(everything, 0.95) - np.quantile(everything, 0.05)
    if not width > 0:
        return 0.0
    return float(abs(np.median(last) - np.median(first)) / width)


def _chains(problem: _Problem, start: _Batch, settings: ReconstructSettings,
            rng: np.random.Generator) -> tuple[list[_Batch], list[np.ndarray], float]:
    """Random-walk chains inside the feasible set; returns the records after the burn-in,
    their step numbers and the move rate after the burn-in.
    """
    d = problem.d
    state = start
    n = state.z.shape[0]

    def proposal_chol(z: np.ndarray) -> np.ndarray:
        cov = np.cov(z, rowvar=False).reshape(d, d) + 1e-6 * np.eye(d)
        try:
            return np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            return np.eye(d)

    distinct = np.unique(np.round(state.z, 9), axis=0).shape[0]
    chol = proposal_chol(state.z) if distinct > 2 * d + 2 else np.eye(d) * 0.1
    scale = 2.38 / math.sqrt(d)
    records: list[_Batch] = []
    steps: list[np.ndarray] = []
    moves = tries = 0
    window = 0
    for step in range(int(settings.n_steps)):
        z_new = state.z + scale * rng.standard_normal((n, d)) @ chol.T
        cand = problem.run(z_new)
        log_ratio = -0.5 * (np.sum(z_new**2, axis=1) - np.sum(state.z**2, axis=1))
        move = cand.accepted & (np.log(rng.random(n)) < log_ratio)
        state = state.where(move, cand)
        if step < settings.burn_in:
            window += int(move.sum())
            if (step + 1) % _ADAPT_EVERY == 0:
                rate = window / (n * _ADAPT_EVERY)
                scale *= math.exp(rate - _TARGET_MOVE_RATE)
                if np.unique(np.round(state.z, 9), axis=0).shape[0] > 2 * d + 2:
                    chol = proposal_chol(state.z)
                window = 0
        else:
            moves += int(move.sum())
            tries += n
            if (step - settings.burn_in) % settings.thin == 0:
                records.append(state)
                steps.append(np.full(n, step))
    return records, steps, (moves / tries if tries else math.nan)


@one_blas_thread
def reconstruct(cases: CaseSet, case_id: object, config: UncertaintyConfig | None = None,
                observation: ObservationSettings | None = None,
                settings: ReconstructSettings | None = None,
                seed: int | np.random.Generator | None = 0) -> Reconstruction:
    """Impact speeds and parameters consistent with the observed scene of one case.

    Parameters
    ----------
    cases : CaseSet
        Cases with their reconstruction (impact configuration = the known
        impact poses, POI, contact plane; observations = rest positions etc.).
    case_id : object
        The case to reconstruct.
    config : UncertaintyConfig, optional
        Distributions of the uncertain parameters (default
        :func:`vfs.uncertainty.config.default_config`); the speed distributions are
        replaced by the priors of ``settings``.
    observation : ObservationSettings, optional
    settings : ReconstructSettings, optional
    seed : int or numpy.random.Generator

    Returns
    -------
    Reconstruction
    """
    t0 = time.perf_counter()
    config = config or default_config()
    observation = observation or ObservationSettings()
    settings = settings or ReconstructSettings()
    if isinstance(seed, np.random.Generator):
        rng = seed
    elif seed is None:
        raise ParameterError("a seed (int) or numpy.random.Generator is required")
    else:
        rng = np.random.default_rng(int(seed))
    position = int(cases.index_of([case_id])[0])
    config = config.with_inputs(speed1=settings.speed1, speed2=settings.speed2)
    obs = observations(cases, position, observation)
    problem = _Problem(cases, position, config, obs, settings)
    d = problem.d

    # 1. Monte-Carlo acceptance from the prior
    prior = problem.run(rng.standard_normal((int(settings.n_prior), d)))
    # 2. local optimisation from the best prior samples, spread over the speed prior so
    #    that separate basins of the feasible set (e.g. one more or less spin) are found
    optima = sorted(_optimise(problem, _starts(problem, prior, settings)), key=lambda o: o[2])
    best = problem.run(optima[0][0][None])
    # 3. over-dispersed feasible starting points of the chains: the accepted prior samples
    #    and the accepted samples of Gaussians around the distinct optima (Gauss-Newton
    #    covariance, widened and narrowed along the constrained directions); they only
    #    start the chains, the burn-in removes their bias within a basin
    centres: list[tuple[np.ndarray, np.ndarray]] = []
    distinct: list[np.ndarray] = []
    for z_opt, jac_obs, _, _ in optima:
        if any(np.linalg.norm(z_opt - c) < 0.25 for c in distinct):
            continue
        distinct.append(z_opt)
        for widen in _START_WIDEN:  # a wide and a tight Gaussian: basins differ in size
            cov = np.linalg.inv(jac_obs.T @ jac_obs / widen**2 + np.eye(d))
            centres.append((z_opt, np.linalg.cholesky(0.5 * (cov + cov.T))))
    batches = [prior]
    if settings.n_local and settings.n_chains:
        which = rng.integers(0, len(centres), size=int(settings.n_local))
        z_loc = np.empty((int(settings.n_local), d))
        for k, (c, chol) in enumerate(centres):
            sel = which == k
            z_loc[sel] = c + rng.standard_normal((int(sel.sum()), d)) @ chol.T
        batches.append(problem.run(z_loc))
    pool = _Batch.concat(batches)
    records: list[_Batch] = []
    steps: list[np.ndarray] = []
    move_rate = math.nan
    start = None
    n_starts_pool = int(pool.accepted.sum())
    if n_starts_pool and settings.n_chains:
        ok = np.flatnonzero(pool.accepted)
        start = pool.take(ok[rng.integers(0, ok.size, size=int(settings.n_chains))])
    elif settings.n_chains:
        # no accepted sample: start from the accepted optima (their basins are narrow);
        # the burn-in spreads the chains, the drift shows whether it sufficed
        opt = problem.run(np.array([o[0] for o in optima]))
        ok = np.flatnonzero(opt.accepted)
        if ok.size:
            start = opt.take(ok[rng.integers(0, ok.size, size=int(settings.n_chains))])
    if start is not None:
        records, steps, move_rate = _chains(problem, start, settings, rng)

    samples = prior.table(obs)
    parts = [samples[samples["accepted"]].assign(source="prior", chain=-1, step=-1)]
    for rec, st in zip(records, steps, strict=True):
        parts.append(rec.table(obs).assign(source="chain", chain=np.arange(st.shape[0]),
                                           step=st))
    feasible = pd.concat(parts, ignore_index=True)
    _, threshold = _accept(prior.res[:1], settings)
    r_best = best.res[0]
    optimum = Optimum(
        inputs={n: float(v) for n, v in zip(INPUT_NAMES, best.x[0], strict=True)},
        outcomes={n: float(best.out[n][0]) for n in KEPT_OUTCOMES},
        residuals={n: float(v) for n, v in zip(obs.names, r_best, strict=True)},
        chi2=float(np.sum(r_best**2)), objective=float(optima[0][2]),
        accepted=bool(best.accepted[0]), success=bool(optima[0][3].success),
        message=str(optima[0][3].message))
    band = _band(feasible, problem, optimum)
    drift = {name: _drift(records, INPUT_NAMES.index(name)) for name in ("speed1", "speed2")}
    stats = {
        "n_prior": int(prior.z.shape[0]), "n_prior_accepted": int(prior.accepted.sum()),
        "acceptance_rate": float(prior.accepted.mean()), "n_feasible": len(feasible),
        "n_chains": int(settings.n_chains) if records else 0,
        "n_start_points": n_starts_pool, "move_rate": move_rate,
        "drift": drift, "n_model_runs": problem.runs, "criterion": settings.criterion,
        "threshold": threshold, "unknowns": list(problem.names),
        "optima": [float(o[2]) for o in optima], "seconds": time.perf_counter() - t0,
    }
    return Reconstruction(cases.case_id[position], obs, samples, feasible, band, optimum,
                          stats, settings)


def _band(feasible: pd.DataFrame, problem: _Problem, optimum: Optimum) -> pd.DataFrame:
    nominal = dict(zip(INPUT_NAMES, problem.resolved.nominal[:, 0], strict=True))
    rows = []
    for name in (*problem.names, *BAND_OUTCOMES):
        v = feasible[name].to_numpy(float) if len(feasible) else np.zeros(0)
        v = v[np.isfinite(v)]
        p5, p50, p95 = np.quantile(v, (0.05, 0.5, 0.95), method="hazen") if v.size else \
            (np.nan,) * 3
        rows.append({
            "quantity": name, "kind": "input" if name in INPUT_NAMES else "outcome",
            "nominal": nominal.get(name, np.nan),
            "optimum": optimum.inputs.get(name, optimum.outcomes.get(name, np.nan)),
            "p5": p5, "p50": p50, "p95": p95,
            "min": float(v.min()) if v.size else np.nan,
            "max": float(v.max()) if v.size else np.nan,
        })
    return pd.DataFrame(rows)


def format_reconstruction(rec: Reconstruction) -> str:
    """A short text summary for the console (km/h, degrees)."""
    s = rec.stats
    drift = ", ".join(f"{k} {v:.2f}" for k, v in s["drift"].items() if math.isfinite(v))
    lines = [f"case {rec.case_id}: {s['n_prior_accepted']} of {s['n_prior']} prior samples "
             f"accepted ({s['criterion']}, threshold {s['threshold']:.3g}); feasible set "
             f"{s['n_feasible']} samples ({s['n_chains']} chains, move rate "
             f"{s['move_rate']:.2f}, drift {drift or '-'}); {s['n_model_runs']} model runs, "
             f"{s['seconds']:.1f} s"]
    k = KMH_PER_MS
    for _, row in rec.speed_band().iterrows():
        lines.append(
            f"  {row['quantity']}: feasible 5-95 % {row['p5'] * k:.1f} - {row['p95'] * k:.1f} "
            f"km/h (median {row['p50'] * k:.1f}; range {row['min'] * k:.1f} - "
            f"{row['max'] * k:.1f}); optimum {row['optimum'] * k:.1f}; database "
            f"{row['nominal'] * k:.1f} km/h")
    if rec.observations.missing:
        lines.append(f"  not observed (NaN in the record, left out): "
                     f"{', '.join(rec.observations.missing)}")
    if len(rec.observations.names) < len(rec.speed_band()):
        lines.append(f"  {len(rec.observations.names)} observation(s) for "
                     f"{len(rec.speed_band())} impact speeds: the speeds are not identifiable "
                     f"from these observations alone; the band shows what the prior allows")
    o = rec.optimum
    res = ", ".join(f"{n} {v:+.2f}" for n, v in o.residuals.items())
    lines.append(f"  optimum: chi2 {o.chi2:.2f} ({'accepted' if o.accepted else 'NOT accepted'})"
                 f"; scaled residuals: {res}")
    if s["n_feasible"] == 0:
        lines.append("  no sample is consistent with the observations within the tolerances: "
                     "widen the tolerances or the speed prior, or check the observations")
    return "\n".join(lines)


__all__ = [
    "BAND_OUTCOMES", "DEFAULT_SD", "KEPT_OUTCOMES", "OBSERVABLES", "ObservationSettings",
    "Observations", "Optimum", "ReconstructSettings", "Reconstruction",
    "format_reconstruction", "observations", "reconstruct", "scaled_residuals",
]
