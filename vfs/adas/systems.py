"""Generic AEB systems: a registry of named presets.

An :class:`AEBSystem` bundles the AEB logic and sensor (:class:`AEBParams`),
the reaction of the equipped vehicle's driver (:class:`DriverParams`) and the
brake actuator (:class:`vfs.physics.precrash.BrakeActuatorParams`).  The built-in
presets (:data:`SYSTEM_NAMES`; sources in docs/aeb.md and docs/references.md) are the
definition files ``adas/<name>.toml`` (:mod:`vfs.adas.definition`, read through
:mod:`vfs.catalog`; the numbers live there only):

``none``
    No AEB; the record is replayed.
``openpass-like``
    openPASS Algorithm_AEB: one stage, full braking at 6 m/s^2 as a step
    when the TTC of the outlines enlarged by 4.0 m / 1.5 m falls to 2.0 s,
    released when it exceeds 1.5 x 2.0 s; sensor 150 m, 0.35 rad, latency 0;
    no driver reaction.
``three-stage``
    Warning at TTC 2.6 s, partial braking (4 m/s^2, about 40 %) at 1.6 s,
    full braking (friction limit) at 0.6 s, held to standstill; jerk-limited
    build-up (40 m/s^3); sensor 150 m, 0.35 rad, 20 Hz, latency 0.1 s;
    CTRV prediction; the driver (Gamma(7, 7) s reaction, 0.2 s lag, 70 %
    brake at N(6.4, 1) m/s^2 on [3, 9]) reacts to the warning.
``ideal``
    Perfect 360 deg sensor without latency, decision every step; instant
    full braking at the friction limit at the last moment that still
    avoids the contact under the CV prediction; held to standstill.

Also registered (not in :data:`SYSTEM_NAMES`): ``ideal-ctra``, the ideal
system with the CTRA prediction (path curvature and acceleration kept),
which also handles braking leads and turning objects.

:func:`register_system` adds user systems; :func:`get_system` looks one up by name;
:func:`find_system` takes what ``vfs study --systems`` takes: a definition file, a name in
the project's ``adas/`` folder, or a registered name.
"""

from __future__ import annotations

import os
from pathlib import Path

from vfs.adas.contract import System, contract_problems, require_system
from vfs.adas.definition import (
    AEBSystem,  # noqa: F401  (re-exported, as before)
    is_definition_path,
    load_system,
)
from vfs.catalog import catalog_path, project_path
from vfs.errors import ParameterError
from vfs.registry import Registry

# ----------------------------------------------------------------------------
# Presets: the files adas/<name>.toml (one source; vfs.catalog finds them)
# ----------------------------------------------------------------------------


def builtin_definition(name: str) -> Path:
    """The definition file of the built-in system ``name`` (``adas/<name>.toml``)."""
    return catalog_path("adas", f"{name}.toml")


NONE = load_system(builtin_definition("none"))
OPENPASS_LIKE = load_system(builtin_definition("openpass-like"))
THREE_STAGE = load_system(builtin_definition("three-stage"))
IDEAL = load_system(builtin_definition("ideal"))
IDEAL_CTRA = load_system(builtin_definition("ideal-ctra"))

#: Names of the built-in systems.
SYSTEM_NAMES: tuple[str, ...] = ("none", "openpass-like", "three-stage", "ideal")

def _check_system(name: str, system: System) -> None:
    require_system(system, f"register_system({type(system).__name__} object)")
    if name != system.name:
        raise ParameterError(f"AEB system {system.name!r} registered as {name!r}")


#: AEB systems by name (the built-in presets first); add one with :func:`register_system`.
SYSTEMS: Registry[System] = Registry("AEB system", entry_point_group="vfs.systems",
                                     check=_check_system)
for _system in (NONE, OPENPASS_LIKE, THREE_STAGE, IDEAL, IDEAL_CTRA):
    SYSTEMS.add(_system.name, _system)


def register_system(system: System) -> System:
    """Add ``system`` to :data:`SYSTEMS` under its name and return it.

    Raises
    ------
    ParameterError
        If the name is taken by a different system.
    """
    _check_system(getattr(system, "name", ""), system)
    return SYSTEMS.add(system.name, system)


def get_system(name: str) -> System:
    """The registered system ``name``.

    Raises
    ------
    ParameterError
        Listing the known names if there is none of that name.
    """
    return SYSTEMS.get(name)


def system_names() -> tuple[str, ...]:
    """Names of all registered systems (built-in first, then in registration order)."""
    return SYSTEMS.names()


def find_system(spec: str, *, cwd: str | os.PathLike[str] | None = None) -> System:
    """An AEB system by name or definition file, as ``vfs study --systems`` takes them.

    Parameters
    ----------
    spec : str
        A path of a definition file (ends in ``.toml`` or holds a ``/``; relative to
        ``cwd``), or a name.  A name is looked up (1) in the project's ``adas/`` folder,
        ``<cwd>/adas/<name>.toml``, then (2) among the registered systems: the built-ins
        and those added by :func:`register_system` or a ``--plugin`` module.
    cwd : path, optional
        The project folder; default the current working directory.

    Raises
    ------
    DefinitionError
        For a definition file that is missing or wrong (names file, field and range).
    ParameterError
        For an unknown name (listing the known ones).
    """
    if is_definition_path(spec):
        path = Path(spec)
        if not path.is_absolute() and cwd is not None:
            path = Path(cwd) / path
        return load_system(path)
    own = project_path("adas", f"{spec}.toml", cwd=cwd)
    if own is not None and own.is_file():
        return load_system(own)
    return get_system(spec)


def python_system(path: str | os.PathLike[str], attribute: str = "SYSTEM") -> System:
    """The system ``attribute`` of a user's Python file (imported once per process).

    A user-written controller (``adas/example_controller.py``) pickles itself as a call of
    this function, so the worker processes of a study import the same file by path.

    Raises
    ------
    ParameterError
        A missing file or one without ``attribute``.
    """
    from vfs.registry import import_file

    file = Path(path).resolve()
    module = import_file(file)
    system = getattr(module, attribute, None)
    if system is None or contract_problems(system):
        raise ParameterError(f"{file}: {attribute} is not an AEB system")
    return system
