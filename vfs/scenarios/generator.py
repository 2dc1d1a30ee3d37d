"""Synthetic CEDATU-like accident databases with switchable hidden effects.

Real in-depth accident data cannot be shipped, so the platform generates
databases that look like them (``vfs generate``):

1. **Scenes** (:mod:`vfs.scenarios.scenes`): accident types, a passenger-car
   fleet, road friction, pre-crash trajectories of at least 5 s leading into
   the collision (or a near miss), drivers braking or steering late.
2. **Reconstructions** as an expert would record them.  The expert chooses
   restitution and contact friction per case (:class:`ExpertChoice`) and
   reads the true impact configuration from the damage.  The outcomes come
   from the *truth physics*: the platform's own simulation chain
   (:func:`vfs.simulation.simulate_cases`) with the **hidden effects**
   switched on (:mod:`vfs.effects`; the model and the generator share the
   implementations), plus measurement noise of stated size
   (:class:`NoiseModel`).  With no effect and no noise the reconstruction
   equals the model's result exactly; the impact configuration recorded is
   always the one the truth physics used (so a penetration effect moves
   the recorded impact time, the structure effect the POI and contact plane).
3. **Ground truth**: which effects were hidden, with their parameters, the
   noise model and per-case true values go to ``ground_truth.json`` and
   ``ground_truth_cases.parquet`` in the database folder.  The loader and
   every analysis command ignore these files; they exist to grade the
   diagnosis.

Everything is deterministic for a seed: the scene, expert and noise random
streams are spawned separately from the seed, so switching an effect on or
off changes only the outcomes, never the scenes.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.catalog import Field, catalog_path, project_path, read_fields, read_toml
from vfs.database import Database, default_meta, save_csv_folder, save_database
from vfs.database.schema import empty_table, normalise_table, table_as_stored
from vfs.effects import Effect, check_effects, parse_effect
from vfs.errors import DefinitionError, ParameterError
from vfs.physics.impact import (
    angle_between,
    deformation_energy,
    impact_type_names,
    velocity_change,
)
from vfs.scenarios.catalogue import SCENARIO_TYPES, ScenarioSpec, scenario_from_dict
from vfs.scenarios.scenes import generate_scenes
from vfs.simulation import CaseBatch, CaseResults, SimulationParams, simulate_cases
from vfs.units import KMH_PER_MS, wrap_angle

_KMH = 1.0 / KMH_PER_MS  # km/h -> m/s

#: Version of the generator; written to meta.json and the ground truth.
GENERATOR_VERSION = "1.0"
#: Files of the ground truth inside a generated database folder.
GROUND_TRUTH_FILE = "ground_truth.json"
GROUND_TRUTH_CASES_FILE = "ground_truth_cases.parquet"


@dataclass(frozen=True)
class NoiseModel:
    """Measurement noise of the recorded reconstruction outcomes (1 sigma, normal).

    The impact configuration (poses, velocities, POI, contact plane, eps,
    mu, impact type) is recorded without noise: the expert reads it from the
    damage.  The outcomes carry the noise of a reconstruction:

    Attributes
    ----------
    post_velocity : float
        Each component of a post-impact CG velocity gets noise with this
        standard deviation relative to the vehicle's delta-v [-]; delta-v
        and the change of velocity angle are recomputed from the noisy
        velocities.  Default 0.05 (reconstructed delta-v about +-5 %).
    yaw_rate : float
        Post-impact yaw rate noise [rad/s], default 0.1.
    ees : float
        Relative noise of the EES [-] (estimated from the damage with EES
        catalogues), default 0.08; the energy loss is recomputed from the
        noisy EES.
    pdof : float
        PDOF noise [deg], default 5.
    rest_position : float
        Rest position noise [m] per coordinate (scene survey), default 0.2.
    rest_yaw : float
        Rest yaw noise [deg], default 3.
    scale : float
        Factor on all of the above (0 = no noise).
    """

    post_velocity: float = 0.05
    yaw_rate: float = 0.1
    ees: float = 0.08
    pdof: float = 5.0
    rest_position: float = 0.2
    rest_yaw: float = 3.0
    scale: float = 1.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (math.isfinite(value) and value >= 0):
                raise ParameterError(f"noise {name}={value} must be finite and >= 0")

    @property
    def is_zero(self) -> bool:
        """True if no noise is added."""
        return self.scale == 0.0


#: No measurement noise.
NO_NOISE = NoiseModel(scale=0.0)


@dataclass(frozen=True)
class ExpertChoice:
    """How the synthetic expert chooses the impact parameters per case.

    Attributes
    ----------
    restitution : tuple of float
        Uniform range of eps [-]; default (0.05, 0.25) (the Reconstruction chapter: 0.1-0.3,
        the Momentum Based Impact Model paper: 0.1).
    contact_friction : tuple of float
        Uniform range of the inter-vehicle friction mu [-]; default (0.4, 0.8).
    """

    restitution: tuple[float, float] = (0.05, 0.25)
    contact_friction: tuple[float, float] = (0.4, 0.8)


@dataclass(frozen=True)
class Preset:
    """A named recipe for a synthetic database.

    Attributes
    ----------
    name, description : str
    cases : int
        Default number of cases.
    type_shares : mapping
        Accident-type code -> share of the cases.
    specs : mapping
        Overrides of :data:`vfs.scenarios.catalogue.SCENARIO_TYPES`.
    near_miss_share : float
        Share of near misses (recorded paths that do not collide).
    wet_share : float
        Share of wet roads.
    hidden : tuple of str
        Hidden effects (specs as for ``--hidden``) unless the caller gives some.
    noise : NoiseModel
    expert : ExpertChoice
    exclude_secondary_collisions : bool
        Drop cases whose vehicles collide again in the run-out (the Momentum Based Impact Model
        paper's
        sampling criterion).
    frontal_only : bool
        Keep only collisions whose PDOF is 10, 11, 12, 1 or 2 o'clock for
        both vehicles (the Momentum Based Impact Model paper's sampling criterion, STAIRS protocol).
    sample_interval : float
        Trajectory sampling [s].
    """

    name: str
    description: str
    cases: int
    type_shares: Mapping[int, float]
    specs: Mapping[int, ScenarioSpec] = field(default_factory=dict)
    near_miss_share: float = 0.0
    wet_share: float = 0.3
    hidden: tuple[str, ...] = ()
    noise: NoiseModel = NoiseModel()
    expert: ExpertChoice = ExpertChoice()
    exclude_secondary_collisions: bool = False
    frontal_only: bool = False
    sample_interval: float = 0.01


#: The fields of a preset file (``scenarios/presets/<name>.toml``) besides its tables
#: ``type_shares`` or ``type_weights``, ``specs``, ``noise`` and ``expert``.
PRESET_FIELDS: tuple[Field, ...] = (
    Field("name", "text"), Field("description", "text"),
    Field("cases", "int", lo=1, hi=10_000_000),
    Field("near_miss_share", "ratio", lo=0.0, hi=1.0),
    Field("wet_share", "ratio", lo=0.0, hi=1.0),
    Field("exclude_secondary_collisions", "bool"), Field("frontal_only", "bool"),
    Field("sample_interval", "time", lo=1e-4, hi=0.1),
)
#: The fields of a preset's ``[noise]`` table (:class:`NoiseModel`).
NOISE_FIELDS: tuple[Field, ...] = tuple(
    Field(name, quantity, lo=0.0, hi_open=True) for name, quantity in (
        ("post_velocity", "ratio"), ("yaw_rate", "angular_rate"), ("ees", "ratio"),
        ("pdof", "degrees"), ("rest_position", "length"), ("rest_yaw", "degrees"),
        ("scale", "ratio")))
#: The fields of a preset's ``[expert]`` table (:class:`ExpertChoice`).
EXPERT_FIELDS: tuple[Field, ...] = (
    Field("restitution", "pair", lo=0.0, hi=1.0, pair_of="ratio"),
    Field("contact_friction", "pair", lo=0.0, hi=2.0, pair_of="ratio"),
)
_PRESET_TABLES = ("type_shares", "type_weights", "specs", "noise", "expert", "hidden")


def _codes(table: Any, path: str, key: str) -> dict[int, Any]:
    if not isinstance(table, Mapping) or not table:
        raise DefinitionError(path, key, "must be a non-empty table code = value")
    out = {}
    for code, value in table.items():
        if not (code.isdigit() and 100 <= int(code) <= 799):
            raise DefinitionError(path, f"{key}.{code}", "not an accident-type code",
                                  "a 3-digit code in [100, 799]")
        out[int(code)] = value
    return out


def preset_from_dict(data: Mapping[str, Any], path: str | os.PathLike[str]) -> Preset:
    """The :class:`Preset` of a parsed preset file (see ``scenarios/README.md``).

    Type shares are given as ``[type_shares]`` (used as written) or ``[type_weights]``
    (divided by their sum); ``[specs.CODE]`` tables override fields of the catalogue's
    accident type ``CODE`` (:data:`vfs.scenarios.catalogue.SCENARIO_TYPES`).

    Raises
    ------
    DefinitionError
        Naming the file, the field and the allowed values.
    """
    p = str(path)
    values = read_fields(data, PRESET_FIELDS, path=p, extra=_PRESET_TABLES)
    for key in ("name", "description", "cases"):
        if key not in values:
            raise DefinitionError(p, key, "missing")
    if ("type_shares" in data) == ("type_weights" in data):
        raise DefinitionError(p, "type_shares", "give either [type_shares] or [type_weights]")
    key = "type_shares" if "type_shares" in data else "type_weights"
    raw = _codes(data[key], p, key)
    for code, share in raw.items():
        if not (isinstance(share, int | float) and not isinstance(share, bool)
                and math.isfinite(share) and share >= 0):
            raise DefinitionError(p, f"{key}.{code}", f"{share!r} is not a share", "[0, inf)")
    total = sum(raw.values())
    if not total > 0:
        raise DefinitionError(p, key, "the shares must have a positive sum")
    shares = raw if key == "type_shares" else {c: w / total for c, w in raw.items()}
    specs = {}
    specs_table = data.get("specs")
    spec_items = _codes(specs_table, p, "specs").items() if specs_table is not None else ()
    for code, table in spec_items:
        if code not in SCENARIO_TYPES:
            raise DefinitionError(p, f"specs.{code}", "no such accident type in "
                                  "scenarios/accident-types", ", ".join(map(str, SCENARIO_TYPES)))
        if not isinstance(table, Mapping):
            raise DefinitionError(p, f"specs.{code}", "must be a table ([specs.CODE])")
        specs[code] = scenario_from_dict(table, f"{p} [specs.{code}]",
                                         base=SCENARIO_TYPES[code])[1]
    hidden = data.get("hidden", [])
    if not (isinstance(hidden, list) and all(isinstance(h, str) for h in hidden)):
        raise DefinitionError(p, "hidden", f"{hidden!r} is not a list of effect specs",
                              'e.g. ["structure_poi"]')
    try:
        noise = NoiseModel(**read_fields(data.get("noise", {}), NOISE_FIELDS, path=p,
                                         where="noise."))
        expert = ExpertChoice(**read_fields(data.get("expert", {}), EXPERT_FIELDS, path=p,
                                            where="expert."))
        return Preset(type_shares=shares, specs=specs, hidden=tuple(hidden), noise=noise,
                      expert=expert, **values)
    except ParameterError as exc:
        if isinstance(exc, DefinitionError):
            raise
        raise DefinitionError(p, "", str(exc)) from None


def load_presets(folder: str | os.PathLike[str] | None = None) -> dict[str, Preset]:
    """The presets of a folder of ``<name>.toml`` files ("default" first, then by name).

    Parameters
    ----------
    folder : path, optional
        Default ``scenarios/presets`` of the catalogue (:mod:`vfs.catalog`).
    """
    root = Path(folder) if folder is not None else catalog_path("scenarios", "presets")
    presets = [preset_from_dict(read_toml(f), f) for f in sorted(root.glob("*.toml"))]
    out: dict[str, Preset] = {}
    for preset in sorted(presets, key=lambda q: (q.name != "default", q.name)):
        if preset.name in out:
            raise DefinitionError(str(root), "name", f"preset {preset.name!r} defined twice")
        out[preset.name] = preset
    return out


#: The generator's presets: the files ``scenarios/presets/<name>.toml``.
PRESETS: dict[str, Preset] = load_presets()


@dataclass(frozen=True)
class GroundTruth:
    """What generated a database (never read by analysis code).

    Attributes
    ----------
    preset, seed, n_cases
    effects : tuple of Effect
        The hidden effects with their parameters.
    noise : NoiseModel
    expert : ExpertChoice
    cases : pandas.DataFrame
        Per case: the scene design (:func:`vfs.scenarios.scenes.generate_scenes`)
        and the values the truth physics used (restitution, penetration time,
        POI, contact plane, wheel brake factors, yaw inertias).
    """

    preset: str
    seed: int
    n_cases: int
    effects: tuple[Effect, ...]
    noise: NoiseModel
    expert: ExpertChoice
    cases: pd.DataFrame

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (without the per-case table)."""
        return {
            "generator_version": GENERATOR_VERSION,
            "preset": self.preset,
            "seed": self.seed,
            "n_cases": self.n_cases,
            "hidden_effects": [e.to_dict() for e in self.effects],
            "noise": asdict(self.noise),
            "expert": asdict(self.expert),
            "note": "ground truth of a synthetic database; analysis code never reads it",
        }


def get_preset(name: str, *, cwd: str | os.PathLike[str] | None = None) -> Preset:
    """A preset by name or file, as ``vfs generate --preset`` takes it.

    Parameters
    ----------
    name : str
        The path of a preset file (ends in ``.toml`` or holds a ``/``; relative to ``cwd``),
        or a name: looked up in the project's ``<cwd>/scenarios/presets/<name>.toml`` first,
        then among :data:`PRESETS`.
    cwd : path, optional
        The project folder; default the current working directory.

    Raises
    ------
    DefinitionError
        For a preset file that is missing or wrong.
    ParameterError
        For an unknown name (naming the known ones).
    """
    if name.endswith(".toml") or "/" in name:
        path = Path(name) if cwd is None or Path(name).is_absolute() else Path(cwd) / name
        return preset_from_dict(read_toml(path), path)
    own = project_path("scenarios", "presets", f"{name}.toml", cwd=cwd)
    if own is not None and own.is_file():
        return preset_from_dict(read_toml(own), own)
    if name not in PRESETS:
        raise ParameterError(f"unknown preset {name!r}; known: {', '.join(sorted(PRESETS))}")
    return PRESETS[name]


def _effects(hidden: Iterable[str | Effect]) -> tuple[Effect, ...]:
    return check_effects(e if isinstance(e, Effect) else parse_effect(e) for e in hidden)


# ----------------------------------------------------------------------------
# Reconstruction rows
# ----------------------------------------------------------------------------

def reconstruction_rows(batch: CaseBatch, res: CaseResults, rows: np.ndarray,
                        recorded_eps: np.ndarray, recorded_mu: np.ndarray) -> pd.DataFrame:
    """Reconstruction table rows (schema columns) of the cases ``rows`` of a simulation.

    The configuration is the one the simulation solved (poses and velocities
    at impact, POI and contact plane after effects); restitution and contact
    friction are the *recorded* values (the expert's choice, not any value an
    effect derived from them).  SI units (angles in rad; the files store
    PDOF and change of velocity angle in degrees, see
    :func:`vfs.database.schema.table_as_stored`).
    """
    pre, imp, ro = res.precrash, res.impact, res.runout
    st = pre.impact_state
    cols: dict[str, Any] = {"case_id": batch.case_id[rows], "t_impact": pre.impact_time[rows]}
    for i in (1, 2):
        j = i - 1
        for name in ("x", "y", "yaw", "vx", "vy", "yaw_rate"):
            cols[f"{name}{i}"] = getattr(st, name)[rows, j]
    cols["poi_x"], cols["poi_y"] = res.poi[rows, 0], res.poi[rows, 1]
    cols["cp_angle"] = res.cp_angle[rows]
    cols["restitution"], cols["contact_friction"] = recorded_eps[rows], recorded_mu[rows]
    cols["impact_type"] = impact_type_names(imp.impact_type[rows])
    for i in (1, 2):
        for name in ("vx", "vy", "yaw_rate"):
            cols[f"{name}{i}_post"] = getattr(imp, f"{name}_post")[rows, i - 1]
    for name in ("delta_v", "ees"):
        for i in (1, 2):
            cols[f"{name}{i}"] = getattr(imp, name)[rows, i - 1]
    cols["energy_loss"] = imp.energy_loss[rows]
    for i in (1, 2):
        cols[f"pdof{i}"] = imp.pdof[rows, i - 1]
    for i in (1, 2):
        cols[f"velocity_angle_change{i}"] = imp.velocity_angle_change[rows, i - 1]
    for i in (1, 2):
        cols[f"rest_x{i}"], cols[f"rest_y{i}"] = ro.rest_x[rows, i - 1], ro.rest_y[rows, i - 1]
        cols[f"rest_yaw{i}"] = ro.rest_yaw[rows, i - 1]
    return pd.DataFrame(cols)


def add_noise(rec: pd.DataFrame, masses: np.ndarray, noise: NoiseModel,
              rng: np.random.Generator) -> pd.DataFrame:
    """Recorded outcomes with measurement noise and their ``_sd`` columns.

    ``masses`` (n, 2) [kg] of the two vehicles (for the energy loss).  See
    :class:`NoiseModel` for what gets which noise.  Deterministic for the rng.
    """
    out = rec.copy()
    n = len(rec)
    if noise.is_zero or n == 0:
        return out
    k = noise.scale
    z = rng.standard_normal((n, 16))  # fixed draw layout: reproducible per case count
    ees_new = []
    for i in (1, 2):
        j = 8 * (i - 1)
        vx, vy = rec[f"vx{i}"].to_numpy(float), rec[f"vy{i}"].to_numpy(float)
        dv = rec[f"delta_v{i}"].to_numpy(float)
        sd_v = k * noise.post_velocity * dv
        vxp = rec[f"vx{i}_post"].to_numpy(float) + sd_v * z[:, j]
        vyp = rec[f"vy{i}_post"].to_numpy(float) + sd_v * z[:, j + 1]
        out[f"vx{i}_post"], out[f"vy{i}_post"] = vxp, vyp
        out[f"vx{i}_post_sd"] = out[f"vy{i}_post_sd"] = sd_v
        sd_w = k * noise.yaw_rate
        out[f"yaw_rate{i}_post"] = rec[f"yaw_rate{i}_post"].to_numpy(float) + sd_w * z[:, j + 2]
        out[f"yaw_rate{i}_post_sd"] = sd_w
        out[f"delta_v{i}"] = velocity_change(vxp - vx, vyp - vy)
        out[f"delta_v{i}_sd"] = sd_v
        out[f"velocity_angle_change{i}"] = angle_between(vx, vy, vxp, vyp)
        ees = rec[f"ees{i}"].to_numpy(float)
        sd_e = k * noise.ees * ees
        ees_n = np.maximum(ees + sd_e * z[:, j + 3], 0.0)
        ees_new.append(ees_n)
        out[f"ees{i}"], out[f"ees{i}_sd"] = ees_n, sd_e
        sd_p = math.radians(k * noise.pdof)
        out[f"pdof{i}"] = wrap_angle(rec[f"pdof{i}"].to_numpy(float) + sd_p * z[:, j + 4])
        out[f"pdof{i}_sd"] = sd_p
        sd_r = k * noise.rest_position
        out[f"rest_x{i}"] = rec[f"rest_x{i}"].to_numpy(float) + sd_r * z[:, j + 5]
        out[f"rest_y{i}"] = rec[f"rest_y{i}"].to_numpy(float) + sd_r * z[:, j + 6]
        out[f"rest_x{i}_sd"] = out[f"rest_y{i}_sd"] = sd_r
        sd_y = math.radians(k * noise.rest_yaw)
        out[f"rest_yaw{i}"] = rec[f"rest_yaw{i}"].to_numpy(float) + sd_y * z[:, j + 7]
        out[f"rest_yaw{i}_sd"] = sd_y
    out["energy_loss"] = (deformation_energy(masses[:, 0], ees_new[0])
                          + deformation_energy(masses[:, 1], ees_new[1]))
    return out


# ----------------------------------------------------------------------------
# The generator
# ----------------------------------------------------------------------------

#: Extra scenes drawn to replace cases that must be dropped (secondary
#: collisions for presets that exclude them, touches without an impulse).
_OVERDRAW = 0.25


def generate_database(preset: str | Preset = "default", n_cases: int | None = None,
                      seed: int = 0, hidden: Iterable[str | Effect] | None = None,
                      noise: NoiseModel | None = None,
                      sample_interval: float | None = None) -> tuple[Database, GroundTruth]:
    """Generate a synthetic accident database and its ground truth.

    Parameters
    ----------
    preset : str or Preset
        Recipe (:data:`PRESETS`).
    n_cases : int, optional
        Number of cases (default: the preset's).
    seed : int
        Seed of all randomness.
    hidden : iterable of str or Effect, optional
        Hidden effects (``"NAME"``, ``"NAME=VALUE"``, ``"NAME:P=V,..."`` or
        instances); default: the preset's.  Pass ``()`` for none.
    noise : NoiseModel, optional
        Measurement noise (default: the preset's; :data:`NO_NOISE` for none).
    sample_interval : float, optional
        Trajectory sampling [s] (default: the preset's).

    Returns
    -------
    (Database, GroundTruth)
    """
    p = get_preset(preset) if isinstance(preset, str) else preset
    n = p.cases if n_cases is None else int(n_cases)
    if n < 1:
        raise ParameterError(f"cases={n} must be >= 1")
    effects = _effects(p.hidden if hidden is None else hidden)
    noise = p.noise if noise is None else noise
    dt = p.sample_interval if sample_interval is None else float(sample_interval)
    scene_rng, expert_rng, noise_rng = np.random.default_rng(seed).spawn(3)
    strict = p.exclude_secondary_collisions or p.frontal_only
    n_draw = n + (math.ceil(_OVERDRAW * n) + 4 if strict else math.ceil(0.02 * n) + 2)
    scenes = generate_scenes(n_draw, scene_rng, p.type_shares, specs=p.specs or None,
                             near_miss_share=p.near_miss_share, wet_share=p.wet_share,
                             sample_interval=dt)
    cases = normalise_table(scenes.cases, "cases")
    parts = normalise_table(scenes.participants, "participants")
    traj = normalise_table(scenes.trajectories, "trajectories")
    scene_db = Database(cases, parts, traj, empty_table("reconstruction"),
                        meta={**default_meta(), "has_reconstruction": False})
    ids = scene_db.case_ids
    eps = np.asarray(expert_rng.uniform(*p.expert.restitution, size=ids.shape[0]))
    mu = np.asarray(expert_rng.uniform(*p.expert.contact_friction, size=ids.shape[0]))
    batch = CaseBatch.from_database(scene_db)._replace(restitution=eps, contact_friction=mu)
    res = simulate_cases(batch, params=SimulationParams(effects=effects))

    designed = cases["collision"].to_numpy(bool)
    collided = res.precrash.collided
    real = res.impact.impact_type != 0
    keep = designed == collided
    keep &= ~collided | real  # a touch without an impulse cannot be recorded
    if p.exclude_secondary_collisions:
        keep &= ~res.runout.secondary_collision
    if p.frontal_only:
        frontal = np.zeros(13, dtype=bool)  # index = clock direction 1-12 (0: none)
        frontal[[10, 11, 12, 1, 2]] = True
        keep &= frontal[res.impact.pdof_clock[:, 0]] & frontal[res.impact.pdof_clock[:, 1]]
    chosen = np.flatnonzero(keep)[:n]
    if chosen.shape[0] < n:
        raise ParameterError(
            f"preset {p.name}: only {chosen.shape[0]} of {n} cases usable from {n_draw} scenes "
            "(try another seed)")
    # renumber the kept cases 1..n in their drawn order
    new_id = dict(zip(ids[chosen].tolist(), range(1, n + 1), strict=True))

    def renumber(df: pd.DataFrame) -> pd.DataFrame:
        df = df[df["case_id"].isin(new_id)].copy()
        df["case_id"] = df["case_id"].map(new_id).astype("int64")
        return df.sort_values([c for c in ("case_id", "participant", "t") if c in df.columns],
                              kind="stable").reset_index(drop=True)

    crash_rows = chosen[collided[chosen]]
    rec = reconstruction_rows(batch, res, crash_rows, eps, mu)
    masses = np.stack([batch.vehicle1.mass[crash_rows], batch.vehicle2.mass[crash_rows]], axis=1)
    rec = add_noise(rec, masses, noise, noise_rng)
    rec = renumber(table_as_stored(rec, "reconstruction"))  # as if read from the files
    meta = {
        **default_meta(
            name=f"synthetic-{p.name}",
            created_by=f"vfs generate (generator {GENERATOR_VERSION})",
            description=(f"synthetic database, preset {p.name!r}, seed {seed}, {n} cases; "
                         f"{p.description}. Ground truth in {GROUND_TRUTH_FILE}."),
        ),
        "generator": {"preset": p.name, "seed": seed, "cases": n, "sample_interval": dt,
                      "version": GENERATOR_VERSION},
    }
    db = Database(renumber(cases), renumber(parts), renumber(traj), rec, meta=meta).normalised()

    truth_cases = scenes.design.set_index("case_id").reindex(ids[chosen]).reset_index()
    truth_cases["source_scene"] = truth_cases["case_id"]
    truth_cases["case_id"] = np.arange(1, n + 1)
    pre = res.precrash
    truth_cases["collided"] = collided[chosen]
    truth_cases["true_restitution"] = res.restitution[chosen]
    truth_cases["true_contact_friction"] = res.contact_friction[chosen]
    truth_cases["recorded_restitution"] = eps[chosen]
    truth_cases["penetration_time"] = (pre.impact_time - pre.contact_time)[chosen]
    truth_cases["geometric_poi_x"] = pre.poi[chosen, 0]
    truth_cases["geometric_poi_y"] = pre.poi[chosen, 1]
    truth_cases["geometric_cp_angle"] = pre.cp_angle[chosen]
    truth_cases["true_poi_x"] = res.poi[chosen, 0]
    truth_cases["true_poi_y"] = res.poi[chosen, 1]
    truth_cases["true_cp_angle"] = res.cp_angle[chosen]
    truth_cases["true_impact_type"] = res.impact.impact_type[chosen]
    for i in (1, 2):
        for w, wheel in enumerate(("FL", "FR", "RL", "RR")):
            truth_cases[f"wheel_brake{i}_{wheel}"] = res.wheel_brake[chosen, i - 1, w]
    truth_cases["secondary_collision"] = res.runout.secondary_collision[chosen]
    truth = GroundTruth(p.name, int(seed), n, effects, noise, p.expert, truth_cases)
    return db, truth


def write_generated(db: Database, truth: GroundTruth, out: str | os.PathLike[str],
                    fmt: str = "parquet", truth_path: str | os.PathLike[str] | None = None
                    ) -> Path:
    """Write a generated database (Parquet or CSV folder) and its ground truth.

    The ground truth goes to ``out/ground_truth.json`` and
    ``out/ground_truth_cases.parquet`` unless ``truth_path`` names another
    JSON file (the per-case table then goes beside it).
    """
    if fmt == "parquet":
        folder = save_database(db, out)
    elif fmt == "csv":
        folder = save_csv_folder(db, out)
    else:
        raise ParameterError(f"format {fmt!r}; use 'parquet' or 'csv'")
    target = Path(truth_path) if truth_path is not None else folder / GROUND_TRUTH_FILE
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.tmp")
    tmp.write_text(json.dumps(truth.summary(), indent=2, default=float) + "\n",
                   encoding="utf-8")
    os.replace(tmp, target)
    cases_file = target.with_name(target.stem + "_cases.parquet")
    tmp_cases = cases_file.with_name(f".{cases_file.name}.tmp")
    truth.cases.to_parquet(tmp_cases, index=False)
    os.replace(tmp_cases, cases_file)
    return folder


def read_ground_truth(folder: str | os.PathLike[str]) -> dict[str, Any]:
    """The ground-truth summary of a generated database (for grading, never for analysis)."""
    path = Path(folder) / GROUND_TRUTH_FILE
    return json.loads(path.read_text(encoding="utf-8"))
