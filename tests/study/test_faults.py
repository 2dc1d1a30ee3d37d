"""Faults of a study end in one clear line, a non-zero exit code and a resumable folder."""

from __future__ import annotations

import errno
import json
import os
import socket
import subprocess
import sys

import pandas as pd
import pytest

import vfs.study.run as study_run
from vfs.cli import main
from vfs.errors import ParameterError
from vfs.study import load_study, run_study

WHERE = "case_id <= 30"


def _study(out, **kw):
    return run_study("default", ["three-stage"], out, engine="serial", where=WHERE,
                     chunk_size=10, progress=False, **kw)


def test_a_folder_in_use_is_refused_and_a_stale_lock_taken_over(tmp_path):
    out = tmp_path / "s"
    lock = study_run.lock_path(out)
    # a live owner: this test's parent process
    lock.write_text(json.dumps({"pid": os.getppid(), "host": socket.gethostname(),
                                "started": "now"}))
    with pytest.raises(ParameterError, match=f"in use by process {os.getppid()}"):
        _study(out)
    # a dead owner: a finished child process's pid
    child = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                           capture_output=True, text=True, check=True)
    lock.write_text(json.dumps({"pid": int(child.stdout), "host": socket.gethostname(),
                                "started": "then"}))
    result = _study(out)
    assert result.complete and not lock.exists()  # taken over, then released


def test_a_full_disk_marks_the_study_failed_and_resume_completes_it(tmp_path, monkeypatch,
                                                                     capsys):
    out = tmp_path / "s"
    real = study_run.write_table

    def full_disk(path, table, *args, **kwargs):
        if str(path).endswith("runs.parquet"):
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, table, *args, **kwargs)

    monkeypatch.setattr(study_run, "write_table", full_disk)
    code = main(["study", "--db", "default", "--where", WHERE, "--systems", "three-stage",
                 "--engine", "serial", "--chunk-size", "10", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1
    assert err.strip().splitlines() == [f"error: No space left on device ({out}/runs.parquet)"]
    manifest = json.loads((out / "study.json").read_text())
    assert manifest["status"] == "failed" and "No space left" in manifest["error"]
    assert not study_run.lock_path(out).exists()
    monkeypatch.setattr(study_run, "write_table", real)
    resumed = _study(out, resume=True)
    fresh = _study(tmp_path / "fresh")
    assert resumed.complete
    pd.testing.assert_frame_equal(resumed.table, fresh.table)


def test_an_incomplete_study_has_its_own_exit_code(tmp_path, monkeypatch, capsys):
    out = tmp_path / "s"
    partial = _study(out, max_chunks=1)
    assert not partial.complete and load_study(out).manifest["status"] == "incomplete"
    import vfs.study

    monkeypatch.setattr(vfs.study, "run_study", lambda *a, **k: partial)
    code = main(["study", "--db", "default", "--systems", "three-stage", "--out", str(out),
                 "--resume"])
    assert code == study_run.EXIT_INCOMPLETE == 3
    assert "incomplete" in capsys.readouterr().err
