"""The AEB-system contract (vfs.adas.contract): every built-in and the example plugin keep
it, check_system finds each way of breaking it, and a study's lookup names what is missing."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from vfs.adas import SYSTEMS, System, check_system, get_system
from vfs.adas.contract import ControllerDefaults, ReportsEvents, Segmentable, is_system
from vfs.adas.systems import python_system
from vfs.database import load_database
from vfs.database.source import database_location
from vfs.errors import ParameterError
from vfs.physics.precrash import PrecrashObservation, PrecrashParams
from vfs.simulation import CaseBatch
from vfs.study.systems import resolve_system, resolve_systems

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def batch() -> CaseBatch:
    db = load_database(database_location("default"))
    return CaseBatch.from_database(db, db.case_ids[:3])


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_every_builtin_system_keeps_the_whole_contract(name: str, batch: CaseBatch) -> None:
    system = get_system(name)
    assert isinstance(system, System) and is_system(system)
    check_system(system, batch)
    controller = system.controller(batch, np.ones((batch.size, 2), bool))
    assert controller is None or (isinstance(controller, ReportsEvents)
                                  and isinstance(controller, Segmentable))


def test_the_example_plugin_keeps_the_whole_contract(batch: CaseBatch) -> None:
    check_system(python_system(ROOT / "adas" / "example_controller.py"), batch)


class _Demanding(ControllerDefaults):
    def __init__(self, value: float, shape: tuple[int, ...] | None = None) -> None:
        self.value, self.shape = value, shape

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        return np.full(self.shape or (obs.rows.shape[0], 2), self.value)


class _Bare:
    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        pass

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        return np.zeros((obs.rows.shape[0], 2))


@dataclasses.dataclass(frozen=True)
class _System:
    make: object
    name: str = "test-system"
    description: str = "for the tests"

    def controller(self, batch, equipped):  # noqa: ANN001, ANN201
        return self.make()  # type: ignore[operator]

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        return base


def _negative() -> _Demanding:
    return _Demanding(-1.0)


def _nan() -> _Demanding:
    return _Demanding(np.nan)


@pytest.mark.parametrize(("make", "problem"), [
    (_negative, "demand() is not finite and >= 0"),
    (_nan, "demand() is not finite and >= 0"),
    (_Bare, "has no events(), reset_segments()"),
])
def test_check_system_names_each_broken_part(make: object, problem: str,
                                             batch: CaseBatch) -> None:
    with pytest.raises(ParameterError, match=problem.replace("(", r"\(").replace(")", r"\)")):
        check_system(_System(make), batch)


def test_a_bare_controller_passes_the_lenient_check(batch: CaseBatch) -> None:
    check_system(_System(_Bare), batch, strict=False)  # a study runs it chunk by chunk


def test_a_system_that_does_not_pickle_is_named(batch: CaseBatch) -> None:
    local = _System(lambda: _Demanding(0.0))  # a lambda does not pickle
    with pytest.raises(ParameterError, match="does not pickle"):
        check_system(local, batch)


def test_the_lookup_names_every_missing_part() -> None:
    class Half:
        name = "half"

    with pytest.raises(ParameterError, match="needs a str 'description'; needs a method "
                                             "controller\\(\\); needs a method "
                                             "precrash_params\\(\\)"):
        resolve_system("half", {"half": Half()})
    with pytest.raises(ParameterError, match="is not an AEB system"):
        resolve_systems([Half()], None)  # type: ignore[list-item]
