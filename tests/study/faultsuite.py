"""A corruption and fault harness for the command line (used by tests and benchmarks).

:func:`run_cli` runs ``python -m vfs ...`` in its own process group, optionally
sends a signal at a given moment (SIGINT to the whole group as a terminal's
Ctrl-C does, SIGTERM or SIGKILL to the study process as ``kill`` does), ends it
after a time limit (a *hang*), and afterwards checks that no process of the
group outlived it (an *orphan*: a worker, the fork server, the resource
tracker).  :func:`classify` turns the result into one of the outcomes of the
suite's table: ``CLEAR`` (a non-zero exit with an error line naming the
problem), ``OK`` (exit 0 and no warning), ``WARN`` (exit 0 with a warning
line), ``SILENT`` (exit 0 without a word where one was expected),
``TRACEBACK`` and ``HANG``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import psutil

#: Seconds the processes of a stopped study may take to end (worker watchdog 0.5 s).
ORPHAN_GRACE_S = 5.0


@dataclass(frozen=True)
class CliRun:
    """What one command line run did."""

    argv: tuple[str, ...]
    code: int | None  # None: it hung and was killed
    stdout: str
    stderr: str
    wall_s: float
    orphans: tuple[str, ...]  # processes of its group alive ORPHAN_GRACE_S after it ended
    signal_sent: str = ""

    @property
    def traceback(self) -> bool:
        text = self.stdout + self.stderr
        return "Traceback" in text or "Fatal Python error" in text

    @property
    def hung(self) -> bool:
        return self.code is None


def _group_alive(pgid: int) -> list[str]:
    alive = []
    for proc in psutil.process_iter(["pid", "name", "cmdline", "status"]):
        try:
            if os.getpgid(proc.pid) == pgid and proc.info["status"] != psutil.STATUS_ZOMBIE:
                alive.append(f"{proc.pid} {' '.join(proc.info['cmdline'] or [])[:120]}")
        except (ProcessLookupError, psutil.Error, OSError):
            continue
    return alive


def run_cli(argv: list[str], *, cwd: str | os.PathLike[str], limit_s: float,
            sig: int | None = None, at_s: float = 0.0, group: bool = False,
            env: dict[str, str] | None = None) -> CliRun:
    """Run ``python -m vfs *argv`` in a new process group (see the module's description).

    Parameters
    ----------
    argv : list of str
        Arguments after ``python -m vfs``.
    cwd : path
        Working directory (the repository root, so that its ``vfs`` is imported).
    limit_s : float
        Wall-clock seconds after which the run counts as hung and is killed.
    sig : int, optional
        Signal to send ``at_s`` seconds after the start.
    group : bool
        Send ``sig`` to the whole process group (a terminal's Ctrl-C), else to the
        study process only (``kill PID``).
    """
    import tempfile

    out_dir = Path(cwd)
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        started = time.monotonic()
        proc = subprocess.Popen([sys.executable, "-m", "vfs", *argv], cwd=out_dir,
                                stdout=out, stderr=err, start_new_session=True,
                                env={**os.environ, **(env or {})})
        pgid = proc.pid
        sent = ""
        code: int | None = None
        if sig is not None:
            try:
                code = proc.wait(timeout=at_s)
            except subprocess.TimeoutExpired:
                try:
                    if group:
                        os.killpg(pgid, sig)
                    else:
                        os.kill(proc.pid, sig)
                    where = " (group)" if group else ""
                    sent = f"{signal.Signals(sig).name}{where} at {at_s:.2f} s"
                except ProcessLookupError:
                    pass
        if code is None:
            try:
                code = proc.wait(timeout=max(0.1, limit_s - (time.monotonic() - started)))
            except subprocess.TimeoutExpired:
                code = None
        wall = time.monotonic() - started
        if code is None:  # hung: end it and all of its group
            if (env or {}).get("PYTHONFAULTHANDLER"):  # its threads' stacks to stderr
                os.kill(proc.pid, signal.SIGABRT)
                time.sleep(1.0)
            with_suppress_kill(pgid)
            proc.wait()
        deadline = time.monotonic() + ORPHAN_GRACE_S
        orphans = _group_alive(pgid)
        while orphans and time.monotonic() < deadline:
            time.sleep(0.1)
            orphans = _group_alive(pgid)
        if orphans:
            with_suppress_kill(pgid)
        out.seek(0)
        err.seek(0)
        return CliRun(tuple(argv), code, out.read(), err.read(), wall, tuple(orphans), sent)


def with_suppress_kill(pgid: int) -> None:
    """SIGKILL to every process of group ``pgid`` (clean-up after a hang or orphans)."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def classify(run: CliRun, *, expect_word: bool = True) -> str:
    """The outcome of a bad-input run: HANG, TRACEBACK, CLEAR, WARN, OK or SILENT.

    Parameters
    ----------
    expect_word : bool
        Whether the input is bad (exit 0 without a warning is then SILENT, else OK).
    """
    if run.hung:
        return "HANG"
    if run.traceback:
        return "TRACEBACK"
    text = run.stderr
    if run.code != 0:
        return "CLEAR" if "error" in text.lower() else "SILENT"
    if "warning" in text.lower():
        return "WARN"
    return "SILENT" if expect_word else "OK"


__all__ = ["ORPHAN_GRACE_S", "CliRun", "classify", "run_cli", "with_suppress_kill"]
