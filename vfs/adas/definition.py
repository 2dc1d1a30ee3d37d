"""AEB systems as files: the :class:`AEBSystem` and its TOML definition.

A system is written as a TOML file (``adas/<name>.toml`` in the repository;
every field in ``adas/README.md``)::

    description = "one line for reports"   # the name is the file's: my-aeb

    [aeb]                      # absent: write aeb = false (no AEB, the record is replayed)
    kind = "generic"           # the controller kind (vfs.adas.kinds); default generic
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
field against its declared range (:mod:`vfs.settings`: the fields, bounds and
defaults are those declared on the parameter classes; :data:`SCHEMA` is derived
from them) and the rules between fields (stage order, speed window, driver
decelerations), and reports every problem of the file at once: one
:class:`vfs.errors.DefinitionError` line each naming the file, the field and what
is allowed.

The system's name is the file's name without ``.toml``: a copy of a built-in file
under a new name runs beside the original without editing.  A file must say what
it is: an ``[aeb]`` table, or ``aeb = false`` for a system without AEB (an empty
file is an error, not a system that does nothing).
A field left out takes the default of :class:`~vfs.adas.params.SensorParams`,
:class:`~vfs.adas.params.AEBParams`, :class:`~vfs.adas.params.DriverParams` or
:class:`~vfs.physics.precrash.BrakeActuatorParams`; a stage left out (or a stage
table without ``ttc_s``) is off.

The built-in systems of :mod:`vfs.adas.systems` are these files
(``adas/*.toml``, read through :mod:`vfs.catalog`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy.typing as npt

from vfs.adas.contract import SystemController
from vfs.adas.kinds import CONTROLLER_KINDS, DEFAULT_KIND
from vfs.adas.kinds.generic import table_fields
from vfs.adas.params import DriverParams
from vfs.catalog import Field, read_toml
from vfs.errors import DefinitionError, ParameterError
from vfs.physics.precrash import BrakeActuatorParams, PrecrashParams
from vfs.settings import build, fields_of, raise_problems, read_table

if TYPE_CHECKING:
    from vfs.simulation import CaseBatch


@dataclass(frozen=True)
class AEBSystem:
    """A named AEB system defined by a file: logic, sensor, driver reaction, brake actuator.

    It keeps the contract :class:`vfs.adas.contract.System`.

    Attributes
    ----------
    name : str
        Registry key.
    description : str
        One line for reports.
    aeb : object or None
        The parameters of the controller kind ``kind`` (:class:`AEBParams` for
        ``"generic"``); None = no AEB.
    driver : DriverParams or None
        How the equipped vehicle's driver reacts to the first alert; None =
        no reaction.
    brake : BrakeActuatorParams
        The brake actuator of the equipped vehicles (the simulation uses one
        actuator for both participants; see :meth:`precrash_params`).
    kind : str
        The controller kind (:data:`vfs.adas.kinds.CONTROLLER_KINDS`).
    """

    name: str
    description: str
    aeb: Any | None
    driver: DriverParams | None
    brake: BrakeActuatorParams = dataclasses.field(default_factory=BrakeActuatorParams)
    kind: str = dataclasses.field(default=DEFAULT_KIND, repr=False)  # repr as before kinds

    def __post_init__(self) -> None:
        if not self.name or not isinstance(self.name, str):
            raise ParameterError("an AEB system needs a non-empty name")

    def controller(self, batch: CaseBatch, equipped: npt.ArrayLike) -> SystemController | None:
        """A fresh controller for ``batch``; None for a system without AEB.

        Parameters
        ----------
        batch : CaseBatch
        equipped : array_like of bool, broadcastable to (N, 2)
            Which participant of each case carries the system.
        """
        if self.aeb is None:
            return None
        return CONTROLLER_KINDS.get(self.kind).build(batch, equipped, self.aeb, self.driver,
                                                     self.brake)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``base`` with this system's brake actuator."""
        return dataclasses.replace(base, brake=self.brake)


# ----------------------------------------------------------------------------
# The file form
# ----------------------------------------------------------------------------

#: The top level of a system file.
TOP_FIELDS: tuple[Field, ...] = (Field("name", "text"), Field("description", "text"))


def schema() -> dict[str, tuple[Field, ...]]:
    """The fields of each table of a system file of kind ``generic``, derived from the
    declared settings: ``""`` (top level), ``"aeb"``, ``"aeb.sensor"``, ``"aeb.warning"``,
    ``"aeb.partial"``, ``"aeb.full"``, ``"driver"``, ``"brake"``.
    """
    return {"": TOP_FIELDS, **table_fields(), "driver": fields_of(DriverParams),
            "brake": fields_of(BrakeActuatorParams)}


#: :func:`schema` as it is at import.
SCHEMA: dict[str, tuple[Field, ...]] = schema()


