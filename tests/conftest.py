"""Shared test configuration.

Slow, exhaustive tests are marked ``slow``; they run at a reduced size by default
(environment variable VFS_SLOW_SCALE, default 0.2, as in CI); ``VFS_SLOW_SCALE=1`` runs
them at full size (about twice the suite's time).
"""

from __future__ import annotations

import logging
import os

import pytest
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


class _Collected(logging.Handler):
    """Keeps the records it is handed."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@pytest.fixture
def vfs_log(monkeypatch: pytest.MonkeyPatch) -> list[logging.LogRecord]:
    """The records of the ``vfs`` loggers at INFO and above during the test, each once.

    The ``vfs`` logger gets this one handler and does not propagate: independent of a
    command run earlier in the same process (``configure_logging`` leaves a handler on a
    stream that pytest has closed since) and of the handlers on the root logger.
    """
    collected = _Collected()
    logger = logging.getLogger("vfs")
    monkeypatch.setattr(logger, "handlers", [collected])
    monkeypatch.setattr(logger, "propagate", False)
    level = logger.level
    logger.setLevel(logging.INFO)
    yield collected.records
    logger.setLevel(level)
