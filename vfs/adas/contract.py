"""The contract of an AEB system, written once: :class:`System` and its :class:`SystemController`.

Everything that runs a system (a study's tasks, the replay, the OpenSCENARIO
export, the gym's evaluation) takes a :class:`System`: a picklable object with
a ``name``, a ``description``, ``controller(batch, equipped)`` and
``precrash_params(base)``.  Its controller is a :class:`SystemController`
(``reset``, ``demand``: a :class:`vfs.physics.precrash.BrakeController`) and,
to keep the whole contract, also :class:`ReportsEvents` (``events()``, per case
and participant, NaN where never) and :class:`Segmentable` (``reset_segments``:
several chunks with one random stream each).  A study asks for the last two by
these Protocols (a controller without them adds no event columns and runs chunk
by chunk).  :class:`ControllerDefaults` gives a controller that records no events
and draws nothing the last two.

:func:`is_system` is the one answer to "is this a system?"; :func:`check_system`
(like gymnasium's ``check_env``) runs a system on a small batch and reports
every way it breaks the contract.  Every built-in system passes it
(``tests/adas/test_contract.py``), and so must a plugin's.
"""

from __future__ import annotations

import pickle
from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError

if TYPE_CHECKING:
    from vfs.physics.precrash import PrecrashObservation, PrecrashParams
    from vfs.simulation import CaseBatch


@runtime_checkable
class SystemController(Protocol):
    """What every system's controller does for a batch of cases
    (:class:`vfs.physics.precrash.BrakeController`).
    """

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Prepare for a batch of ``n_cases`` cases (draws from ``rng`` only)."""

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        """Demanded deceleration [m/s^2] (>= 0), shape (n, 2), for ``obs.rows``."""


@runtime_checkable
class ReportsEvents(Protocol):
    """A controller whose events become columns of a study's runs table
    (``<key>1``, ``<key>2``); one without ``events`` adds none.
    """

    def events(self) -> Mapping[str, np.ndarray]:
        """Event times [s] by key, each (N, 2) (NaN where never); ``{}`` for none."""


@runtime_checkable
class Segmentable(Protocol):
    """A controller that runs several study chunks as one batch, one random stream each;
    one without ``reset_segments`` runs chunk by chunk (same results, slower).
    """

    def reset_segments(self, sizes: tuple[int, ...],
                       generators: tuple[np.random.Generator, ...]) -> None:
        """Prepare for consecutive segments of ``sizes`` cases, one generator each."""


#: The methods of a controller that keeps the whole contract (:func:`check_system`).
CONTROLLER_METHODS: tuple[str, ...] = ("reset", "demand", "events", "reset_segments")


@runtime_checkable
class System(Protocol):
    """An AEB system as everything that runs one sees it; it must be picklable."""

    @property
    def name(self) -> str:
        """Its name in studies and reports (not ``"baseline"``)."""

    @property
    def description(self) -> str:
        """One line for reports."""

    def controller(self, batch: CaseBatch, equipped: npt.ArrayLike
                   ) -> SystemController | None:
        """A fresh controller for ``batch`` (None: no AEB); ``equipped`` (N, 2) bool."""

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``base`` with this system's brake actuator."""


class ControllerDefaults:
    """Mix-in for a controller without events and without per-chunk state.

    ``reset_segments`` resets for all segments with the first generator: right for a
    controller that draws nothing (a deterministic one); a controller that draws
    must write its own (one stream per segment keeps a study independent of how
    chunks are grouped into tasks).
    """

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        """Nothing to prepare."""

    def reset_segments(self, sizes: tuple[int, ...],
                       generators: tuple[np.random.Generator, ...]) -> None:
        """``reset(sum(sizes), generators[0])``."""
        self.reset(int(sum(sizes)), generators[0])

    def events(self) -> Mapping[str, np.ndarray]:
        """No events."""
        return {}


def is_system(obj: object) -> bool:
    """True for an object that has the attributes and methods of :class:`System`."""
    return (isinstance(getattr(obj, "name", None), str)
            and isinstance(getattr(obj, "description", None), str)
            and callable(getattr(obj, "controller", None))
            and callable(getattr(obj, "precrash_params", None)))


def contract_problems(obj: object) -> list[str]:
    """The parts of :class:`System` that ``obj`` lacks (empty when it has them all)."""
    problems = []
    if not isinstance(getattr(obj, "name", None), str) or not getattr(obj, "name", ""):
        problems.append("needs a non-empty str 'name'")
    if not isinstance(getattr(obj, "description", None), str):
        problems.append("needs a str 'description'")
    for method in ("controller", "precrash_params"):
        if not callable(getattr(obj, method, None)):
            problems.append(f"needs a method {method}()")
    return problems


def require_system(obj: object, what: str = "") -> System:
    """``obj`` as a :class:`System`.

    Raises
    ------
    ParameterError
        Naming every part of the contract it lacks.
    """
    problems = contract_problems(obj)
    if problems:
        label = what or f"{type(obj).__name__} object"
        raise ParameterError(f"{label} is not an AEB system: it " + "; ".join(problems))
    return obj  # type: ignore[return-value]


