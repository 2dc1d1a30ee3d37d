"""Build step that puts the catalogue folders into the wheel (metadata: pyproject.toml).

The repository root holds ``adas/`` (AEB system definitions) and ``scenarios/`` (generator
presets, accident-type designs, bundled databases): one source, edited there.  A clone or an
editable install reads them in place (``vfs.catalog``); a wheel carries a copy at
``vfs/data/catalog/<folder>``, made here when the package is built, which ``vfs.catalog``
finds with ``importlib.resources``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

#: The catalogue folders and where a wheel holds them (must match vfs.catalog).
CATALOGS = ("adas", "scenarios")
PACKAGED = ("vfs", "data", "catalog")


class BuildPyWithCatalog(build_py):
    """``build_py`` plus a copy of the catalogue folders into the built package."""

    def run(self) -> None:
        """Build the package, then copy ``adas/`` and ``scenarios/`` below it."""
        super().run()
        if getattr(self, "editable_mode", False):
            return  # an editable install reads the folders in place
        root = Path(__file__).resolve().parent
        target = Path(self.build_lib).joinpath(*PACKAGED)
        for folder in CATALOGS:
            source = root / folder
            if not source.is_dir():
                raise FileNotFoundError(f"{source} missing: the catalogue is part of vfs")
            shutil.rmtree(target / folder, ignore_errors=True)  # no stale files of a former build
            shutil.copytree(source, target / folder,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))


setup(cmdclass={"build_py": BuildPyWithCatalog})
