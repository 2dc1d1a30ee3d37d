"""solve_impact gives bit-identical results whatever its block size (elementwise only)."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics import impact
from vfs.scenarios.random import random_impact_configs


@pytest.mark.parametrize("mode", ["impulse", "normal"])
def test_block_size_does_not_change_results(monkeypatch: pytest.MonkeyPatch, mode: str) -> None:
    config = random_impact_configs(np.random.default_rng(5), 3_000)
    whole = impact.solve_impact(config, restitution_mode=mode)
    monkeypatch.setattr(impact, "CHUNK", 257)  # 12 blocks, the last one partial
    blocked = impact.solve_impact(config, restitution_mode=mode)
    for name, a, b in zip(whole._fields, whole, blocked, strict=True):
        np.testing.assert_array_equal(a, b, err_msg=name)
