"""`vfs impact`: batch-solving tables, errors naming row and column, --on-error record."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from vfs.cli import main
from vfs.database.impact_table import INPUT_COLUMNS, OUTPUT_COLUMNS, solve_impact_table
from vfs.errors import DataError
from vfs.physics.impact import ImpactConfig, solve_impact


def table(n: int = 5) -> pd.DataFrame:
    rng = np.random.default_rng(4)
    df = pd.DataFrame({
        "case_id": np.arange(100, 100 + n),
        "m1": rng.uniform(900, 2000, n), "izz1": rng.uniform(1500, 3500, n),
        "x1": np.zeros(n), "y1": np.zeros(n), "yaw1": np.zeros(n),
        "vx1": rng.uniform(10, 25, n), "vy1": np.zeros(n), "yaw_rate1": rng.uniform(-.2, .2, n),
        "m2": rng.uniform(900, 2000, n), "izz2": rng.uniform(1500, 3500, n),
        "x2": np.full(n, 4.4), "y2": rng.uniform(-1.5, 1.5, n), "yaw2": np.full(n, np.pi),
        "vx2": rng.uniform(-25, -10, n), "vy2": np.zeros(n), "yaw_rate2": np.zeros(n),
        "poi_x": np.full(n, 2.2), "poi_y": rng.uniform(-0.6, 0.6, n),
        "cp_angle": rng.uniform(1.2, 1.9, n), "restitution": np.full(n, 0.1),
        "contact_friction": np.full(n, 0.6),
    })
    return df


def test_table_matches_kernel_and_units():
    df = table()
    out = solve_impact_table(df)
    assert list(out.columns[: len(df.columns)]) == list(df.columns)
    assert set(OUTPUT_COLUMNS) <= set(out.columns)
    r = solve_impact(ImpactConfig.from_columns(**{c: df[c] for c in INPUT_COLUMNS[1:]}))
    np.testing.assert_array_equal(out["delta_v1"], r.delta_v[:, 0])
    np.testing.assert_allclose(out["pdof2"], np.degrees(r.pdof[:, 1]))
    assert set(out["impact_type"]) <= {"full", "sliding"}
    assert (out["error"] == "").all()


@pytest.mark.parametrize("column,value,needle", [
    ("m1", -5.0, "m1"), ("restitution", 1.5, "restitution"),
    ("contact_friction", -0.1, "contact_friction"), ("vx2", np.nan, "vx2"),
])
def test_bad_row_error_names_row_column_and_range(column, value, needle):
    df = table()
    df.loc[3, column] = value
    with pytest.raises(DataError) as info:
        solve_impact_table(df, table="impacts.csv")
    text = str(info.value)
    assert "impacts.csv" in text and f"column '{needle}'" in text and "row 3" in text
    assert "case_id 103" in text and ("[0, 1]" in text or "> 0" in text or "finite" in text)


def test_record_mode_solves_the_rest():
    df = table()
    df.loc[1, "m2"] = 0.0
    out = solve_impact_table(df, on_error="record")
    assert out.loc[1, "impact_type"] == "error" and "m2" in out.loc[1, "error"]
    assert np.isnan(out.loc[1, "delta_v1"])
    good = solve_impact_table(df.drop(index=1))
    np.testing.assert_array_equal(out.drop(index=1)["delta_v1"].to_numpy(),
                                  good["delta_v1"].to_numpy())


def test_missing_column_and_cli_round_trip(tmp_path, capsys):
    df = table()
    src = tmp_path / "in.csv"
    df.drop(columns=["izz2"]).to_csv(src, index=False)
    assert main(["impact", "--input", str(src), "--output", str(tmp_path / "o.csv")]) == 2
    assert "izz2" in capsys.readouterr().err
    df.to_parquet(tmp_path / "in.parquet")
    assert main(["impact", "--input", str(tmp_path / "in.parquet"),
                 "--output", str(tmp_path / "out.parquet")]) == 0
    out = pd.read_parquet(tmp_path / "out.parquet")
    assert len(out) == len(df) and "ees1" in out.columns


def test_unreadable_empty_and_overflowing_inputs_end_in_one_clear_error(tmp_path):
    import numpy as np

    from vfs.cli import main
    from vfs.database.impact_table import read_table, solve_impact_table
    from vfs.errors import DataError
    from vfs.scenarios.examples import example_impact_table

    empty = tmp_path / "empty.csv"
    empty.write_text("")
    binary = tmp_path / "binary.csv"
    binary.write_bytes(bytes(range(128, 256)) * 4)
    header_only = tmp_path / "header.csv"
    header_only.write_text(",".join(example_impact_table().columns) + "\n")
    for path, text in ((empty, "is empty"), (binary, "not a readable CSV"),
                       (header_only, "has no rows")):
        with pytest.raises(DataError, match=text):
            read_table(path)
        assert main(["impact", "--input", str(path), "--output", str(tmp_path / "o.csv")]) == 2
    # overflowing and documented-invalid values: an error naming column, row and range
    t = example_impact_table()
    t.loc[0, "vx1"] = 1e300
    t["stiffness_ratio"] = np.nan
    t.loc[1, "stiffness_ratio"] = 0.0
    with pytest.raises(DataError) as info:
        solve_impact_table(t)
    text = str(info.value)
    assert "'vx1', row 0" in text and "[-150, 150]" in text
    assert "stiffness_ratio=0.0 not allowed" in text and "np." not in text
    out = solve_impact_table(t, on_error="record")
    assert list(out["impact_type"][:2]) == ["error", "error"]
    assert np.isfinite(out.loc[2:, "delta_v1"]).all() and np.isfinite(out.loc[2:, "ees1"]).all()
