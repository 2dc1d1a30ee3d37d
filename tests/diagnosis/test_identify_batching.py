"""The identification of several channels runs their grids and refinement steps together
(one stacked simulation per step, :func:`vfs.diagnosis.identify.identify`): each case's
result must not depend on which other channels share its simulations.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from vfs.diagnosis.calibrate import CalibrationData, VariantSimulator
from vfs.diagnosis.identify import identify
from vfs.scenarios.generator import generate_database

CHANNELS = ["restitution", "penetration_time", "runout_brake1", "yaw_inertia_factor"]


def test_channels_identified_together_equal_each_identified_alone():
    db, _ = generate_database("default", n_cases=16, seed=8)
    data = CalibrationData.from_database(db)
    sim = VariantSimulator(data)
    together = identify(data, CHANNELS, grid_points=5, sim=sim)
    calls_alone = 0
    for name in CHANNELS:
        own = VariantSimulator(data)
        alone = identify(data, [name], grid_points=5, sim=own)
        calls_alone += own.n_calls
        part = together[together["channel"] == name].reset_index(drop=True)
        # bit for bit: the values tried, their simulations and the intervals are the same
        pd.testing.assert_frame_equal(part, alone, check_exact=True)
    # the base run, one grid call per pre-crash kind, one per refinement step and kind
    assert sim.n_calls < calls_alone
    assert np.isfinite(together["value"]).all()
