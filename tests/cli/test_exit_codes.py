"""Exit codes of the ``vfs`` commands: 2 for a user error (vfs.cli, vfs.cli.db).

Each case is a user error that fails before any work: a database folder that does not exist,
or a flag value argparse refuses (argparse itself exits with 2).
"""

from __future__ import annotations

import pytest

from vfs.cli import main


@pytest.mark.parametrize("argv", [
    ["compare", "--db", "{missing}", "--out", "{tmp}/compare"],
    ["study", "--db", "{missing}", "--systems", "ideal", "--out", "{tmp}/study"],
    ["db", "convert", "{missing}", "{tmp}/out", "--to", "csv"],
    ["db", "import-pcm", "{missing}", "{tmp}/out"],
])
def test_a_missing_database_folder_exits_with_2(argv, tmp_path, capsys):
    missing = tmp_path / "no-such-database"
    args = [a.format(missing=missing, tmp=tmp_path) for a in argv]
    assert main(args) == 2
    out = capsys.readouterr()
    assert str(missing) in out.err + out.out or "no-such-database" in out.err + out.out


@pytest.mark.parametrize("argv", [
    ["study", "--workers", "0"],
    ["compare", "--dpi", "not-a-number"],
    ["db", "convert", "a", "b", "--to", "no-such-format"],
])
def test_a_bad_flag_value_exits_with_2(argv):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
