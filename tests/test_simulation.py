"""End-to-end case simulation: batch = single, mirror symmetry, run-case CLI."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.cli import main
from vfs.errors import ParameterError
from vfs.physics.paths import PathArrays
from vfs.physics.precrash import ScheduledBraking
from vfs.physics.runout import RunoutMemo
from vfs.scenarios.examples import example_case_database
from vfs.scenarios.random import synthetic_case_batch
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases


def mirrored(batch: CaseBatch) -> CaseBatch:
    """Mirror every case about the x axis: y -> -y, yaw -> -yaw."""
    k = batch.paths.knots.copy()
    from vfs.physics.paths import KNOT_FIELDS

    for name in ("y", "yaw", "heading"):
        k[..., KNOT_FIELDS.index(name)] *= -1.0
    p = batch.paths
    paths = PathArrays(k, p.count, p.t0, -p.end_curvature)
    return batch._replace(paths=paths)


def test_example_case_runs_to_rest():
    batch = CaseBatch.from_database(example_case_database())
    res = simulate_cases(batch)
    table = results_table(batch, res)
    row = table.iloc[0]
    assert row["collided"] and row["impact_type"] in ("full", "sliding")
    assert row["at_rest1"] and row["at_rest2"]
    assert row["impact_speed1"] == pytest.approx(60 / 3.6, rel=1e-6)
    # momentum is exchanged, not created: the heavier car's delta-v is smaller
    assert row["delta_v1"] < row["delta_v2"]


def test_batch_equals_single_for_the_whole_chain():
    batch = synthetic_case_batch(12, np.random.default_rng(5))
    start = np.c_[np.where(np.arange(12) % 2 == 0, 4.0, np.nan), np.full(12, np.nan)]
    dec = np.c_[np.full(12, 9.0), np.zeros(12)]
    full = results_table(batch, simulate_cases(batch, ScheduledBraking(start, dec)))
    for k in (0, 3, 7, 11):
        one = results_table(batch.take([k]),
                            simulate_cases(batch.take([k]),
                                           ScheduledBraking(start[k:k + 1], dec[k:k + 1])))
        a = one.iloc[0]
        b = full.iloc[k]
        for col in ("contact_time", "delta_v1", "ees2", "rest_x1", "rest_y2", "rest_yaw1",
                    "min_distance"):
            assert (a[col] == b[col]) or (np.isnan(a[col]) and np.isnan(b[col])), col


def test_outcome_only_runs_equal_the_full_chain_and_need_no_secondary_check():
    # the variant searches' settings: no secondary-collision check, no run-out paths, a
    # memo of rest results; every outcome column but those is the same to the last bit,
    # also on the second call that takes every run-out from the memo
    batch = synthetic_case_batch(10, np.random.default_rng(6))
    cols = [c for c in results_table(batch, simulate_cases(batch)).columns
            if not c.startswith("secondary")]
    full = results_table(batch, simulate_cases(
        batch, params=SimulationParams(secondary_collisions=False)))[cols]
    lean = SimulationParams(secondary_collisions=False, runout_paths=False)
    memo = RunoutMemo()
    for _ in range(2):
        got = results_table(batch, simulate_cases(batch, params=lean, runout_memo=memo))[cols]
        assert got.equals(full)
    assert memo.hits == memo.misses > 0
    with pytest.raises(ParameterError, match="secondary_collisions=False"):
        SimulationParams(runout_paths=False)
    with pytest.raises(ParameterError, match="secondary_collisions=False"):  # not ignored
        simulate_cases(batch, runout_memo=memo)


def test_mirror_symmetric_cases_give_mirrored_outcomes():
    batch = synthetic_case_batch(8, np.random.default_rng(11))
    a = results_table(batch, simulate_cases(batch))
    b = results_table(batch, simulate_cases(mirrored(batch)))
    assert (a["collided"] == b["collided"]).all()
    hit = a["collided"].to_numpy()
    for col in ("delta_v1", "delta_v2", "ees1", "energy_loss", "rest_x1", "rest_x2"):
        np.testing.assert_allclose(b[col][hit], a[col][hit], rtol=1e-6, atol=1e-6)
    for col in ("rest_y1", "rest_y2", "rest_yaw1", "pdof1"):
        np.testing.assert_allclose(b[col][hit], -a[col][hit], rtol=1e-6, atol=1e-6)


def test_run_case_cli_prints_table_and_plots(tmp_path, capsys):
    png = tmp_path / "case.png"
    assert main(["run-case", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "delta-v [km/h]" in out and "rest x [m]" in out and "impact type" in out
    assert png.exists() and png.stat().st_size > 10_000
    # braking early enough avoids the crash
    assert main(["run-case", "--brake-at-s", "0.5"]) == 0
    assert "no collision" in capsys.readouterr().out
    assert main(["run-case", "--case", "999"]) == 2
