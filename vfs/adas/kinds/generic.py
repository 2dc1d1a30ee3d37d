"""The ``generic`` controller kind: the staged AEB of :mod:`vfs.adas.controller`.

Its ``[aeb]`` table holds the settings of :class:`vfs.adas.params.AEBParams` and the
sub-tables ``[aeb.sensor]`` (:class:`vfs.adas.params.SensorParams`) and
``[aeb.warning]``, ``[aeb.partial]``, ``[aeb.full]`` (a stage is on when its table
gives ``ttc_s``); adas/README.md lists every field.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from vfs.adas.controller import AEBController
from vfs.adas.kinds import ControllerKind, register_kind
from vfs.adas.params import AEBParams, SensorParams
from vfs.catalog import Field
from vfs.errors import DefinitionError
from vfs.settings import build, declared, read_table

#: The braking stages, in trigger order, each an ``[aeb.<stage>]`` table.
STAGE_TABLES = ("warning", "partial", "full")

#: The settings of AEBParams that sit in a stage table, by stage: attribute -> key base.
STAGE_SETTINGS: dict[str, dict[str, str]] = {
    "warning": {"warning_ttc": "ttc"},
    "partial": {"partial_ttc": "ttc", "partial_deceleration": "deceleration"},
    "full": {"full_ttc": "ttc", "full_deceleration": "deceleration",
             "last_moment": "last_moment"},
}


def _stage_fields(stage: str) -> tuple[Field, ...]:
    settings = declared(AEBParams)
    return tuple(Field(key, settings[attr].quantity, lo=settings[attr].lo,
                       hi=settings[attr].hi, lo_open=settings[attr].lo_open,
                       hi_open=settings[attr].hi_open)
                 for attr, key in STAGE_SETTINGS[stage].items())


def aeb_fields() -> tuple[Field, ...]:
    """The fields of the ``[aeb]`` table itself (without the stage settings)."""
    staged = {a for stage in STAGE_SETTINGS.values() for a in stage}
    return tuple(s.field() for name, s in declared(AEBParams).items() if name not in staged)


def table_fields() -> dict[str, tuple[Field, ...]]:
    """The fields of each table of this kind (``"aeb"``, ``"aeb.sensor"``, ``"aeb.full"``...)."""
    out = {"aeb": aeb_fields(), "aeb.sensor": tuple(s.field() for s in
                                                    declared(SensorParams).values())}
    out.update({f"aeb.{stage}": _stage_fields(stage) for stage in STAGE_TABLES})
    return out


def read(table: Mapping[str, Any], path: str, problems: list[DefinitionError]) -> Any:
    """The :class:`AEBParams` of an ``[aeb]`` table (None when it has problems)."""
    fields = table_fields()
    n_before = len(problems)
    values, found = read_table(table, fields["aeb"], path=path, where="aeb.",
                               extra=("kind", "sensor", *STAGE_TABLES))
    problems += found
    sensor_values: dict[str, Any] = {}
    sub = table.get("sensor")
    if sub is not None:
        sensor_values, found = read_table(sub, fields["aeb.sensor"], path=path,
                                          where="aeb.sensor.")
        problems += found
    sensor = build(SensorParams, sensor_values, path=path, where="aeb.sensor.",
                   problems=problems)
    for stage in STAGE_TABLES:
        sub = table.get(stage)
        got: dict[str, Any] = {}
        if sub is not None:
            got, found = read_table(sub, fields[f"aeb.{stage}"], path=path,
                                    where=f"aeb.{stage}.")
            problems += found
        keys = STAGE_SETTINGS[stage]
        values[f"{stage}_ttc"] = got.get("ttc")  # no ttc_s: the stage is off
        for attr, key in keys.items():
            if key != "ttc" and key in got:
                values[attr] = got[key]
    if len(problems) > n_before or sensor is None:
        return None
    labels = {attr: f"{stage}.{key}" for stage, keys in STAGE_SETTINGS.items()
              for attr, key in keys.items()}
    return build(AEBParams, {"sensor": sensor, **values}, path=path, where="aeb.",
                 problems=problems, labels=labels)


KIND = register_kind(ControllerKind(
    "generic", "staged AEB: warning, partial and full braking on TTC thresholds, a sensor "
    "sector, an optional last-moment trigger (docs/aeb.md)", read, AEBController, AEBParams))