def check_system(system: object, batch: CaseBatch | None = None, *, steps: int = 0,
                 strict: bool = True) -> None:
    """Check that ``system`` keeps the whole contract (like gymnasium's ``check_env``).

    It checks the attributes, that the system pickles and unpickles to a system of
    the same name, ``precrash_params`` on the defaults, and, for a system with a
    controller, ``reset``/``reset_segments`` (same demand), ``demand`` (finite,
    >= 0, shape (n, 2)) for a few steps of the batch's first record, and
    ``events`` (each (N, 2)).

    Parameters
    ----------
    system : object
    batch : CaseBatch, optional
        Cases to run it on; default two cases of the bundled database.
    steps : int
        Check only the first ``steps`` demands (0: all).
    strict : bool
        Require ``events`` and ``reset_segments`` too (:data:`CONTROLLER_METHODS`); with
        False they are checked where present.

    Raises
    ------
    ParameterError
        Listing every problem found.
    """
    from vfs.physics.precrash import PrecrashParams

    require_system(system)
    sys_ = system  # narrowed by require_system
    problems: list[str] = []
    try:
        copy = pickle.loads(pickle.dumps(sys_))
        if getattr(copy, "name", None) != sys_.name:  # type: ignore[attr-defined]
            problems.append("does not unpickle to a system of the same name")
    except Exception as exc:  # any failure to pickle is a broken contract
        problems.append(f"does not pickle ({type(exc).__name__}: {exc})")
    base = PrecrashParams()
    params = sys_.precrash_params(base)  # type: ignore[attr-defined]
    if not isinstance(params, PrecrashParams):
        problems.append(f"precrash_params() returned {type(params).__name__}, not "
                        "PrecrashParams")
    if batch is None:
        batch = _sample_batch()
    equipped = np.ones((batch.size, 2), dtype=bool)
    controller = sys_.controller(batch, equipped)  # type: ignore[attr-defined]
    if controller is not None:
        problems += _controller_problems(controller, sys_, batch, equipped, steps, strict)
    if problems:
        raise ParameterError(f"AEB system {sys_.name!r} breaks the contract: "  # type: ignore[attr-defined]
                             + "; ".join(problems))


class _Recorder:
    """A controller that forwards to another and keeps every demand it returned."""

    def __init__(self, inner: SystemController) -> None:
        self.inner = inner
        self.demands: list[np.ndarray] = []

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        self.inner.reset(n_cases, rng)

    def reset_segments(self, sizes: tuple[int, ...],
                       generators: tuple[np.random.Generator, ...]) -> None:
        if isinstance(self.inner, Segmentable):
            self.inner.reset_segments(sizes, generators)

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        d = np.asarray(self.inner.demand(obs), dtype=float)
        self.demands.append(d)
        return d


def _controller_problems(controller: object, system: object, batch: CaseBatch,
                         equipped: np.ndarray, steps: int, strict: bool) -> list[str]:
    from vfs.physics.precrash import SegmentedRandom
    from vfs.simulation import SimulationParams, simulate_cases

    required = CONTROLLER_METHODS if strict else CONTROLLER_METHODS[:2]
    missing = [m for m in required if not callable(getattr(controller, m, None))]
    if missing:
        return [f"its controller ({type(controller).__name__}) has no "
                + ", ".join(f"{m}()" for m in missing)
                + " (vfs.adas.contract.ControllerDefaults gives events and reset_segments)"]
    problems: list[str] = []
    n = batch.size
    params = SimulationParams(precrash=system.precrash_params(  # type: ignore[attr-defined]
        SimulationParams().precrash))
    plain = _Recorder(controller)  # type: ignore[arg-type]
    simulate_cases(batch, plain, params, rng=np.random.default_rng(0))
    segmented = _Recorder(system.controller(batch, equipped))  # type: ignore[attr-defined]
    if isinstance(controller, Segmentable):
        simulate_cases(batch, segmented, params,
                       rng=SegmentedRandom.of((n,), [np.random.default_rng(0)]))
    else:
        segmented.demands = plain.demands
    for d in plain.demands[:steps] if steps else plain.demands:
        if d.ndim != 2 or d.shape[1] != 2:
            problems.append(f"demand() has shape {d.shape}, expected (n, 2)")
            break
        if not (np.all(np.isfinite(d)) and np.all(d >= 0.0)):
            problems.append("demand() is not finite and >= 0")
            break
    same = len(plain.demands) == len(segmented.demands) and all(
        np.array_equal(a, b) for a, b in zip(plain.demands, segmented.demands, strict=True))
    if not problems and not same:
        problems.append("reset_segments((n,), [rng]) does not give the demands of "
                        "reset(n, rng)")
    events = plain.inner.events() if isinstance(plain.inner, ReportsEvents) else {}
    if not isinstance(events, Mapping):
        problems.append(f"events() returned {type(events).__name__}, not a mapping")
    else:
        for key, values in events.items():
            if np.shape(values) != (n, 2):
                problems.append(f"event {key!r} has shape {np.shape(values)}, expected "
                                f"({n}, 2)")
    return problems


def _sample_batch() -> CaseBatch:
    from vfs.database import load_database
    from vfs.database.source import database_location
    from vfs.simulation import CaseBatch

    db = load_database(database_location("default"))
    return CaseBatch.from_database(db, db.case_ids[:2])


__all__ = ["CONTROLLER_METHODS", "ControllerDefaults", "ReportsEvents", "Segmentable",
           "System", "SystemController", "check_system", "contract_problems", "is_system",
           "require_system"]
