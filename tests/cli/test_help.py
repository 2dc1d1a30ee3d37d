"""The command line behaves like the ecosystem's tools: "did you mean" for a mistyped command,
choice or option (exit code 2), examples below ``vfs --help``, the distribution's name."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from vfs.cli import EXAMPLES, build_parser, main
from vfs.version import DISTRIBUTION

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("argv", "hint"), [
    (["stdy"], "did you mean 'study'?"),
    (["db", "schem"], "did you mean 'schema'?"),
    (["report", "efectiveness", "x"], "did you mean 'effectiveness'?"),
    (["db", "validate", "default", "--strikt"], "did you mean '--strict' for '--strikt'?"),
])
def test_a_mistyped_word_gets_a_suggestion(argv, hint, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert hint in capsys.readouterr().err


def test_no_suggestion_for_a_word_far_from_every_choice(capsys):
    with pytest.raises(SystemExit):
        main(["xyzzy"])
    assert "did you mean" not in capsys.readouterr().err


def test_help_ends_with_examples_that_parse():
    text = build_parser().format_help()
    assert "examples:" in text and EXAMPLES.splitlines()[1].strip() in text
    parser = build_parser()
    for line in EXAMPLES.splitlines()[1:]:
        words = line.split("#")[0].split()
        if words[:1] == ["vfs"] and "COMMAND" not in words and "DIR" not in words:
            parser.parse_args(words[1:])  # every example is a valid command line


def test_distribution_name_is_the_one_in_pyproject():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["name"] == DISTRIBUTION != "vfs"
    assert project["scripts"]["vfs"] == "vfs.cli:main"
