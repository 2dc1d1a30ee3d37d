"""The ``vfs`` command line: one entry point, one module per command group.

Each module of this package has ``add_parsers(subparsers)``; the sub-parsers
set ``func(args) -> int`` (the exit code).  Heavy imports happen inside the
commands, so ``vfs --help`` stays fast.

Exit codes (every command; tests/cli/test_exit_codes.py):

* 0: done;
* 1: ``vfs db validate`` found problems in the database it checks (its verdict), the
  system refused a file operation (a full disk, a read-only folder: one line), or no command
  was given (the help is printed);
* 2: a user error: a bad flag value (argparse), or a :class:`vfs.errors.VfsError` (unreadable
  input, a value out of range), printed as one line without a traceback;
* 3: ``vfs study`` ended incomplete (``vfs.study.run.EXIT_INCOMPLETE``; ``--resume`` goes on);
* 4: ``vfs study`` finished but some runs failed inside the simulation
  (``vfs.study.faults.EXIT_FAILED_CASES``; ``--allow-failed`` accepts them);
* 130: interrupted (Ctrl-C); 143: terminated by SIGTERM (``vfs study`` and ``python -m vfs``)
  (``vfs.study.faults.EXIT_TERMINATED``).

README.md lists the same codes; tests/test_docs_figures.py checks that the two lists agree.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence

from vfs.cli import (
    bench,
    compare,
    db,
    diagnose,
    generate,
    gym,
    impact,
    learn,
    run_case,
    study,
    uncertainty,
)
from vfs.errors import Terminated, VfsError

#: Every command group of the CLI, in the order of ``vfs --help``.
COMMAND_GROUPS: tuple[Callable[[argparse._SubParsersAction], object], ...] = (
    impact.add_parsers,
    run_case.add_parsers,
    bench.add_parsers,
    db.add_parsers,
    generate.add_parsers,
    study.add_parsers,
    compare.add_parsers,
    diagnose.add_parsers,
    learn.add_parsers,
    uncertainty.add_parsers,
    gym.add_parsers,
)

#: The top-level commands each group of :data:`COMMAND_GROUPS` declares (same order):
#: ``vfs study ...`` builds the study group's parsers only (tests/cli/test_lazy_parsers.py checks
#: that the two agree).
GROUP_COMMANDS: tuple[tuple[str, ...], ...] = (
    ("impact",),
    ("run-case",),
    ("bench",),
    ("db",),
    ("generate",),
    ("study", "report"),
    ("compare",),
    ("diagnose", "calibrate", "ledger"),
    ("identify", "learn"),
    ("uncertainty", "sensitivity", "reconstruct"),
    ("evaluate-policy",),
)


#: Shown below the command list of ``vfs --help``.
EXAMPLES = """examples:
  vfs study --db default --systems three-stage,ideal --out results/quickstart
  vfs report effectiveness results/quickstart      # report.html, a page per case
  vfs run-case --plot case.png                     # the built-in example, pre-crash to rest
  vfs compare --db default                         # simulation against reconstructions
  vfs diagnose --db DIR                            # which physical effect is missing
  vfs db schema runs                               # the columns of runs.parquet, with units
  vfs COMMAND --help                               # the options of one command

documentation: README.md and docs/ (mkdocs build), exit codes: README.md"""


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every command.

    Parameters
    ----------
    command : str, optional
        A top-level command (``"study"``): only the sub-parsers of its group
        (:data:`GROUP_COMMANDS`) are built, which imports only what that group's
        options name (``vfs study`` does not import the uncertainty, diagnosis or gym
        modules to build its parser); every command for None or an unknown name
        (``vfs --help`` and the "did you mean" of a mistyped command list them all).
    """
    from vfs.cli.common import Parser
    from vfs.version import __version__

    parser = Parser(
        prog="vfs", verbosity=False,
        description="Virtual forward simulation of real accidents for the assessment of ADAS.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"vfs {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    groups = [add for add, names in zip(COMMAND_GROUPS, GROUP_COMMANDS, strict=True)
              if command in names] or COMMAND_GROUPS
    for add in groups:  # readers declare --strict (common.add_input_option)
        add(subparsers)
    return parser  # -v/-q: declared once, by every sub-parser (vfs.cli.common.Parser)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vfs`` console script (and ``python -m vfs``)."""
    words = list(sys.argv[1:] if argv is None else argv)
    # the command's own group only: the first word (never after an option: "vfs -h study"
    # is the help of every command)
    parser = build_parser(words[0] if words and not words[0].startswith("-") else None)
    args = parser.parse_args(words)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    from vfs.blas import single_threaded_blas
    from vfs.cli.common import configure_logging, input_messages

    configure_logging(args.verbose - args.quiet)

    try:
        # input warnings as "warning:" lines; --strict; one BLAS thread (vfs.blas)
        with _terminate_as_interrupt(), input_messages(args), single_threaded_blas():
            return _run(args)
    except VfsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # Ctrl-C (in vfs study also SIGTERM) before its handler
        print("interrupted", file=sys.stderr, flush=True)
        return int(getattr(exc, "exit_status", 130))  # Terminated: 143
    except OSError as exc:  # a full disk, a read-only folder: one line, not a traceback
        where = f" ({exc.filename})" if exc.filename else ""
        print(f"error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM raises :class:`vfs.errors.Terminated` here (main thread only): the command
    ends with one line and exit 143, as on Ctrl-C (``vfs study`` handles both itself).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: object) -> None:
        raise Terminated(f"signal {signum} (SIGTERM)")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run(args: argparse.Namespace) -> int:
    """The command of ``args`` (with its figure options)."""
    if hasattr(args, "figure_format"):
        from vfs.report.figures import figure_options

        with figure_options(args.figure_format, args.dpi):
            return int(args.func(args))
    return int(args.func(args))


__all__ = ["COMMAND_GROUPS", "EXAMPLES", "GROUP_COMMANDS", "build_parser", "main"]
