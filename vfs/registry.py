"""One registry type for every named, pluggable thing of vfs.

Effects, AEB systems, injury-risk curves, study executors and benchmarks are
each kept in a :class:`Registry`: a name -> object mapping with one way to add
(``add`` or the ``register`` decorator), one way to look up (``get``, whose
error lists the known names) and, optionally, a Python entry-point group from
which third-party packages add entries when the registry is first read.

>>> r = Registry[int]("number")
>>> r.add("one", 1)
1
>>> r.get("one")
1
>>> r.get("two")
Traceback (most recent call last):
...
vfs.errors.ParameterError: unknown number 'two'; known: one
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import Generic, TypeVar

from vfs.errors import ParameterError

T = TypeVar("T")


class Registry(Mapping[str, T], Generic[T]):
    """Named objects of one kind, in registration order.

    Parameters
    ----------
    kind : str
        What the entries are, for messages (``"effect"``, ``"AEB system"``).
    entry_point_group : str, optional
        Entry-point group whose entries are loaded (once) when the registry
        is first read; each entry point's object is passed to ``add`` under
        the entry point's name unless that name is taken.
    check : callable, optional
        ``check(name, obj)`` raising :class:`ParameterError` for an object
        that may not be registered.
    same : callable, optional
        ``same(old, new)``: True when ``new`` may silently replace ``old``
        of the same name (e.g. a module reloaded); default identity or
        equality.
    """

    def __init__(self, kind: str, *, entry_point_group: str | None = None,
                 check: Callable[[str, T], None] | None = None,
                 same: Callable[[T, T], bool] | None = None) -> None:
        self.kind = kind
        self.entry_point_group = entry_point_group
        self._check = check
        self._same = same
        self._items: dict[str, T] = {}
        self._entry_points_loaded = entry_point_group is None

    # ------------------------------------------------------------------ adding

    def add(self, name: str, obj: T, *, replace: bool = False) -> T:
        """Register ``obj`` under ``name`` and return it.

        Raises
        ------
        ParameterError
            If the name is taken by another object and ``replace`` is False,
            or ``check`` rejects the object.
        """
        if not isinstance(name, str) or not name:
            raise ParameterError(f"a {self.kind} needs a non-empty name, got {name!r}")
        if self._check is not None:
            self._check(name, obj)
        old = self._items.get(name)
        if old is not None and not replace and not self._is_same(old, obj):
            raise ParameterError(f"a {self.kind} named {name!r} is already registered")
        self._items[name] = obj
        return obj

    def register(self, name: str, *, replace: bool = False) -> Callable[[T], T]:
        """Decorator form of :meth:`add`."""

        def wrap(obj: T) -> T:
            return self.add(name, obj, replace=replace)

        return wrap

    def remove(self, name: str) -> None:
        """Remove an entry if present (for tests and interactive use)."""
        self._items.pop(name, None)

    def _is_same(self, old: T, new: T) -> bool:
        if self._same is not None:
            return self._same(old, new)
        return old is new or bool(old == new)

    # ---------------------------------------------------------------- reading

    def _load_entry_points(self) -> None:
        if self._entry_points_loaded:
            return
        self._entry_points_loaded = True
        for ep in metadata.entry_points(group=str(self.entry_point_group)):
            if ep.name in self._items:
                continue
            try:
                obj = ep.load()
            except Exception as exc:  # a broken plugin is reported, not hidden
                raise ParameterError(f"{self.kind} entry point {ep.name!r} ({ep.value}) "
                                     f"failed to load: {exc}") from exc
            self.add(ep.name, obj)

    def get(self, name: str) -> T:  # type: ignore[override]  # raises instead of default
        """The entry ``name``.

        Raises
        ------
        ParameterError
            Naming the known entries if there is none of that name.
        """
        self._load_entry_points()
        try:
            return self._items[name]
        except (KeyError, TypeError):
            raise ParameterError(f"unknown {self.kind} {name!r}; known: "
                                 f"{', '.join(self._items) or '(none)'}") from None

    def names(self) -> tuple[str, ...]:
        """Registered names in registration order."""
        self._load_entry_points()
        return tuple(self._items)

    def __getitem__(self, name: str) -> T:
        return self.get(name)

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        self._load_entry_points()
        return len(self._items)

    def __contains__(self, name: object) -> bool:
        self._load_entry_points()
        return name in self._items

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._items)})"


__all__ = ["Registry"]


def import_file(path: str | os.PathLike[str], what: str = "") -> ModuleType:
    """Import a user's Python file once per process, as module ``vfs_plugin_<stem>``.

    Importing it registers what it registers (effects, systems, executors); a second call
    returns the module already imported.  ``what`` prefixes the error messages (e.g.
    ``"--plugin x.py"``; default the path).

    Raises
    ------
    ParameterError
        A file that does not exist or cannot be imported as Python.
    """
    import importlib.util
    import sys

    file = Path(path)
    label = what or str(file)
    name = f"vfs_plugin_{file.stem}"
    module = sys.modules.get(name)
    if module is not None:
        return module
    if not file.is_file():
        raise ParameterError(f"{label}: no such file")
    spec = importlib.util.spec_from_file_location(name, file)
    if spec is None or spec.loader is None:
        raise ParameterError(f"{label}: cannot import")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except Exception:
        del sys.modules[name]
        raise
    return module
