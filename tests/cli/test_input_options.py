"""--strict on every command that reads input, declared by the command itself.

A command that reads a database or an impact table calls
``vfs.cli.common.add_input_option`` on its own parser (as a command that draws calls
``add_figure_options``); ``vfs.cli.build_parser`` adds nothing afterwards.
"""

from __future__ import annotations

import argparse

import pytest

from vfs.cli import build_parser
from vfs.cli.common import add_input_option


def command_options() -> dict[str, set[str]]:
    """Option strings of every command and sub-command, by its path (``"db export-xosc"``)."""
    options: dict[str, set[str]] = {}

    def walk(parser: argparse.ArgumentParser, path: str) -> None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    key = f"{path} {name}".strip()
                    options[key] = {s for a in sub._actions for s in a.option_strings}
                    walk(sub, key)

    walk(build_parser(), "")
    return options


def test_every_reader_declares_strict():
    options = command_options()
    readers = {name for name, opts in options.items() if opts & {"--db", "--input"}}
    strict = {name for name, opts in options.items() if "--strict" in opts}
    # db validate checks a folder given as an argument and has its own --strict
    assert strict == readers | {"db validate"}
    assert {"study", "compare", "impact", "diagnose", "uncertainty", "identify", "run-case",
            "db export-xosc"} <= readers


def test_add_input_option_declares_flag_and_strict():
    p = argparse.ArgumentParser()
    add_input_option(p, "--input", help="table")
    args = p.parse_args(["--input", "t.parquet", "--strict"])
    assert args.input == "t.parquet" and args.strict is True
    assert p.parse_args(["--input", "t.csv"]).strict is False
    with pytest.raises(SystemExit):
        p.parse_args([])  # required by default
    q = argparse.ArgumentParser()
    add_input_option(q, required=False)
    assert q.parse_args([]).db is None


def test_build_parser_adds_no_option_after_the_commands():
    """The parser is what the command groups declared: no walk over argparse internals."""
    import inspect

    import vfs.cli

    source = inspect.getsource(vfs.cli)
    assert "_SubParsersAction)" not in source.replace("argparse._SubParsersAction], object]", "")
    assert ".choices" not in source and "._actions" not in source
