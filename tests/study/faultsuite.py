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
from typing import Any

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


def _handlers_ready(proc: subprocess.Popen[Any], deadline: float) -> float:
    """Wait until process ``proc`` catches SIGTERM (``SigCgt`` of /proc/PID/status): the
    first line of ``vfs/__main__.py`` has run.  Seconds waited."""
    started = time.monotonic()
    bit = 1 << (signal.SIGTERM - 1)
    status = Path(f"/proc/{proc.pid}/status")
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            for line in status.read_text().splitlines():
                if line.startswith("SigCgt:") and int(line.split()[1], 16) & bit:
                    return time.monotonic() - started
        except (OSError, ValueError):
            return time.monotonic() - started
        time.sleep(0.01)
    return time.monotonic() - started


def run_cli(argv: list[str], *, cwd: str | os.PathLike[str], limit_s: float,
            sig: int | None = None, at_s: float = 0.0, group: bool = False,
            env: dict[str, str] | None = None, after_ready: bool = True) -> CliRun:
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
    after_ready : bool
        Count ``at_s`` from the moment the process catches SIGTERM (its first line
        of vfs code has run; before, while Python starts and imports the ``vfs``
        package, a signal has Python's default effect: SIGINT a KeyboardInterrupt
        traceback, SIGTERM the end of the process), else from its start.
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
            ready = _handlers_ready(proc, started + limit_s) if after_ready else 0.0
            try:
                code = proc.wait(timeout=at_s)
            except subprocess.TimeoutExpired:
                try:
                    if group:
                        os.killpg(pgid, sig)
                    else:
                        os.kill(proc.pid, sig)
                    where = " (group)" if group else ""
                    sent = (f"{signal.Signals(sig).name}{where} at {at_s:.2f} s after "
                            f"{ready:.2f} s of start-up")
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




# ----------------------------------------------------------------------------
# The generated bad inputs (nothing stored: each is made from the bundled database)
# ----------------------------------------------------------------------------

#: Tables of a database folder, in file units.
TABLES = ("cases", "participants", "trajectories", "reconstruction")


@dataclass(frozen=True)
class BadInput:
    """One generated bad input and what the user must see.

    Attributes
    ----------
    name : str
        Row of the suite's table.
    argv : tuple of str
        Arguments after ``python -m vfs``.
    expect : str
        ``CLEAR`` (an error), ``WARN`` or ``OK``.
    words : str
        Text the message must hold (names the problem).
    limit_s : float
        Seconds within which the command must end (the no-hang guard).
    """

    name: str
    argv: tuple[str, ...]
    expect: str
    words: str
    limit_s: float = 120.0


def small_database(folder: Path, cases: int = 12) -> Path:
    """The first ``cases`` cases of the bundled database, as a Parquet folder."""
    from vfs.database import open_database, save_database

    if not (folder / "cases.parquet").exists():
        save_database(open_database("default", where=f"case_id <= {cases}"), folder)
    return folder


def edited_database(base: Path, out: Path, edit: Any) -> Path:
    """A copy of ``base`` with ``edit(frames)`` applied to its tables (file units);
    ``edit`` may return ``{table: pyarrow.Table}`` to write instead of the frames."""
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(base, out)
    frames = {name: pq.read_table(out / f"{name}.parquet").to_pandas() for name in TABLES}
    raw = edit(frames) or {}
    for name, df in frames.items():
        table = raw.get(name, pa.Table.from_pandas(df, preserve_index=False))
        pq.write_table(table, out / f"{name}.parquet")
    return out


def _ms_time(frames: dict[str, Any]) -> None:
    frames["trajectories"]["t"] = frames["trajectories"]["t"] * 1000.0


def _date_time(frames: dict[str, Any]) -> None:
    import pandas as pd

    frames["trajectories"]["t"] = pd.to_datetime(frames["trajectories"]["t"], unit="s")


def _twice(frames: dict[str, Any]) -> dict[str, Any]:
    import pyarrow as pa

    tr = pa.Table.from_pandas(frames["trajectories"], preserve_index=False)
    return {"trajectories": pa.Table.from_arrays([*tr.columns, tr.column("x")],
                                                 names=[*tr.column_names, "x"])}


