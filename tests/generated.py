"""Shared helpers of the tests that hold a compiled kernel against its numpy reference:
generated cases of every accident type, and the fields of two results that differ."""

from __future__ import annotations

import dataclasses

import numpy as np

from vfs.physics.post_impact import PostImpactInputs
from vfs.scenarios.generator import generate_database, get_preset
from vfs.scenarios.scenes import SCENARIO_TYPES
from vfs.simulation import CaseBatch


def cases_of_every_type(per_type: int, seed: int, near_miss_share: float) -> CaseBatch:
    """``per_type`` generated cases of each accident type of the generator (default
    preset, no hidden effects), ``near_miss_share`` of them near misses."""
    preset = dataclasses.replace(get_preset("default"),
                                 type_shares={code: 1.0 for code in SCENARIO_TYPES},
                                 near_miss_share=near_miss_share, hidden=())
    db, _ = generate_database(preset, n_cases=per_type * len(SCENARIO_TYPES), seed=seed)
    assert set(db.cases["accident_type"]) == set(SCENARIO_TYPES)
    return CaseBatch.from_database(db)


def with_random_wheel_inputs(cases: CaseBatch, seed: int) -> CaseBatch:
    """``cases`` with random post-impact wheel inputs drawn from ``default_rng(seed)``:
    wheel brake factors (about a third locked), driver braking, wheel drag, steer angle
    [rad] and its onset [s], each given for 40-50 % of the vehicles or wheels (NaN there:
    the default)."""
    n = cases.size
    rng = np.random.default_rng(seed)

    def some(a: np.ndarray, share: float) -> np.ndarray:
        return np.where(rng.random(a.shape) < share, a, np.nan)

    brake = rng.uniform(0, 1, (n, 2, 4))
    brake[rng.random((n, 2, 4)) < 0.3] = 1.0
    post = PostImpactInputs(some(brake, 0.5), some(rng.uniform(0, 1, (n, 2)), 0.5),
                            some(rng.uniform(0, 0.3, (n, 2, 4)), 0.4),
                            some(rng.uniform(-1.0, 1.0, (n, 2)), 0.5),
                            some(rng.uniform(0, 2, (n, 2)), 0.5))
    return cases._replace(post_impact=post)


def bit_differences(ref: object, got: object, path: str = "") -> list[str]:
    """Names of the fields (recursively in named tuples and dicts) that are not equal bit
    for bit (NaN equal to NaN)."""
    if isinstance(ref, dict):
        assert isinstance(got, dict) and ref.keys() == got.keys()
        return [d for k in ref for d in bit_differences(ref[k], got[k], f"{path}{k}.")]
    if hasattr(ref, "_fields"):
        return [d for name, a, b in zip(ref._fields, ref, got, strict=True)
                for d in bit_differences(a, b, f"{path}{name}.")]
    x, y = np.asarray(ref), np.asarray(got)
    if x.shape != y.shape or not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
        return [path.rstrip(".")]
    return []
