"""AEB systems as files: the :class:`AEBSystem` and its TOML definition.

A system is written as a TOML file (``adas/<name>.toml`` in the repository;
every field in ``adas/README.md``)::

    name = "my-aeb"
    description = "one line for reports"

    [aeb]                      # absent: no AEB (the record is replayed)
    prediction = "ctrv"
    ttc_horizon_s = 4.0
    release = "standstill"
    min_speed_kmh = 5.0

    [aeb.sensor]
    range_m = 150.0
    field_of_view_deg = 20.0
    latency_s = 0.1

    [aeb.warning]              # a stage is on when its table gives ttc_s
    ttc_s = 2.6
    [aeb.full]
    ttc_s = 0.6
    deceleration_mps2 = 10.0

    [driver]                   # absent: the driver does not react
    brake_lag_s = 0.2

    [brake]
    jerk_mps3 = 40.0

Keys name their unit (:data:`vfs.catalog.QUANTITY_UNITS`); :func:`load_system`
converts to SI at this edge (degrees to radians, km/h to m/s) and checks each
field against its allowed range (:data:`SCHEMA`), so a wrong file gets one
:class:`vfs.errors.DefinitionError` naming the file, the field and the range.
A field left out takes the default of :class:`~vfs.adas.params.SensorParams`,
:class:`~vfs.adas.params.AEBParams`, :class:`~vfs.adas.params.DriverParams` or
:class:`~vfs.physics.precrash.BrakeActuatorParams`; a stage left out (or a stage
table without ``ttc_s``) is off.

The built-in systems of :mod:`vfs.adas.systems` are these files
(``adas/*.toml``, read through :mod:`vfs.catalog`).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy.typing as npt

from vfs.adas.controller import AEBController
from vfs.adas.params import PREDICTION_MODELS, RELEASE_RULES, AEBParams, DriverParams, SensorParams
from vfs.catalog import Field, read_fields, read_toml, sub_table
from vfs.errors import DefinitionError, ParameterError
from vfs.physics.precrash import BrakeActuatorParams, PrecrashParams

if TYPE_CHECKING:
    from vfs.simulation import CaseBatch


@dataclass(frozen=True)
class AEBSystem:
    """A named AEB system: logic, sensor, driver reaction and brake actuator.

    Attributes
    ----------
    name : str
        Registry key.
    description : str
        One line for reports.
    aeb : AEBParams or None
        The AEB; None = no AEB.
    driver : DriverParams or None
        How the equipped vehicle's driver reacts to the first alert; None =
        no reaction.
    brake : BrakeActuatorParams
        The brake actuator of the equipped vehicles (the simulation uses one
        actuator for both participants; see :meth:`precrash_params`).
    """

    name: str
    description: str
    aeb: AEBParams | None
    driver: DriverParams | None
    brake: BrakeActuatorParams = dataclasses.field(default_factory=BrakeActuatorParams)

    def __post_init__(self) -> None:
        if not self.name or not isinstance(self.name, str):
            raise ParameterError("an AEB system needs a non-empty name")

    def controller(self, batch: CaseBatch, equipped: npt.ArrayLike) -> AEBController | None:
        """A fresh controller for ``batch``; None for a system without AEB.

        Parameters
        ----------
        batch : CaseBatch
        equipped : array_like of bool, broadcastable to (N, 2)
            Which participant of each case carries the system.
        """
        if self.aeb is None:
            return None
        return AEBController(batch, equipped, self.aeb, self.driver, self.brake)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``base`` with this system's brake actuator."""
        return dataclasses.replace(base, brake=self.brake)


# ----------------------------------------------------------------------------
# The file form
# ----------------------------------------------------------------------------

_POS = dict(lo=0.0, lo_open=True)          # (0, inf)
_NONNEG = dict(lo=0.0)                     # [0, inf)
_FINITE = dict(lo=-math.inf, hi=math.inf, lo_open=True, hi_open=True)
_POS_FINITE = dict(lo=0.0, lo_open=True, hi_open=True)

