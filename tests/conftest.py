"""Shared test configuration.

Slow, exhaustive tests are marked ``slow``; they run at a reduced size by default
(environment variable VFS_SLOW_SCALE, default 0.2, as in CI); ``VFS_SLOW_SCALE=1`` runs
them at full size (about twice the suite's time).
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "dev", max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


def slow_scale() -> float:
    """Fraction of the full size that slow tests run at (VFS_SLOW_SCALE, default 0.2)."""
    return float(os.environ.get("VFS_SLOW_SCALE", "0.2"))
