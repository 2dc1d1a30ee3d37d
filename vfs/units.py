"""Unit conversions used at the edges (reports, CLI); everything inside is SI."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

KMH_PER_MS = 3.6  # [km/h per m/s]
G = 9.80665  # standard gravity [m/s^2]


def kmh_to_ms(speed_kmh: npt.ArrayLike) -> np.ndarray:
    """Convert a speed from km/h to m/s."""
    return np.asarray(speed_kmh, dtype=float) / KMH_PER_MS


def ms_to_kmh(speed_ms: npt.ArrayLike) -> np.ndarray:
    """Convert a speed from m/s to km/h."""
    return np.asarray(speed_ms, dtype=float) * KMH_PER_MS


def wrap_axial(angle_rad: npt.ArrayLike) -> np.ndarray:
    """Wrap an axial angle [rad] (a direction modulo pi, e.g. a difference of
    contact-plane angles) to the interval [-pi/2, pi/2).
    """
    a = np.asarray(angle_rad, dtype=float)
    return (a + 0.5 * np.pi) % np.pi - 0.5 * np.pi


def wrap_angle(angle_rad: npt.ArrayLike) -> np.ndarray:
    """Wrap an angle [rad] to the interval (-pi, pi]."""
    a = np.asarray(angle_rad, dtype=float)
    wrapped = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped == -np.pi, np.pi, wrapped)
