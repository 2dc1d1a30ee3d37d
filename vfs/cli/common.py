"""What several commands share: database and selection options, plugins, messages."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.util
import logging
import sys
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, NoReturn

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
        from vfs.errors import quiet_numpy_warnings

        quiet_numpy_warnings()  # users see the clear line, not numpy's RuntimeWarning
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
    """A progress line (INFO on the ``vfs`` logger: standard error; ``-q`` silences it)."""
    from vfs.progress import note

    note("%s", msg)


class Parser(argparse.ArgumentParser):
    """The parser of ``vfs`` and of every command (argparse gives sub-parsers their parent's
    class): ``-v/--verbose`` and ``-q/--quiet`` on every command, declared here once, and
    "did you mean" for a mistyped command, choice or option (Python 3.11's argparse has no
    ``suggest_on_error``).

    Parameters
    ----------
    verbosity : bool
        Declare ``-v/-q`` (every command; not the top-level ``vfs``, whose value the
        command's own default would override).
    **kwargs
        Those of :class:`argparse.ArgumentParser`.
    """

    #: Every option string a vfs parser declared (the candidates of "did you mean").
    declared: ClassVar[set[str]] = set()

    def __init__(self, *args: Any, verbosity: bool = True, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if verbosity:
            group = self.add_argument_group("output")
            group.add_argument("-v", "--verbose", action="count", default=0,
                               help="more detail on standard error (debug lines)")
            group.add_argument("-q", "--quiet", action="count", default=0,
                               help="no progress lines or bars, warnings and errors only")

    def add_argument(self, *args: Any, **kwargs: Any) -> Any:
        """:meth:`argparse.ArgumentParser.add_argument`, remembering the option strings."""
        Parser.declared.update(a for a in args if isinstance(a, str) and a.startswith("-"))
        return super().add_argument(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        """Print usage and ``message`` with the closest valid word, exit with code 2."""
        import difflib
        import re

        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if m:
            choices = re.findall(r"'([^']*)'", m.group(2)) or \
                [c.strip() for c in m.group(2).split(",")]
            close = difflib.get_close_matches(m.group(1), choices, n=3, cutoff=0.5)
            if close:
                message += "; did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
        m = re.search(r"unrecognized arguments: (.*)", message)
        if m:
            for word in m.group(1).split():
                close = difflib.get_close_matches(word.split("=")[0], sorted(Parser.declared),
                                                  n=1, cutoff=0.6) \
                    if word.startswith("-") else []
                if close:
                    message += f"; did you mean '{close[0]}' for '{word}'?"
        super().error(message)


class _Format(logging.Formatter):
    """Progress lines as they are; warnings and errors with their level."""

    def format(self, record: logging.LogRecord) -> str:
        text = record.getMessage()
        if record.levelno >= logging.WARNING:
            return f"{record.levelname.lower()}: {text}"
        return text


def configure_logging(verbosity: int) -> None:
    """The ``vfs`` logger of the command line: standard error, INFO by default, DEBUG with
    ``-v``, WARNING with ``-q`` (``verbosity`` = number of -v minus number of -q).
    """
    from vfs.progress import LOGGER

    level = logging.DEBUG if verbosity > 0 else logging.INFO if verbosity == 0 else \
        logging.WARNING
    for handler in [h for h in LOGGER.handlers if getattr(h, "vfs_cli", False)]:
        LOGGER.removeHandler(handler)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Format())
    handler.vfs_cli = True  # type: ignore[attr-defined]
    LOGGER.addHandler(handler)
    LOGGER.setLevel(level)
    LOGGER.propagate = False


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


#: Spellings of ``--impact-parameters`` of earlier versions -> the declared one
#: (:class:`vfs.simulation.ImpactParameterSource`).
IMPACT_PARAMETERS_ALIASES = {"defaults": "default"}


def impact_parameter_source(text: str) -> str:
    """The value of ``--impact-parameters``; an earlier spelling is accepted with a
    :class:`FutureWarning` naming the one to use (argparse checks the choices after).
    """
    if text in IMPACT_PARAMETERS_ALIASES:
        new = IMPACT_PARAMETERS_ALIASES[text]
        warnings.warn_explicit(f"--impact-parameters {text} is deprecated and will be "
                               f"removed; use --impact-parameters {new}", FutureWarning,
                               filename="vfs", lineno=0)
        return new
    return text


def add_impact_parameters_option(p: argparse.ArgumentParser, default: str, note: str) -> None:
    """``--impact-parameters``: choices and help from the declaration of
    :attr:`vfs.study.spec.StudySpec.impact_parameters`, the command's own ``default``
    and ``note`` (what the choice means for it).
    """
    from vfs.settings import cli_kwargs, declared
    from vfs.study.spec import StudySpec

    kwargs = cli_kwargs(declared(StudySpec)["impact_parameters"], default=default)
    p.add_argument("--impact-parameters", type=impact_parameter_source,
                   **kwargs | {"help": f"{kwargs['help']}; {note}"})


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