def _aeb_table(data: Mapping[str, Any], path: str, problems: list[DefinitionError]
               ) -> tuple[Mapping[str, Any] | None, str]:
    """The ``[aeb]`` table (None for ``aeb = false``) and its kind."""
    table = data.get("aeb")
    if table is False:
        return None, DEFAULT_KIND
    if table is None:
        problems.append(DefinitionError(
            path, "aeb", "no [aeb] table", "an [aeb] table, or aeb = false for a system "
            "without AEB (like none.toml)"))
        return None, DEFAULT_KIND
    if not isinstance(table, Mapping):
        problems.append(DefinitionError(path, "aeb", f"{table!r} is neither a table nor false",
                                        "an [aeb] table, or aeb = false"))
        return None, DEFAULT_KIND
    kind = table.get("kind", DEFAULT_KIND)
    if kind not in CONTROLLER_KINDS:
        problems.append(DefinitionError(path, "aeb.kind", f"{kind!r} is not allowed",
                                        "one of " + ", ".join(repr(k) for k in
                                                              CONTROLLER_KINDS)))
        return None, DEFAULT_KIND
    return table, str(kind)


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
        The system's name (default the file name without ``.toml``; a ``name`` in the
        file that differs from it is replaced by it, so that a copied file runs beside
        its original).

    Raises
    ------
    DefinitionError
        Naming the file, the field and the allowed range; several problems at once as
        :class:`vfs.errors.DefinitionErrors`.
    """
    p = str(path)
    problems: list[DefinitionError] = []
    top, found = read_table(data, TOP_FIELDS, path=p, extra=("aeb", "driver", "brake"))
    problems += found
    name = default_name or Path(p).stem
    aeb_table, kind = _aeb_table(data, p, problems)
    aeb = None
    if aeb_table is not None:
        aeb = CONTROLLER_KINDS.get(kind).read(aeb_table, p, problems)
    driver = None
    driver_table = data.get("driver")
    if driver_table is not None:
        values, found = read_table(driver_table, fields_of(DriverParams), path=p,
                                   where="driver.")
        problems += found
        if not found:
            driver = build(DriverParams, values, path=p, where="driver.", problems=problems)
    values, found = read_table(data.get("brake", {}), fields_of(BrakeActuatorParams),
                               path=p, where="brake.")
    problems += found
    brake = None if found else build(BrakeActuatorParams, values, path=p, where="brake.",
                                     problems=problems)
    raise_problems(problems)
    return AEBSystem(name=name, description=top.get("description", ""), aeb=aeb,
                     driver=driver, brake=brake, kind=kind)  # type: ignore[arg-type]


def load_system(path: str | os.PathLike[str]) -> AEBSystem:
    """The AEB system defined by a TOML file (see the module docstring and adas/README.md).

    Raises
    ------
    DefinitionError
        A missing file, invalid TOML, an unknown field, a wrong type, a value out of
        range or a broken rule between fields; each line names the file, the field and
        what is allowed (all problems of the file at once).
    """
    return system_from_dict(read_toml(path), path)


def readme_tables() -> str:
    """The field tables of adas/README.md, derived from the declared settings (a test
    checks that the README holds them; regenerate with
    ``python -c "from vfs.adas.definition import readme_tables; print(readme_tables())"``).
    """
    from vfs.adas.kinds.generic import STAGE_SETTINGS
    from vfs.adas.params import AEBParams, SensorParams
    from vfs.settings import markdown_table

    staged = [a for keys in STAGE_SETTINGS.values() for a in keys]
    kinds = ", ".join(f"`{k.name}` ({k.doc})" for k in CONTROLLER_KINDS.values())
    parts = ["### top level", "",
             "| key | allowed | default | meaning |", "|---|---|---|---|",
             "| `name` | text | the file name without .toml | the system's name is the file's "
             "name; a `name` that differs is replaced by it (so a copy runs beside its "
             "original) |",
             "| `description` | text | '' | one line for reports |",
             "| `aeb` | false | | `aeb = false`: a system without AEB; otherwise the [aeb] "
             "table is required |", "",
             "### [aeb]", "", f"`kind` (default `{DEFAULT_KIND}`) names the controller kind: "
             f"{kinds}. The fields below are those of `generic`.", "",
             markdown_table(AEBParams, exclude=staged), "",
             "### [aeb.sensor]", "", markdown_table(SensorParams)]
    for stage, keys in STAGE_SETTINGS.items():
        parts += ["", f"### [aeb.{stage}]", "",
                  markdown_table(AEBParams, include=tuple(keys), rename=keys,
                                 default_text={f"{stage}_ttc": "absent"})]
    for kind in CONTROLLER_KINDS.values():
        if kind.name != DEFAULT_KIND:
            parts += ["", f"### [aeb] with kind = \"{kind.name}\"", "", kind.doc + ".", "",
                      markdown_table(kind.params_type)]
    parts += ["", "### [driver]", "", markdown_table(DriverParams),
              "", "### [brake]", "", markdown_table(BrakeActuatorParams)]
    return "\n".join(parts)


def is_definition_path(spec: str) -> bool:
    """True when a ``--systems`` entry is a file path rather than a name."""
    return spec.endswith(".toml") or "/" in spec or os.sep in spec


__all__ = ["SCHEMA", "TOP_FIELDS", "AEBSystem", "is_definition_path", "load_system",
           "readme_tables", "schema", "system_from_dict"]
