"""Messages a user reads print plain numbers, and help texts list choices and defaults."""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd
import pytest

from vfs.analysis.effectiveness import effectiveness
from vfs.analysis.stats import bootstrap_ci, wilson_interval
from vfs.cli import build_parser, main
from vfs.errors import DataError, DataProblem, ParameterError, VfsError, plain_numbers


def _triggers() -> list[tuple[str, object]]:
    runs = pd.DataFrame({"case_id": [1], "system": ["baseline"]})
    return [
        ("n_boot", lambda: effectiveness(runs, n_boot=np.int64(0))),
        ("confidence", lambda: effectiveness(runs, confidence=np.float64(np.nan))),
        ("wilson", lambda: wilson_interval(np.int64(5), np.int64(3))),
        ("bootstrap", lambda: bootstrap_ci(np.mean, [1.0, 2.0], rng=np.random.default_rng(0),
                                           confidence=np.float64(1.5))),
        ("problem", lambda: (_ for _ in ()).throw(DataError(DataProblem(
            "cases", "speed", np.int64(3), np.int64(7), f"value {np.float64(np.nan)!r}")))),
    ]


@pytest.mark.parametrize(("name", "trigger"), _triggers(), ids=[n for n, _ in _triggers()])
def test_error_messages_have_no_numpy_reprs(name: str, trigger) -> None:  # noqa: ANN001
    with pytest.raises(VfsError) as info:
        trigger()
    text = str(info.value)
    assert "np." not in text, text


def test_plain_numbers_keeps_ordinary_text() -> None:
    assert plain_numbers("np.int64(12) of np.float32(0.5)") == "12 of 0.5"
    assert plain_numbers("use np.clip(x) and numpy") == "use np.clip(x) and numpy"
    assert "np." not in str(ParameterError(f"x={np.True_!r}, n={np.uint8(3)!r}"))


def test_cli_error_prints_plain_numbers(tmp_path, capsys) -> None:  # noqa: ANN001
    code = main(["report", "effectiveness", str(tmp_path)])
    err = capsys.readouterr().err
    assert code != 0 and "np." not in err


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # noqa: SLF001 - argparse has no public walk
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            return dict(action.choices)
    return {}


def test_study_and_bench_help_list_the_registries() -> None:
    from vfs.adas import SYSTEM_NAMES
    from vfs.bench import BENCHMARKS
    subs = _subparsers(build_parser())
    study = subs["study"].format_help().replace("\n", " ")
    bench = subs["bench"].format_help().replace("\n", " ")
    for name in SYSTEM_NAMES:
        assert name in " ".join(study.split()).replace("- ", "-"), name
    for name in BENCHMARKS:
        assert name in bench, name


def test_options_with_choices_or_defaults_name_them() -> None:
    """Every option with a default or choices says so in its help (%(default)s or text)."""
    missing = []

    def walk(parser: argparse.ArgumentParser, name: str) -> None:
        for action in parser._actions:  # noqa: SLF001
            if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
                for sub_name, sub in action.choices.items():
                    walk(sub, f"{name} {sub_name}")
            elif action.option_strings and not isinstance(action, argparse._HelpAction):  # noqa: SLF001
                text = (action.help or "").lower()
                has_default = action.default not in (None, False, argparse.SUPPRESS)
                if has_default and "default" not in text:
                    missing.append(f"{name} {action.option_strings[-1]} (default)")
                if action.choices and "default" not in text and not action.required \
                        and action.metavar is None and has_default:
                    missing.append(f"{name} {action.option_strings[-1]} (choices)")

    walk(build_parser(), "vfs")
    assert not missing, missing


def test_db_help_shows_no_rest_markup() -> None:
    subs = _subparsers(build_parser())
    texts = [subs["db"].format_help(), *(p.format_help() for p in _subparsers(subs["db"]).values())]
    for text in texts:
        for markup in ("``", ":func:", ":class:", ":mod:", ".. "):
            assert markup not in text, (markup, text)
