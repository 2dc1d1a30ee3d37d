"""Controller kinds: what the ``kind`` of a system file's ``[aeb]`` table names.

A :class:`ControllerKind` reads its ``[aeb]`` table (the parameters, with every
problem of the table reported at once) and builds the controller of a batch
from them.  The kinds are kept in :data:`CONTROLLER_KINDS`:

* the modules of this package register theirs when it is imported (``generic``,
  the staged AEB of :mod:`vfs.adas.controller`, is the default): a new kind in
  vfs is one new module here, its test and its docs;
* another package adds one through the entry-point group ``vfs.controller_kinds``
  (its object a :class:`ControllerKind`), without editing vfs.

:func:`flat_kind` makes a kind whose ``[aeb]`` table holds the declared settings
(:mod:`vfs.settings`) of one parameter dataclass.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy.typing as npt

from vfs.errors import DefinitionError
from vfs.registry import Registry
from vfs.settings import build, fields_of, read_table

if TYPE_CHECKING:
    from vfs.adas.contract import SystemController
    from vfs.adas.params import DriverParams
    from vfs.physics.braking import BrakeActuatorParams
    from vfs.simulation import CaseBatch

#: ``read(table, path, problems) -> params or None``: the parameters of an ``[aeb]``
#: table (``kind`` left out), its problems appended to ``problems``.
Reader = Callable[[Mapping[str, Any], str, list[DefinitionError]], Any]

#: ``build(batch, equipped, params, driver, brake) -> controller``.
Builder = Callable[["CaseBatch", npt.ArrayLike, Any, "DriverParams | None",
                    "BrakeActuatorParams"], "SystemController"]

#: The kind of an ``[aeb]`` table without ``kind``.
DEFAULT_KIND = "generic"


@dataclass(frozen=True)
class ControllerKind:
    """One kind of controller a system file can name.

    Attributes
    ----------
    name : str
        The value of ``kind`` in ``[aeb]``.
    doc : str
        One line for the docs and messages.
    read : Reader
        The parameters of an ``[aeb]`` table.
    build : Builder
        The controller of a batch.
    params_type : type
        The class of the parameters ``read`` returns.
    """

    name: str
    doc: str
    read: Reader
    build: Builder
    params_type: type


def _check_kind(name: str, kind: ControllerKind) -> None:
    from vfs.errors import ParameterError

    if not isinstance(kind, ControllerKind):
        raise ParameterError(f"controller kind {name!r} must be a ControllerKind, got "
                             f"{type(kind).__name__}")
    if kind.name != name:
        raise ParameterError(f"controller kind {kind.name!r} registered as {name!r}")


#: Controller kinds by name; entry-point group ``vfs.controller_kinds``.
CONTROLLER_KINDS: Registry[ControllerKind] = Registry(
    "controller kind", entry_point_group="vfs.controller_kinds", check=_check_kind)


def flat_kind(name: str, doc: str, params_type: type, build_: Builder) -> ControllerKind:
    """A kind whose ``[aeb]`` table holds the declared settings of ``params_type``."""

    def read(table: Mapping[str, Any], path: str, problems: list[DefinitionError]) -> Any:
        values, found = read_table(table, fields_of(params_type), path=path, where="aeb.",
                                   extra=("kind",))
        problems += found
        return None if found else build(params_type, values, path=path, where="aeb.",
                                        problems=problems)

    return ControllerKind(name, doc, read, build_, params_type)


def register_kind(kind: ControllerKind) -> ControllerKind:
    """Add ``kind`` to :data:`CONTROLLER_KINDS` under its name and return it."""
    return CONTROLLER_KINDS.add(kind.name, kind)


for _module in sorted(m.name for m in pkgutil.iter_modules([os.path.dirname(__file__)])):
    importlib.import_module(f"{__name__}.{_module}")

__all__ = ["CONTROLLER_KINDS", "DEFAULT_KIND", "Builder", "ControllerKind", "Reader",
           "flat_kind", "register_kind"]
