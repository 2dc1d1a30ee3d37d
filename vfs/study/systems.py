"""AEB systems as a study takes them: the ``--systems`` list, looked up and checked.

The contract a system keeps is :class:`vfs.adas.contract.System` (one Protocol for
the whole way from ``--systems`` to the simulation).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from vfs.adas.contract import System, require_system
from vfs.errors import ParameterError
from vfs.study.layout import BASELINE

#: Where a study looks systems up: a ``{name: system}`` mapping or a ``name -> system``
#: function.
SystemRegistry = Mapping[str, System] | Callable[[str], System]


def split_systems(systems: str | Sequence[str | System]) -> list[str | System]:
    """The entries of a ``--systems`` list: ``"a, b"`` split on commas (blanks dropped);
    a sequence of names or system objects as it is.
    """
    if isinstance(systems, str):
        return [s.strip() for s in systems.split(",") if s.strip()]
    return list(systems)


def resolve_system(name: str, registry: SystemRegistry | None = None) -> System:
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
    System

    Raises
    ------
    ParameterError
        Unknown name, or an object that is not a system (naming what it lacks).
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
    return require_system(system, f"system {name!r} ({type(system).__name__})")


def resolve_systems(systems: Sequence[str | System] | str,
                    registry: SystemRegistry | None) -> list[System]:
    """System objects for names or objects (``"a,b"`` also works), checked and unique.

    Raises
    ------
    ParameterError
        Unknown names, objects that are not systems, duplicates, none at all,
        or the reserved name ``"baseline"``.
    """
    resolved = [resolve_system(s, registry) if isinstance(s, str) else require_system(s)
                for s in split_systems(systems)]
    if not resolved:
        raise ParameterError("no system given: name at least one, e.g. 'three-stage'")
    names = [s.name for s in resolved]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ParameterError(f"system(s) given twice: {', '.join(dupes)}")
    if BASELINE in names:
        raise ParameterError(f"{BASELINE!r} is reserved for the runs without a system")
    return resolved


__all__ = ["SystemRegistry", "resolve_system", "resolve_systems", "split_systems"]