def _near_miss_collides(frames: dict[str, Any]) -> None:
    import pandas as pd

    cases, tr = frames["cases"], frames["trajectories"]
    case = int(cases.loc[~cases["collision"].astype(bool), "case_id"].iloc[0])
    one = tr[(tr["case_id"] == case) & (tr["participant"] == 1)]
    two = one.copy()  # participant 2 waits where participant 1's record ends
    two["participant"] = 2
    for col in ("x", "y", "yaw"):
        two[col] = one[col].iloc[-1]
    two[["speed", "accel"]] = 0.0
    rest = tr[~((tr["case_id"] == case) & (tr["participant"] == 2))]
    frames["trajectories"] = pd.concat([rest, two]).sort_values(
        ["case_id", "participant", "t"], kind="stable")


def _text_ids(frames: dict[str, Any]) -> None:
    for df in frames.values():
        df["case_id"] = [f"Fall-{i}" for i in df["case_id"]]


def _fifty_g(frames: dict[str, Any]) -> None:
    frames["trajectories"]["accel"] = 50 * 9.81


DATABASE_EDITS = {
    "trajectory time in milliseconds": (_ms_time, "CLEAR", "time in milliseconds"),
    "trajectory time as dates": (_date_time, "CLEAR", "t"),
    "Parquet file with two columns of one name": (_twice, "CLEAR", "appears twice"),
    "near miss whose trajectories collide": (_near_miss_collides, "WARN",
                                             "labelled a near miss"),
    "text case ids": (_text_ids, "CLEAR", "case ids are integers"),
    "accel 50 g": (_fifty_g, "CLEAR", "column 'accel'"),
}


def impact_row(**change: float) -> dict[str, float]:
    """A plausible car-to-car side impact [SI], 1,500 and 1,750 kg."""
    import math

    row = dict(case_id=1, m1=1500.0, izz1=2500.0, x1=0.0, y1=0.0, yaw1=0.0, vx1=14.0, vy1=0.0,
               yaw_rate1=0.0, m2=1750.0, izz2=3000.0, x2=3.2, y2=-2.0, yaw2=math.pi / 2,
               vx2=0.0, vy2=10.0, yaw_rate2=0.0, poi_x=2.2, poi_y=-0.6, cp_angle=0.0,
               restitution=0.1, contact_friction=0.3)
    row.update(change)
    return row


IMPACT_EDITS = {
    "impact: plausible side impact": ({}, "OK", ""),
    "impact: contact plane in degrees": ({"cp_angle": 90.0}, "WARN", "cp_angle"),
    "impact: yaw rates in deg/s": ({"yaw_rate1": 25.0, "yaw_rate2": -12.0}, "WARN",
                                   "deg/s"),
    "impact: urban speeds in km/h": ({"vx1": 50.0, "vy2": 40.0}, "WARN", "km/h"),
    "impact: CGs 100 m apart": ({"x2": 100.0, "poi_x": 99.0}, "WARN", "can touch"),
    "impact: truck at 120 km/h": ({"m2": 18000.0, "izz2": 150000.0, "vy2": 33.3}, "WARN",
                                  "speed limiter"),
}


def bad_inputs(root: Path, engine: str = "process") -> list[BadInput]:
    """Write every generated bad input under ``root``; the commands that read them."""
    import pandas as pd

    base = small_database(root / "small")
    runs = []
    for i, (name, (edit, expect, words)) in enumerate(DATABASE_EDITS.items()):
        db = edited_database(base, root / f"db{i}", edit)
        argv = ("study", "--db", str(db), "--systems", "three-stage", "--engine", engine,
                "--workers", "2", "--out", str(root / f"study{i}-{engine}"))
        runs.append(BadInput(f"{name} (study, {engine})", argv, expect, words))
    for i, (name, (change, expect, words)) in enumerate(IMPACT_EDITS.items()):
        file = root / f"impact{i}.csv"
        pd.DataFrame([impact_row(**change)]).to_csv(file, index=False)
        runs.append(BadInput(name, ("impact", "--input", str(file), "--output",
                                    str(root / f"impact{i}-out.parquet")), expect, words))
    dup = root / "impact-dup.csv"
    row = impact_row()
    dup.write_text(",".join([*row, "m1"]) + "\n"
                   + ",".join(str(v) for v in [*row.values(), 1600.0]) + "\n")
    runs.append(BadInput("impact: a column twice", ("impact", "--input", str(dup), "--output",
                                                     str(root / "impact-dup.parquet")),
                         "CLEAR", "twice"))
    return runs