#: The fields of each table of a system file (SI bounds; the message shows them in the
#: unit of the key the file used).  Tables: "" (top level), "aeb", "aeb.sensor",
#: "aeb.warning", "aeb.partial", "aeb.full", "driver", "brake".
SCHEMA: dict[str, tuple[Field, ...]] = {
    "": (Field("name", "text"), Field("description", "text")),
    "aeb": (
        Field("prediction", "text", choices=PREDICTION_MODELS),
        Field("ttc_horizon", "time", lo=0.0, hi=30.0, lo_open=True),
        Field("ctrv_tolerance", "length", lo=0.001, hi=1.0),
        Field("ctrv_step", "time", lo=0.01, hi=1.0),
        Field("release", "text", choices=RELEASE_RULES),
        Field("release_factor", "ratio", lo=1.0, hi_open=True),
        Field("box_margin_longitudinal", "length", lo=0.0, hi=20.0),
        Field("box_margin_lateral", "length", lo=0.0, hi=20.0),
        Field("min_speed", "speed", lo=0.0, hi_open=True),
        Field("max_speed", "speed", lo=0.0, hi_open=True, lo_open=True),
    ),
    "aeb.sensor": (
        Field("range", "length", **_POS),  # type: ignore[arg-type]
        Field("field_of_view", "angle", lo=0.0, hi=2.0 * math.pi, lo_open=True),
        Field("mount_x", "length", **_FINITE),  # type: ignore[arg-type]
        Field("mount_y", "length", **_FINITE),  # type: ignore[arg-type]
        Field("mount_yaw", "angle", **_FINITE),  # type: ignore[arg-type]
        Field("cycle_time", "time", lo=0.0, hi=1.0),
        Field("latency", "time", lo=0.0, hi=2.0),
        Field("detection_probability", "ratio", lo=0.0, hi=1.0),
    ),
    "aeb.warning": (Field("ttc", "time", **_POS_FINITE),),  # type: ignore[arg-type]
    "aeb.partial": (
        Field("ttc", "time", **_POS_FINITE),  # type: ignore[arg-type]
        Field("deceleration", "acceleration", **_POS_FINITE),  # type: ignore[arg-type]
    ),
    "aeb.full": (
        Field("ttc", "time", **_POS_FINITE),  # type: ignore[arg-type]
        Field("deceleration", "acceleration", **_POS_FINITE),  # type: ignore[arg-type]
        Field("last_moment", "bool"),
    ),
    "driver": (
        Field("reaction_time", "time", **_NONNEG, hi_open=True),  # type: ignore[arg-type]
        Field("reaction_shape", "ratio", **_POS_FINITE),  # type: ignore[arg-type]
        Field("reaction_rate", "rate", **_POS_FINITE),  # type: ignore[arg-type]
        Field("brake_lag", "time", lo=0.0, hi=2.0),
        Field("brake_share", "ratio", lo=0.0, hi=1.0),
        Field("deceleration_mean", "acceleration", **_POS_FINITE),  # type: ignore[arg-type]
        Field("deceleration_sd", "acceleration", **_NONNEG, hi_open=True),  # type: ignore[arg-type]
        Field("deceleration_min", "acceleration", **_POS_FINITE),  # type: ignore[arg-type]
        Field("deceleration_max", "acceleration", **_POS_FINITE),  # type: ignore[arg-type]
    ),
    "brake": (
        Field("model", "text", choices=("jerk", "first_order")),
        Field("jerk", "jerk", **_POS_FINITE),  # type: ignore[arg-type]
        Field("release_jerk", "jerk", **_POS_FINITE),  # type: ignore[arg-type]
        Field("time_constant", "time", **_POS_FINITE),  # type: ignore[arg-type]
        Field("max_deceleration", "acceleration", **_POS_FINITE),  # type: ignore[arg-type]
    ),
}

_STAGES = ("warning", "partial", "full")


def _build(path: str, where: str, cls: Any, values: Mapping[str, Any]) -> Any:
    """``cls(**values)`` with a ParameterError of the dataclass as a DefinitionError."""
    try:
        return cls(**values)
    except ParameterError as exc:
        raise DefinitionError(path, where, str(exc)) from None


def _aeb(table: Mapping[str, Any], path: str) -> AEBParams:
    tables = ["sensor", *_STAGES]
    values = read_fields(table, SCHEMA["aeb"], path=path, where="aeb.", extra=tables)
    sensor_table = sub_table(table, "sensor", path=path, where="aeb.")
    sensor = _build(path, "aeb.sensor", SensorParams,
                    read_fields(sensor_table or {}, SCHEMA["aeb.sensor"], path=path,
                                where="aeb.sensor."))
    for stage in _STAGES:
        stage_table = sub_table(table, stage, path=path, where="aeb.")
        got = read_fields(stage_table or {}, SCHEMA[f"aeb.{stage}"], path=path,
                          where=f"aeb.{stage}.")
        values[f"{stage}_ttc"] = got.pop("ttc", None)  # no ttc_s: the stage is off
        if "deceleration" in got:
            values[f"{stage}_deceleration"] = got.pop("deceleration")
        values.update(got)
    return _build(path, "aeb", AEBParams, {"sensor": sensor, **values})


def system_from_dict(data: Mapping[str, Any], path: str | os.PathLike[str],
                     default_name: str | None = None) -> AEBSystem:
    """The system of a parsed definition (``tomllib`` output).

    Parameters
    ----------
    data : mapping
        The file's tables.
    path : path
        The file, for messages.
    default_name : str, optional
        Name when the file gives none (default the file name without ``.toml``).

    Raises
    ------
    DefinitionError
        Naming the file, the field and the allowed range.
    """
    p = str(path)
    top = read_fields(data, SCHEMA[""], path=p, extra=("aeb", "driver", "brake"))
    name = top.get("name") or default_name or Path(p).stem
    aeb_table = sub_table(data, "aeb", path=p)
    driver_table = sub_table(data, "driver", path=p)
    brake_table = sub_table(data, "brake", path=p)
    aeb = _aeb(aeb_table, p) if aeb_table is not None else None
    driver = None if driver_table is None else _build(
        p, "driver", DriverParams, read_fields(driver_table, SCHEMA["driver"], path=p,
                                               where="driver."))
    brake = _build(p, "brake", BrakeActuatorParams,
                   read_fields(brake_table or {}, SCHEMA["brake"], path=p, where="brake."))
    return _build(p, "name", AEBSystem, dict(name=name, description=top.get("description", ""),
                                             aeb=aeb, driver=driver, brake=brake))


def load_system(path: str | os.PathLike[str]) -> AEBSystem:
    """The AEB system defined by a TOML file (see the module docstring and adas/README.md).

    Raises
    ------
    DefinitionError
        A missing file, invalid TOML, an unknown field, a wrong type or a value out of
        range; the message names the file, the field and its allowed range.
    """
    return system_from_dict(read_toml(path), path)


def is_definition_path(spec: str) -> bool:
    """True when a ``--systems`` entry is a file path rather than a name."""
    return spec.endswith(".toml") or "/" in spec or os.sep in spec


__all__ = ["SCHEMA", "AEBSystem", "is_definition_path", "load_system", "system_from_dict"]
