"""Progress and logging (vfs.progress, -v/-q of the command line)."""

from __future__ import annotations

import argparse
import logging

import pytest

from vfs import progress as prog
from vfs.cli import build_parser, main
from vfs.cli.common import configure_logging


def _leaves(parser: argparse.ArgumentParser, name: str = "vfs"):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield name, parser
    for action in subs:
        for sub_name, sub in action.choices.items():
            yield from _leaves(sub, f"{name} {sub_name}")


def test_every_command_takes_verbose_and_quiet() -> None:
    leaves = list(_leaves(build_parser()))
    assert len(leaves) > 20
    for name, parser in leaves:
        options = {o for a in parser._actions for o in a.option_strings}
        assert {"-v", "--verbose", "-q", "--quiet"} <= options, name


def test_lines_when_piped(vfs_log: list[logging.LogRecord],
                          monkeypatch: pytest.MonkeyPatch) -> None:
    clock = iter([0.0, 5.0, 12.0, 13.0, 30.0, 31.0, 31.0])
    monkeypatch.setattr(prog.time, "perf_counter", lambda: next(clock))
    with prog.progress(4, "simulating the cases", "case", bar=False) as shown:
        for _ in range(4):
            shown.update()
    lines = [r.getMessage() for r in vfs_log]
    # one line after the interval (12 s: 2 of 4 done), none at 5 s or 13 s, one at the end
    assert lines[0] == "simulating the cases: 2 of 4 cases (50 %), 12 s so far, about 12 s left"
    assert lines[-1] == "simulating the cases: 4 cases done in 31 s"
    assert len(lines) == 2


def test_a_short_step_stays_silent(vfs_log: list[logging.LogRecord]) -> None:
    with prog.progress(3, "quick", "case", bar=False) as shown:
        shown.update(3)
    assert vfs_log == []


def test_quiet_silences_progress_and_verbose_shows_debug(
        capsys: pytest.CaptureFixture[str]) -> None:
    configure_logging(-1)
    prog.note("a progress line")
    logging.getLogger("vfs.x").warning("a warning")
    err = capsys.readouterr().err
    assert "a progress line" not in err and "warning: a warning" in err
    configure_logging(1)
    logging.getLogger("vfs.x").debug("detail")
    assert "detail" in capsys.readouterr().err
    configure_logging(0)
    assert prog.LOGGER.level == logging.INFO


def test_cli_quiet_flag_reaches_the_logger(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["db", "schema", "-q"]) == 0
    assert prog.LOGGER.level == logging.WARNING
    assert main(["db", "schema", "-v"]) == 0
    assert prog.LOGGER.level == logging.DEBUG
    configure_logging(0)
