"""The exception hierarchy of vfs.

Every error a user can cause (bad input data, bad parameters, bad command-line
arguments) is raised as a subclass of :class:`VfsError`, never as an
``assert``. Errors about data name where the problem sits: table, column,
row or case id, and the allowed range.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: numpy scalar reprs (numpy >= 2): np.int64(1), np.float64(nan), np.str_('a'), np.True_.
_NUMPY_REPR = re.compile(r"\bnp\.(?:u?int|float|complex|longdouble|str_|bytes_|bool)\w*"
                         r"\(([^()]*)\)")
_NUMPY_BOOL = re.compile(r"\bnp\.(True|False)_")


def plain_numbers(text: str) -> str:
    """``text`` with numpy scalar reprs replaced by their plain values.

    >>> plain_numbers("n=np.int64(1), x=np.float64(nan), s=np.str_('a'), b=np.True_")
    "n=1, x=nan, s='a', b=True"
    """
    return _NUMPY_BOOL.sub(r"\1", _NUMPY_REPR.sub(r"\1", text))


class VfsError(Exception):
    """Base class of all errors raised by vfs for user-caused problems.

    Its message prints plain numbers: numpy scalar reprs that reach a message through
    ``{value!r}`` (``np.int64(1)``, ``np.float64(nan)``) are shown as ``1`` and ``nan``.
    """

    def __str__(self) -> str:
        return plain_numbers(super().__str__())


class ParameterError(VfsError, ValueError):
    """A parameter (vehicle, impact, controller, ...) is outside its allowed range."""


class DefinitionError(ParameterError):
    """A definition file (``adas/*.toml``, ``scenarios/**/*.toml``) is malformed or a field is
    out of range; the message names the file, the field and its allowed range.

    Attributes
    ----------
    path : str
        The file.
    field : str
        The field as written in the file (``aeb.sensor.range_m``); empty for a file that
        cannot be parsed at all.
    allowed : str
        What the field allows (``(0, inf] m``); empty where it does not apply.
    """

    def __init__(self, path: str, field: str, problem: str, allowed: str = "") -> None:
        self.path = str(path)
        self.field = field
        self.allowed = allowed
        self.problem = problem
        where = f"{self.path}: {field}" if field else self.path
        tail = f" (allowed: {allowed})" if allowed else ""
        super().__init__(f"{where}: {problem}{tail}")

    def __reduce__(self) -> tuple[type, tuple[str, str, str, str]]:
        return (type(self), (self.path, self.field, self.problem, self.allowed))


@dataclass(frozen=True)
class SettingProblem:
    """One declared setting (:mod:`vfs.settings`) out of bounds, or a rule between settings
    broken.

    Attributes
    ----------
    owner : str
        The parameter class (``"SensorParams"``).
    name : str
        The setting, or the settings of a rule joined by ``", "``.
    value : object
        The value given (None for a rule).
    problem : str
        What is wrong (``"is out of range"``).
    allowed : str
        What is allowed (``"[0, 2] s"``, or the rule).
    """

    owner: str
    name: str
    value: object
    problem: str
    allowed: str

    def __str__(self) -> str:
        what = self.problem if self.value is None else f"{self.value!r} {self.problem}"
        return f"{self.owner}.{self.name}: {what} (allowed: {self.allowed})"


class SettingsError(ParameterError):
    """Declared settings out of bounds or rules between them broken; every problem at once.

    Attributes
    ----------
    problems : list of SettingProblem
    """

    def __init__(self, problems: list[SettingProblem] | SettingProblem) -> None:
        if isinstance(problems, SettingProblem):
            problems = [problems]
        self.problems = list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))

    def __reduce__(self) -> tuple[type, tuple[list[SettingProblem]]]:
        return (type(self), (self.problems,))


class DefinitionErrors(DefinitionError):
    """Several problems of one definition file, reported at once (one line each).

    Attributes
    ----------
    errors : list of DefinitionError
        The problems; ``path``, ``field``, ``problem`` and ``allowed`` are the first one's.
    """

    def __init__(self, errors: list[DefinitionError]) -> None:
        self.errors = list(errors)
        first = self.errors[0]
        super().__init__(first.path, first.field, first.problem, first.allowed)
        self.args = ("\n".join(str(e) for e in self.errors),)

    def __reduce__(self) -> tuple[type, tuple[list[DefinitionError]]]:  # type: ignore[override]
        return (type(self), (self.errors,))


class GeometryError(VfsError, ValueError):
    """A geometric configuration cannot be evaluated (e.g. degenerate outline)."""


@dataclass(frozen=True)
class DataProblem:
    """One problem found in an input table.

    Attributes
    ----------
    table : str
        Name of the table (e.g. ``"participants"`` or the input file name).
    column : str
        Column the problem sits in (``""`` for whole-row or whole-table problems).
    row : int | None
        Zero-based row index in the table, when known.
    case_id : object
        Case identifier of the offending row, when known.
    message : str
        What is wrong, including the allowed range.
    """

    table: str
    column: str
    row: int | None
    case_id: object
    message: str

    def __str__(self) -> str:
        where = [f"table '{self.table}'"]
        if self.column:
            where.append(f"column '{self.column}'")
        if self.row is not None:
            where.append(f"row {self.row}")
        if self.case_id is not None:
            case_id = self.case_id
            if hasattr(case_id, "item"):  # numpy scalar -> plain Python value
                case_id = case_id.item()
            where.append(f"case_id {case_id!r}")
        return f"{', '.join(where)}: {self.message}"


class DataError(VfsError, ValueError):
    """Input data (a table, a database, a file) is invalid.

    Carries the full list of :class:`DataProblem` records so that a user sees
    every problem at once instead of fixing them one by one.
    """

    def __init__(self, problems: list[DataProblem] | DataProblem, header: str = "") -> None:
        if isinstance(problems, DataProblem):
            problems = [problems]
        self.problems: list[DataProblem] = list(problems)
        shown = self.problems[:50]
        lines = [header or f"{len(self.problems)} problem(s) in the input data:"]
        lines += [f"  - {p}" for p in shown]
        if len(self.problems) > len(shown):
            lines.append(f"  ... and {len(self.problems) - len(shown)} more")
        super().__init__("\n".join(lines))


class DataWarning(UserWarning):
    """A plausibility warning about input data (:mod:`vfs.database.checks`).

    A real database can contain what it reports; ``--strict`` (or
    :func:`vfs.database.checks.strict_input`) turns it into a :class:`DataError`.
    The command line prints each as one ``warning:`` line.

    Attributes
    ----------
    problem : DataProblem
        Table, column, case and message.
    """

    def __init__(self, problem: DataProblem) -> None:
        self.problem = problem
        super().__init__(str(problem))


class SimulationError(VfsError, RuntimeError):
    """A simulation could not be completed for a case (recorded per case in batch runs)."""


class TargetExistsError(VfsError, FileExistsError):
    """The output path exists and does not look like a folder vfs may replace."""


class MissingExtraError(VfsError, ImportError):
    """An optional dependency of a feature is not installed; the message names the extra
    (``pip install "vfs-accident[NAME]"``).
    """


class ClusterError(VfsError, RuntimeError):
    """The workers of a cluster cannot run a study (other vfs or numpy, vfs missing)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM received: the command stops as on Ctrl-C (a study's status ``interrupted``).

    Raised by the SIGTERM handlers of :func:`vfs.cli.main` and of
    :func:`vfs.study.faults.stop_on_signals`.
    """

    #: Exit status of the command line: 128 + SIGTERM (15), as a shell reports it.
    exit_status = 143


#: numpy's floating-point RuntimeWarnings ("invalid value encountered in divide", "Mean of
#: empty slice", ...): the checks meet NaN and zero on purpose, and the user sees the
#: clear error or warning that follows, never these (:func:`quiet_numpy_warnings`).
NUMPY_WARNING_MESSAGES = (r"(invalid value|divide by zero|overflow|underflow) encountered"
                          r"|Mean of empty slice|Degrees of freedom <= 0|All-NaN (slice|axis)"
                          r"|invalid value")


def quiet_numpy_warnings() -> None:
    """Ignore numpy's floating-point RuntimeWarnings (:data:`NUMPY_WARNING_MESSAGES`) in
    this process: called by the command line (inside its warning context) and in the
    study's worker processes.
    """
    import warnings

    warnings.filterwarnings("ignore", message=NUMPY_WARNING_MESSAGES, category=RuntimeWarning)
