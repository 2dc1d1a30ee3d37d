"""The optional dependencies of the file exchange (extra ``xosc``), imported lazily."""

from __future__ import annotations

import importlib
from types import ModuleType

from vfs.errors import MissingExtraError

__all__ = ["EXTRA", "EXTRA_PACKAGES", "require_extra"]

#: Name of the optional extra (``pip install "vfs-accident[xosc]"``).
EXTRA = "xosc"
#: Import name -> distribution name of the packages of the extra.
EXTRA_PACKAGES: dict[str, str] = {"scenariogeneration": "scenariogeneration",
                                  "xmlschema": "xmlschema"}


def require_extra(module: str) -> ModuleType:
    """Import ``module`` (e.g. ``"scenariogeneration.xosc"``) of the ``xosc`` extra.

    Raises
    ------
    MissingExtraError
        The package is not installed; the message says how to install it.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        raise MissingExtraError(
            f"{EXTRA_PACKAGES.get(top, top)} is needed for OpenSCENARIO/OpenDRIVE files and "
            f"is not installed ({exc}); install the optional extra: pip install "
            f'"vfs-accident[{EXTRA}]"') from None
