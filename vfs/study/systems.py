"""AEB systems as a study sees them: the protocol and the lookup by name."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from vfs.errors import ParameterError
from vfs.physics.precrash import BrakeController, PrecrashParams
from vfs.simulation import CaseBatch
from vfs.study.layout import BASELINE


class AEBSystem(Protocol):
    """What a study needs from an AEB system (``vfs.adas.get_system(name)`` returns one).

    It must be picklable (it is sent to the worker processes).
    """

    name: str
    description: str

    def controller(self, batch: CaseBatch, equipped: np.ndarray) -> BrakeController | None:
        """Controller for the cases of ``batch``; ``equipped`` (N, 2) bool."""

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """Pre-crash settings with this system's brake actuator."""


SystemRegistry = Mapping[str, Any] | Callable[[str], Any]


def resolve_system(name: str, registry: SystemRegistry | None = None) -> AEBSystem:
    """Look up an AEB system by name.

    Parameters
    ----------
    name : str
        System name, e.g. ``"three-stage"``, or the path of a definition file
        (``adas/my-aeb.toml``).
    registry : mapping or callable, optional
        Where to look: a ``{name: system}`` mapping or a ``name -> system``
        function; default :func:`vfs.adas.find_system` (a definition file, the
        project's ``adas/<name>.toml``, then the registered systems).

    Returns
    -------
    AEBSystem

    Raises
    ------
    ParameterError
        Unknown name, or the systems package is not installed.
    """
    if registry is None:
        from vfs.adas import find_system

        registry = find_system
    if isinstance(registry, Mapping):
        if name not in registry:
            raise ParameterError(f"unknown system {name!r}; known: {', '.join(registry)}")
        system = registry[name]
    else:
        try:
            system = registry(name)
        except KeyError:
            raise ParameterError(f"unknown system {name!r}") from None
    for attr in ("name", "controller", "precrash_params"):
        if not hasattr(system, attr):
            raise ParameterError(f"system {name!r} ({type(system).__name__}) has no {attr!r}")
    return system


def resolve_systems(systems: Sequence[str | Any] | str,
                    registry: SystemRegistry | None) -> list[Any]:
    """System objects for names or objects (``"a,b"`` also works), checked and unique.

    Raises
    ------
    ParameterError
        Unknown names, objects that are not systems, duplicates, none at all,
        or the reserved name ``"baseline"``.
    """
    if isinstance(systems, str):
        systems = [s.strip() for s in systems.split(",") if s.strip()]
    resolved = [resolve_system(s, registry) if isinstance(s, str) else s for s in systems]
    if not resolved:
        raise ParameterError("no system given: name at least one, e.g. 'three-stage'")
    for s in resolved:
        if not (isinstance(getattr(s, "name", None), str)
                and callable(getattr(s, "controller", None))
                and callable(getattr(s, "precrash_params", None))):
            raise ParameterError(f"{s!r} is not an AEB system: it needs a name, controller() "
                                 "and precrash_params()")
    names = [s.name for s in resolved]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ParameterError(f"system(s) given twice: {', '.join(dupes)}")
    if BASELINE in names:
        raise ParameterError(f"{BASELINE!r} is reserved for the runs without a system")
    return resolved




__all__ = ["AEBSystem", "SystemRegistry", "resolve_system", "resolve_systems"]
