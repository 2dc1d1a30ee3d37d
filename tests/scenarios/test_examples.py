"""The bundled example impact table is what vfs/scenarios/examples.py builds, and solves."""

from __future__ import annotations

import numpy as np
import pandas as pd

from vfs.database.impact_table import solve_impact_table
from vfs.scenarios.examples import EXAMPLE_IMPACTS, example_impact_table


def test_bundled_table_is_current():
    bundled = pd.read_csv(EXAMPLE_IMPACTS)
    built = example_impact_table()
    assert list(bundled.columns) == list(built.columns)
    np.testing.assert_allclose(bundled.to_numpy(float), built.to_numpy(float), rtol=1e-10)


def test_examples_solve_with_the_expected_pattern():
    out = solve_impact_table(example_impact_table())
    # full overlap -> full impact; 25 % overlap at 80/80 km/h -> sliding (the Momentum Based
    # Impact Model paper pattern)
    assert out.loc[0, "impact_type"] == "full" and out.loc[2, "impact_type"] == "sliding"
    assert out.loc[2, "delta_v1"] < 0.5 * out.loc[0, "delta_v1"]
