"""Uncertainty of the collision outcomes: Monte-Carlo bands, Sobol sensitivity and
reconstruction as an inverse problem (docs/uncertainty.md)."""

from vfs.uncertainty.core import *  # noqa: F403
from vfs.uncertainty.core import __all__  # noqa: F401
