"""Model configuration files: the effects of a model, as ``vfs calibrate`` writes them.

A model configuration is a JSON object::

    {"effects": [{"name": "tyre_impulse", "parameters": {"duration": 0.1}}, ...],
     "runout": {"contact": true},
     "name": "...", "description": "...", "comment": "...",
     "created_by": "vfs calibrate", "fit": {...}}

``effects`` and ``runout`` change the model: ``runout`` sets fields of
:class:`vfs.physics.runout.RunoutParams` by name (checked by their declarations; for
example ``{"contact": true}``: vehicles that stay in contact after the impact push each
other instead of passing through).  The other keys of :data:`MODEL_CONFIG_KEYS`
are informational (``fit`` records how ``vfs calibrate`` obtained the
parameters).  :func:`read_model_config` is the one reader (``vfs compare
--model``, ``vfs diagnose``); it refuses unknown keys, so that a misspelt
setting is never silently ignored.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import fields
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vfs.atomic import write_json
from vfs.effects import Effect, effects_from_dicts
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.physics.runout import RunoutParams
from vfs.simulation import SimulationParams

#: Format tag of model configuration files (in ``fit``).
MODEL_CONFIG_FORMAT = "vfs-model/1"

#: Keys of a model configuration file; everything but "effects" and "runout" is
#: informational.
MODEL_CONFIG_KEYS: tuple[str, ...] = ("effects", "runout", "name", "description", "comment",
                                      "created_by", "fit")


def write_model_config(path: str | os.PathLike[str], effects: Iterable[Effect],
                       created_by: str = "vfs calibrate",
                       fit: Mapping[str, Any] | None = None) -> Path:
    """Write a model configuration file ``{"effects": [...], "created_by", "fit"}`` atomically.

    Parameters
    ----------
    path : path
        Target file (its folder is created).
    effects : iterable of Effect
        Written as ``{"name", "parameters"}`` records (:meth:`Effect.to_dict`).
    created_by : str
        Who wrote it.
    fit : mapping, optional
        How the parameters were obtained (database, outputs, errors); the
        format tag and the date are added.

    Returns
    -------
    Path
        The file.
    """
    doc = {
        "effects": [e.to_dict() for e in effects],
        "created_by": created_by,
        "fit": {"format": MODEL_CONFIG_FORMAT,
                "created": datetime.now(UTC).isoformat(timespec="seconds"), **dict(fit or {})},
    }
    return write_json(path, doc)


def read_model_config(path: str | os.PathLike[str]) -> tuple[Effect, ...]:
    """The effects of a model configuration file (its ``runout`` settings are checked
    but not returned: :func:`load_model_config` gives both).

    Parameters
    ----------
    path : path
        JSON file (see the module docstring); ``{}`` is the default model.

    Returns
    -------
    tuple of Effect
        The listed effects (:func:`vfs.effects.effects_from_dicts`), in order.

    Raises
    ------
    DataError
        If the file does not exist, is not valid JSON or not a JSON object.
    ParameterError
        If a key is unknown, ``effects`` is not a list of objects with a
        ``name``, or an effect or parameter is unknown or out of range.
    """
    return effects_from_dicts(_read(path)[1])


def _read(path: str | os.PathLike[str]) -> tuple[Path, list[dict[str, Any]], dict[str, Any]]:
    """The file, its effect records and its run-out settings, checked as
    :func:`read_model_config` documents.
    """
    file = Path(path)
    if not file.is_file():
        raise DataError(DataProblem(str(file), "", None, None, "model configuration not found"))
    try:
        cfg = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(DataProblem(str(file), "", None, None, f"invalid JSON: {exc}")) from exc
    if not isinstance(cfg, dict):
        raise DataError(DataProblem(str(file), "", None, None,
                                    "must hold a JSON object {\"effects\": [...]}"))
    unknown = sorted(set(cfg) - set(MODEL_CONFIG_KEYS))
    if unknown:
        raise ParameterError(f"{file}: unknown key(s) {unknown}; known: {list(MODEL_CONFIG_KEYS)}")
    items = cfg.get("effects", [])
    if not isinstance(items, list) or not all(
            isinstance(d, dict) and "name" in d and isinstance(d.get("parameters", {}), dict)
            for d in items):
        raise ParameterError(f"{file}: 'effects' must be a list of objects "
                             "{\"name\": ..., \"parameters\": {...}}")
    runout = cfg.get("runout", {})
    if not isinstance(runout, dict):
        raise ParameterError(f"{file}: 'runout' must be an object of run-out settings, "
                             "e.g. {\"contact\": true}")
    known = [f.name for f in fields(RunoutParams)]
    unknown = sorted(set(runout) - set(known))
    if unknown:
        raise ParameterError(f"{file}: 'runout': unknown setting(s) {unknown}; known: {known}")
    return file, items, runout


def load_model_config(path: str | os.PathLike[str]) -> SimulationParams:
    """Simulation parameters of a model configuration file: the default parameters
    with the effects of :func:`read_model_config` and its ``runout`` settings (same
    errors; a run-out value out of its declared range raises
    :class:`vfs.errors.ParameterError` naming the setting).
    """
    file, items, runout = _read(path)
    try:
        runout_params = RunoutParams(**runout)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{file}: 'runout': {exc}") from exc
    return SimulationParams(effects=effects_from_dicts(items), runout=runout_params)


__all__ = [
    "MODEL_CONFIG_FORMAT",
    "MODEL_CONFIG_KEYS",
    "load_model_config",
    "read_model_config",
    "write_model_config",
]
