"""Shared helpers of the tests that hold a compiled kernel against its numpy reference:
generated cases of every accident type, and the fields of two results that differ."""

from __future__ import annotations

import dataclasses

import numpy as np

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
