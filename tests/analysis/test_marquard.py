"""Marquard's check of simulated cases (vfs.analysis.marquard)."""

from __future__ import annotations

import numpy as np


def test_the_check_on_simulated_cases(tmp_path):
    from vfs.analysis.marquard import marquard_check, summarise
    from vfs.scenarios.generator import generate_database
    from vfs.simulation import CaseBatch, simulate_cases

    db, _ = generate_database("clean", n_cases=30, seed=2)
    batch = CaseBatch.from_database(db)
    res = simulate_cases(batch)
    check = marquard_check(batch, res)
    n_hit = int((res.impact.impact_type > 0).sum())
    assert len(check) == 2 * n_hit
    # the model's speeds are the impulse model's post-impact speeds
    hit = np.flatnonzero(res.impact.impact_type > 0)
    v1 = np.hypot(res.impact.vx_post[hit, 0], res.impact.vy_post[hit, 0])
    np.testing.assert_allclose(check[check.vehicle == 1]["speed_model"], v1)
    table = summarise(check)
    assert table["n"].sum() == (np.isfinite(check.ratio) & (check.speed_model > 1.0)).sum()
