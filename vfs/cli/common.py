"""What several commands share: database and selection options, plugins, messages."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.util
import sys
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from vfs.errors import ParameterError
from vfs.registry import import_file

if TYPE_CHECKING:  # pragma: no cover
    from vfs.database import Database

#: Help text of ``--db``.
DB_HELP = ("database folder (Parquet, CSV or PCM), 'default' for the bundled one, or the "
           "fsspec URL of a Parquet database (file:///shared/db, s3://bucket/db)")
#: Help text of ``--strict``.
STRICT_HELP = ("treat the plausibility warnings of the input (docs/data-format.md, 'Checks') "
               "as errors")
#: Help text of ``--where``.
WHERE_HELP = "SQL predicate on the cases table, e.g. \"accident_type IN (241, 242)\""


#: The folder (relative to the working directory) below which every command writes when
#: ``--out`` is not given: ``results/<command>-<name>`` (results/README.md).
RESULTS_DIR = "results"


def path_label(text: str) -> str:
    """A file-name-safe short label of a database or system given on the command line."""
    name = text.rstrip("/").rsplit("/", 1)[-1]
    name = name.removesuffix(".toml").removesuffix(".py") or "db"
    return "".join(c if c.isalnum() or c in "-_.+" else "_" for c in name)


def results_folder(command: str, *names: str) -> str:
    """The default output folder ``results/<command>-<name>-...`` of a command.

    >>> results_folder("study", "default", "three-stage+ideal")
    'results/study-default-three-stage+ideal'
    >>> results_folder("compare", "/data/my db/")
    'results/compare-my_db'
    """
    parts = [command, *(path_label(n) for n in names if n)]
    return f"{RESULTS_DIR}/{'-'.join(parts)}"


def out_option(p: argparse.ArgumentParser, what: str, default: str) -> None:
    """Add ``--out`` with the default ``results/<default>`` (filled in by :func:`out_folder`)."""
    p.add_argument("--out", default=None, metavar="DIR",
                   help=f"{what} (default {RESULTS_DIR}/{default}; see results/README.md)")


def out_folder(args: argparse.Namespace, command: str, *names: str) -> str:
    """``args.out``, or the default :func:`results_folder` (stored in ``args.out``)."""
    if not getattr(args, "out", None):
        args.out = results_folder(command, *names)
        say(f"output -> {args.out}")
    return str(args.out)


def add_input_option(p: argparse.ArgumentParser, flag: str = "--db", *, help: str = DB_HELP,
                     required: bool = True) -> None:
    """Declare that command ``p`` reads a database (``--db``) or a table (``--input``).

    Adds ``flag`` and ``--strict`` (the input's plausibility warnings become errors,
    :func:`input_messages`).  Each command that reads input calls it on its own parser, as
    a command that draws calls :func:`add_figure_options`, so no command that reads can
    lack ``--strict``.
    """
    p.add_argument(flag, required=required, help=help)
    p.add_argument("--strict", action="store_true", help=STRICT_HELP)


@contextlib.contextmanager
def input_messages(args: argparse.Namespace) -> Iterator[None]:
    """Print input warnings as ``warning: ...`` lines on stderr; ``--strict`` makes them errors.

    Every command runs inside this block (:func:`vfs.cli.main`), so the warnings of
    :mod:`vfs.database.checks` look the same whichever command loads the data.
    """
    from vfs.database.checks import strict_input
    from vfs.errors import DataWarning

    with warnings.catch_warnings():
        warnings.simplefilter("always", DataWarning)
        shown = warnings.showwarning

        def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                 file: object = None, line: str | None = None) -> None:
            if issubclass(category, DataWarning):
                print(f"warning: {message}", file=sys.stderr, flush=True)
            else:
                shown(message, category, filename, lineno, file, line)  # type: ignore[arg-type]

        warnings.showwarning = show
        with strict_input(bool(getattr(args, "strict", False))):
            yield


def open_db(args: argparse.Namespace) -> Database:
    """The database of ``--db`` with the cases of ``--where`` (when the command has it)."""
    from vfs.database import open_database

    return open_database(args.db, getattr(args, "where", None))


def say(msg: str) -> None:
    """Print a progress line now (not buffered)."""
    print(msg, flush=True)


def _register_laws(path: Path) -> list[str]:
    from vfs.diagnosis.learn import read_laws
    from vfs.effects import register_effect, registered_effects
    from vfs.effects.learned import law_effect_class

    names = []
    for law in read_laws(str(path)):
        cls = law_effect_class(law)
        old = registered_effects().get(cls.name)
        if old is None or getattr(old, "law", None) != getattr(cls, "law", None):
            if old is not None:
                from vfs.effects import unregister_effect

                unregister_effect(cls.name)
            register_effect(cls)
        names.append(cls.name)
    return names


def load_plugins(specs: Sequence[str] | None) -> list[str]:
    """Import user modules that register effects (dotted names or ``.py`` files).

    Parameters
    ----------
    specs : sequence of str
        Module names (``mypackage.effects``), paths of ``.py`` files or of
        ``law.json`` files of ``vfs learn`` (each law registers an effect).

    Returns
    -------
    list of str
        The module names imported.

    Raises
    ------
    ParameterError
        A file that does not exist or a module that cannot be found.
    """
    loaded = []
    for spec in specs or ():
        path = Path(spec)
        if spec.endswith(".json"):  # a law file of vfs learn: one effect per law
            loaded += _register_laws(path)
            continue
        if spec.endswith(".py"):
            name = import_file(path, f"--plugin {spec}").__name__
        else:
            try:
                importlib.import_module(spec)
            except ModuleNotFoundError as exc:
                raise ParameterError(f"--plugin {spec}: {exc}") from None
            name = spec
        loaded.append(name)
    return loaded


def add_figure_options(p: argparse.ArgumentParser) -> None:
    """Declare that command ``p`` draws figures: ``--figure-format`` and ``--dpi``.

    Each command that draws calls it on its own parser; :func:`vfs.cli.main` applies the
    options (``vfs.report.figures.figure_options``) wherever they are present.
    """
    p.add_argument("--figure-format", default="png", metavar="LIST",
                   help="figure formats, comma separated, from png, svg, pdf (default png; the "
                   "reports embed the PNG, the others are written beside it)")
    p.add_argument("--dpi", type=float, metavar="N",
                   help="resolution of raster figures [dots per inch] (default: 110, top "
                   "views 120)")
