"""``vfs COMMAND`` builds the parsers of its own command group only (``GROUP_COMMANDS``), with
the same options and help as the whole parser, and imports none of the other commands'
modules (issue 37: fixed costs of ``vfs study``)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vfs.cli import COMMAND_GROUPS, GROUP_COMMANDS, build_parser, main

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = [name for names in GROUP_COMMANDS for name in names]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # noqa: SLF001 - argparse has no public walk
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            return dict(action.choices)
    return {}


def _helps(parser: argparse.ArgumentParser, name: str = "") -> dict[str, str]:
    """Help text of the parser and of every sub-parser below it, by command path."""
    out = {name: parser.format_help()}
    for sub_name, sub in _subparsers(parser).items():
        out.update(_helps(sub, f"{name} {sub_name}"))
    return out


def test_group_commands_name_what_each_group_declares():
    for add, names in zip(COMMAND_GROUPS, GROUP_COMMANDS, strict=True):
        subparsers = argparse.ArgumentParser().add_subparsers()
        add(subparsers)
        assert tuple(subparsers.choices) == names, add.__module__


@pytest.mark.parametrize("command", COMMANDS)
def test_a_command_alone_has_the_options_and_help_of_the_whole_parser(command):
    whole = _subparsers(build_parser())[command]
    alone = _subparsers(build_parser(command))
    assert set(alone) == next(set(n) for n in GROUP_COMMANDS if command in n)
    assert _helps(alone[command]) == _helps(whole)


def test_no_command_or_an_unknown_one_builds_every_command():
    assert set(_subparsers(build_parser())) == set(COMMANDS)
    assert set(_subparsers(build_parser("stdy"))) == set(COMMANDS)  # "did you mean 'study'?"


def test_help_before_the_command_lists_every_command(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["-h", "study"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert all(name in out for name in COMMANDS)


def test_vfs_study_imports_none_of_the_other_commands_modules():
    others = ["vfs.uncertainty", "vfs.diagnosis", "vfs.bench", "vfs.analysis", "vfs.gym.config",
              "scipy.special"]
    code = ("import sys\nfrom vfs.cli import build_parser\n"
            "build_parser('study').parse_args(['study', '--db', 'x', '--systems', 'ideal'])\n"
            f"print([m for m in {others!r} if m in sys.modules])\n")
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env=env, timeout=120, check=True)
    assert out.stdout.strip() == "[]"
    # and the whole parser does import them: the check above can fail
    code = code.replace("build_parser('study')", "build_parser()")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env=env, timeout=120, check=True)
    assert "vfs.uncertainty" in out.stdout
