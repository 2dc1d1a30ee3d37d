"""Fixtures of the physics tests."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from vfs.physics.numba_support import AVAILABLE, ENV_SWITCH

#: The run-out paths: the compiled kernel (the product path) and its numpy reference.
RUNOUT_PATHS = ["compiled", "numpy"] if AVAILABLE else ["numpy"]


@pytest.fixture(scope="module", params=RUNOUT_PATHS, autouse=False)
def both_runout_paths(request: pytest.FixtureRequest) -> Iterator[str]:
    """Run a module's tests on the compiled run-out and again on the numpy reference
    (``VFS_COMPILED`` 1, then 0; module scope, so that hypothesis tests take it too).
    """
    before = os.environ.get(ENV_SWITCH)
    os.environ[ENV_SWITCH] = "1" if request.param == "compiled" else "0"
    yield request.param
    if before is None:
        os.environ.pop(ENV_SWITCH, None)
    else:
        os.environ[ENV_SWITCH] = before
