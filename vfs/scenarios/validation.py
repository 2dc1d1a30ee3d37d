"""Argument checks shared by the scene catalogue, the fleet and the scene generator."""

from __future__ import annotations

import math

import numpy as np

from vfs.errors import ParameterError


def check_range(name: str, value: object, lo: float = -math.inf,
                hi: float = math.inf) -> None:
    """ParameterError unless ``value`` is a finite (low, high) pair with lo <= low <= high <= hi."""
    ok = (isinstance(value, tuple) and len(value) == 2
          and all(isinstance(v, int | float) and math.isfinite(v) for v in value))
    if not ok or not lo <= value[0] <= value[1] <= hi:
        raise ParameterError(f"{name}={value!r} must be a (low, high) pair with "
                             f"{lo:g} <= low <= high <= {hi:g}")


def check_share(name: str, value: object) -> None:
    """ParameterError unless ``value`` is a share [-] in [0, 1]."""
    if not (isinstance(value, int | float) and 0.0 <= value <= 1.0):
        raise ParameterError(f"{name}={value!r} must be a share in [0, 1]")


def check_rng(rng: object) -> None:
    """ParameterError unless ``rng`` is a numpy.random.Generator."""
    if not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")


def check_count(n: object, name: str = "n") -> int:
    """``n`` as int; ParameterError unless an integer >= 0."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
        raise ParameterError(f"{name}={n!r} must be an integer >= 0")
    return int(n)
