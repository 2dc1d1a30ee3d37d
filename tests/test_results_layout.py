"""results/ as the default root of every command's output."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from vfs.cli import main
from vfs.cli.common import results_folder

ROOT = Path(__file__).resolve().parents[1]


def test_study_without_out_writes_below_results_of_the_working_directory(
        tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adas").mkdir()
    text = (ROOT / "adas" / "ideal.toml").read_text(encoding="utf-8")
    (tmp_path / "adas" / "late.toml").write_text(
        text.replace('name = "ideal"', 'name = "late"'), encoding="utf-8")
    code = main(["study", "--db", "default", "--systems", "late,none", "--where",
                 "case_id <= 4", "--engine", "serial"])
    assert code == 0
    folder = tmp_path / results_folder("study", "default", "late+none")
    assert folder == tmp_path / "results" / "study-default-late+none"
    runs = pd.read_parquet(folder / "runs.parquet")
    assert set(runs["system"]) == {"baseline", "late", "none"}
    # the file's system is the built-in ideal under another name: the same runs
    ideal = main(["study", "--db", "default", "--systems", "ideal", "--where", "case_id <= 4",
                  "--engine", "serial"])
    assert ideal == 0
    other = pd.read_parquet(tmp_path / "results" / "study-default-ideal" / "runs.parquet")
    cols = ["case_id", "collided", "impact_speed1"] if "impact_speed1" in runs else \
        ["case_id", "collided"]
    a = runs[runs["system"] == "late"][cols].reset_index(drop=True)
    b = other[other["system"] == "ideal"][cols].reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b)
    printed = capsys.readouterr()  # the output folder is said on stderr, with the log lines
    assert "output -> results/study-default-late+none" in printed.out + printed.err


def test_reference_outputs_named_in_the_readme_exist() -> None:
    readme = (ROOT / "results" / "README.md").read_text(encoding="utf-8")
    for folder in sorted((ROOT / "results" / "reference").iterdir()):
        assert f"`reference/{folder.name}/`" in readme
        assert (folder / "printed.txt").is_file() and (folder / "report.md").is_file()
        for file in folder.iterdir():  # nothing of the machine that wrote them (figures too)
            data = file.read_bytes()
            assert b"file://" not in data and str(ROOT).encode() not in data, file