def judge(bad: BadInput, run: CliRun) -> str:
    """The suite's outcome of a bad input: its class, or ``WRONG`` when the message does not
    name the problem (or the class is not the one expected)."""
    outcome = classify(run, expect_word=bad.expect != "OK")
    if outcome in ("HANG", "TRACEBACK", "SILENT"):
        return outcome
    if "RuntimeWarning" in run.stderr:
        return "LEAK"
    if outcome != bad.expect or bad.words not in run.stderr:
        return f"WRONG ({outcome})"
    return outcome



# ----------------------------------------------------------------------------
# Faults: signals at random moments
# ----------------------------------------------------------------------------

#: The faults: name -> (signal, to the whole process group?).
FAULTS = {
    "SIGINT (Ctrl-C, group)": (signal.SIGINT, True),
    "SIGTERM (kill PID)": (signal.SIGTERM, False),
    "SIGTERM (group)": (signal.SIGTERM, True),
    "SIGKILL (kill -9 PID)": (signal.SIGKILL, False),
}


@dataclass(frozen=True)
class FaultResult:
    """One fault: what the study did, and whether ``--resume`` then completed it."""

    fault: str
    at_s: float
    run: CliRun
    status: str  # the manifest's status after the fault ("" without a manifest)
    resumed: str  # "complete", "not run" or what went wrong

    @property
    def outcome(self) -> str:
        """``HANG``, ``ORPHAN``, ``TRACEBACK``, ``NO-RESUME-HINT``, ``RESUME-FAILED`` or
        ``CLEAN`` (stopped or finished, nothing left behind, resumable)."""
        if self.run.hung:
            return "HANG"
        if self.run.orphans:
            return "ORPHAN"
        if self.run.traceback:
            return "TRACEBACK"
        if self.status == "interrupted" and "--resume" not in self.run.stderr:
            return "NO-RESUME-HINT"
        if self.resumed not in ("complete", "not run"):
            return "RESUME-FAILED"
        return "CLEAN"


def study_argv(out: Path, cases: int = 120, workers: int = 2) -> list[str]:
    """A parallel study of the first ``cases`` bundled cases in chunks of 20."""
    return ["study", "--db", "default", "--where", f"case_id <= {cases}", "--systems",
            "three-stage", "--engine", "process", "--workers", str(workers), "--chunk-size",
            "20", "--out", str(out)]


def fault_run(fault: str, at_s: float, out: Path, *, cwd: str | os.PathLike[str],
              cases: int = 120, resume: bool = True, limit_s: float = 300.0) -> FaultResult:
    """Run the study of :func:`study_argv`, send ``fault`` at ``at_s`` s, then resume it."""
    import json
    import shutil

    shutil.rmtree(out, ignore_errors=True)
    sig, group = FAULTS[fault]
    run = run_cli(study_argv(out, cases), cwd=cwd, limit_s=limit_s, sig=sig, at_s=at_s,
                  group=group)
    manifest = out / "study.json"
    status = ""
    if manifest.exists():
        try:
            status = str(json.loads(manifest.read_text()).get("status", ""))
        except ValueError:
            status = "unreadable"
    resumed = "not run"
    if resume and not run.hung and status != "complete":
        again = run_cli([*study_argv(out, cases), "--resume"], cwd=cwd, limit_s=limit_s)
        if again.code == 0 and json.loads(manifest.read_text()).get("status") == "complete":
            resumed = "complete"
        else:
            resumed = (f"exit {again.code}: "
                       f"{(again.stderr.strip().splitlines() or [''])[-1][:200]}")
    return FaultResult(fault, at_s, run, status, resumed)


__all__ = ["DATABASE_EDITS", "FAULTS", "IMPACT_EDITS", "ORPHAN_GRACE_S", "BadInput", "CliRun",
           "FaultResult", "bad_inputs", "classify", "edited_database", "fault_run",
           "impact_row", "judge", "run_cli", "small_database", "study_argv",
           "with_suppress_kill"]
