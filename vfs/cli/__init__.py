"""The ``vfs`` command line: one entry point, one module per command group.

Each module of this package has ``add_parsers(subparsers)``; the sub-parsers
set ``func(args) -> int`` (the exit code).  Heavy imports happen inside the
commands, so ``vfs --help`` stays fast.

Exit codes (every command; tests/cli/test_exit_codes.py):

* 0: done;
* 1: ``vfs db validate`` found problems in the database it checks (its verdict), or the
  system refused a file operation (a full disk, a read-only folder: one line);
* 2: a user error: a bad flag value (argparse), or a :class:`vfs.errors.VfsError` (unreadable
  input, a value out of range), printed as one line without a traceback;
* 3: ``vfs study`` ended incomplete (``vfs.study.run.EXIT_INCOMPLETE``; ``--resume`` goes on);
* 130: interrupted (Ctrl-C); 143: terminated (SIGTERM).
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


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every command."""
    from vfs.version import __version__

    parser = argparse.ArgumentParser(
        prog="vfs",
        description="Virtual forward simulation of real accidents for the assessment of ADAS.",
    )
    parser.add_argument("--version", action="version", version=f"vfs {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in COMMAND_GROUPS:  # readers declare --strict (common.add_input_option)
        add(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vfs`` console script (and ``python -m vfs``)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    from vfs.blas import single_threaded_blas
    from vfs.cli.common import input_messages

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


__all__ = ["COMMAND_GROUPS", "build_parser", "main"]
