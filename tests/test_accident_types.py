"""The accident-type catalogue names every code the platform generates."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.accident_types import ACCIDENT_TYPES, accident_type_label, accident_type_name
from vfs.scenarios.catalogue import SCENARIO_TYPES
from vfs.scenarios.generator import PRESETS


def test_every_generated_code_has_a_name() -> None:
    codes = set(SCENARIO_TYPES)
    for preset in PRESETS.values():
        codes |= set(preset.type_shares)
    missing = sorted(c for c in codes if c not in ACCIDENT_TYPES)
    assert not missing, missing
    # the scene catalogue uses the same names (one source)
    for code, spec in SCENARIO_TYPES.items():
        assert spec.name == ACCIDENT_TYPES[code]


@pytest.mark.parametrize("value", [241, np.int64(241), 241.0, "241", np.float64(241.0)])
def test_label_accepts_every_spelling_of_a_code(value: object) -> None:
    assert accident_type_label(value) == "241 head-on, straight road"
    assert accident_type_name(value) == "head-on, straight road"


@pytest.mark.parametrize("value", ["all", "unknown", 999, 241.5, None, True])
def test_non_codes_and_unknown_codes_stay_as_text(value: object) -> None:
    assert accident_type_label(value) == str(value)
