"""Uncertainty of the collision outcomes: Monte-Carlo bands, Sobol sensitivity and
reconstruction as an inverse problem (docs/uncertainty.md).

Modules: :mod:`~vfs.uncertainty.config` (input distributions, TOML files),
:mod:`~vfs.uncertainty.cases` (reconstructed cases, recorded outcomes),
:mod:`~vfs.uncertainty.sampling` (per-case distributions, seeded draws),
:mod:`~vfs.uncertainty.model` (impact configuration -> impact -> run-out),
:mod:`~vfs.uncertainty.outcomes` (the outcomes of one run),
:mod:`~vfs.uncertainty.bands` (Monte-Carlo bands and summaries),
:mod:`~vfs.uncertainty.sensitivity` (Sobol indices) and
:mod:`~vfs.uncertainty.reconstruct` (inverse problem; import them from there).
"""

from vfs.uncertainty.bands import (
    BAND,
    UncertaintyResult,
    band_summary,
    coverage,
    input_table,
    run_uncertainty,
    unwrap_circular,
)
from vfs.uncertainty.cases import (
    DEFAULT_PENETRATION,
    MAX_PENETRATION,
    CaseSet,
    estimate_penetration,
    recorded_outcomes,
)
from vfs.uncertainty.config import (
    ABSOLUTE,
    DEFAULT_CONFIG_PATH,
    FACTOR,
    FAMILIES,
    INPUT_NAMES,
    INPUTS,
    INPUTS_BY_NAME,
    MODES,
    OFFSET,
    Distribution,
    InputInfo,
    InputSpec,
    UncertaintyConfig,
    config_from_dict,
    default_config,
    load_config,
    parse_distribution,
)
from vfs.uncertainty.model import ModelRuns, evaluate, nominal_runs
from vfs.uncertainty.outcomes import (
    DISPLAY_UNITS,
    OUTCOME_NAMES,
    OUTCOMES,
    OUTCOMES_BY_NAME,
    RENAMED_OUTCOMES,
    SI_UNITS,
    OutcomeInfo,
)
from vfs.uncertainty.sampling import (
    ResolvedInputs,
    SampledInputs,
    distribution_ppf,
    make_rng,
    nominal_inputs,
    resolve_inputs,
    sample_inputs,
    values_from_unit,
)

__all__ = [
    "ABSOLUTE", "BAND", "DEFAULT_CONFIG_PATH", "DEFAULT_PENETRATION", "DISPLAY_UNITS", "FACTOR",
    "FAMILIES", "INPUTS", "INPUTS_BY_NAME", "INPUT_NAMES", "MAX_PENETRATION", "MODES", "OFFSET",
    "OUTCOMES", "OUTCOMES_BY_NAME", "OUTCOME_NAMES", "RENAMED_OUTCOMES", "SI_UNITS", "CaseSet",
    "Distribution", "InputInfo", "InputSpec", "ModelRuns", "OutcomeInfo", "ResolvedInputs",
    "SampledInputs", "UncertaintyConfig", "UncertaintyResult", "band_summary",
    "config_from_dict", "coverage", "default_config", "distribution_ppf", "estimate_penetration",
    "evaluate", "input_table", "load_config", "make_rng", "nominal_inputs", "nominal_runs",
    "parse_distribution", "recorded_outcomes", "resolve_inputs", "run_uncertainty",
    "sample_inputs", "unwrap_circular", "values_from_unit",
]
