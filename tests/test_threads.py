"""The compute-thread setting (vfs.threads): VFS_THREADS, its range, its default, and 1 in a
study's worker processes."""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import pytest

from vfs.blas import WORKER_THREAD_VARIABLES, single_threaded_workers
from vfs.errors import SettingsError
from vfs.threads import (
    MOST_THREADS,
    THREADS_VARIABLE,
    ComputeThreads,
    available_cores,
    compute_threads,
    threads_setting,
)


@pytest.fixture
def no_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in WORKER_THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def test_default_is_one_thread_per_core_the_process_may_use(no_choice: None) -> None:
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert available_cores() == cores
    assert compute_threads() == min(cores, MOST_THREADS)
    assert compute_threads({THREADS_VARIABLE: "  "}) == compute_threads()  # empty: absent
    assert threads_setting().threads is None


def test_the_variable_sets_the_count(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(THREADS_VARIABLE, "1")
    assert compute_threads() == 1
    monkeypatch.setenv(THREADS_VARIABLE, str(MOST_THREADS))
    assert compute_threads() == MOST_THREADS


@pytest.mark.parametrize("text, problem", [
    ("0", "is out of range"), ("-2", "is out of range"),
    (str(MOST_THREADS + 1), "is out of range"), ("two", "is not an integer"),
    ("1.5", "is not an integer")])
def test_bad_values_name_the_variable_and_the_range(monkeypatch: pytest.MonkeyPatch, text: str,
                                                    problem: str) -> None:
    monkeypatch.setenv(THREADS_VARIABLE, text)
    with pytest.raises(SettingsError) as info:
        compute_threads()
    message = str(info.value)
    assert THREADS_VARIABLE in message and problem in message
    assert f"allowed: an integer in [1, {MOST_THREADS}]" in message


def test_the_declaration_checks_its_range() -> None:
    with pytest.raises(SettingsError, match=r"ComputeThreads\.threads: 0 is out of range"):
        ComputeThreads(0)
    assert ComputeThreads(MOST_THREADS).threads == MOST_THREADS


def test_duckdb_connections_take_the_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    from vfs.database import io

    monkeypatch.setenv(THREADS_VARIABLE, "1")
    con = io._connect()
    try:
        assert con.execute("SELECT current_setting('threads')").fetchone() == (1,)
    finally:
        con.close()


def test_study_worker_processes_get_one_thread(no_choice: None,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A process started as the study starts its workers (its process pool's fork server
    and dask's workers start inside single_threaded_workers) runs on one compute thread;
    a count the user chose is kept."""
    context = multiprocessing.get_context("spawn")
    with single_threaded_workers(), ProcessPoolExecutor(1, mp_context=context) as pool:
        assert pool.submit(compute_threads).result() == 1
    assert THREADS_VARIABLE not in __import__("os").environ
    monkeypatch.setenv(THREADS_VARIABLE, str(MOST_THREADS))
    with single_threaded_workers(), ProcessPoolExecutor(1, mp_context=context) as pool:
        assert pool.submit(compute_threads).result() == MOST_THREADS
