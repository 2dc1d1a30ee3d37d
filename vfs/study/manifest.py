"""The study folder: manifest (``study.json``), hashes, resume rules, reading a study.

Layout of a study folder::

    study.json             manifest (inputs, hashes, versions, status, summary)
    cases.parquet          the selected rows of the database's cases table
    chunks/chunk_*.parquet one table per chunk (kept for --resume)
    runs.parquet           all chunks combined (written when every chunk is done)
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import platform
import shutil
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database import Database
from vfs.database.metadata import read_parquet_with_units
from vfs.errors import DataError, DataProblem, ParameterError, SimulationError, VfsError
from vfs.study.layout import (
    BASELINE,
    CHUNK_DIR,
    MANIFEST_FILE,
    MANIFEST_FORMAT,
    RESUME_KEYS,
    RUNS_FILE,
)
from vfs.study.tasks import normalise_runs


def _sha256(parts: Iterable[bytes]) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(part)
    return h.hexdigest()


def case_ids_hash(case_ids: Sequence[object] | np.ndarray) -> str:
    """SHA-256 of the case ids in order (JSON of the list)."""
    ids = [v.item() if isinstance(v, np.generic) else v for v in np.asarray(case_ids).tolist()]
    return _sha256([json.dumps(ids).encode()])


def data_hash(db: Database) -> str:
    """SHA-256 of the contents of a database's four tables (format independent)."""
    parts = []
    for name, df in db.tables().items():
        parts.append(name.encode())
        parts.append(",".join(map(str, df.columns)).encode())
        parts.append(pd.util.hash_pandas_object(df, index=False).to_numpy().tobytes())
    return _sha256(parts)


def environment_versions() -> dict[str, str]:
    """Versions of vfs, Python and the libraries that determine the numbers."""
    import pyarrow

    from vfs.version import __version__

    versions = {"vfs": __version__, "python": platform.python_version(),
                "numpy": np.__version__, "pandas": pd.__version__,
                "pyarrow": pyarrow.__version__, "platform": platform.platform()}
    return versions


def now() -> str:
    """The current UTC time, ISO 8601 to the second."""
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def read_manifest(folder: str | os.PathLike[str]) -> dict[str, Any]:
    """``study.json`` of a study folder.

    Raises
    ------
    DataError
        If the folder holds no study manifest.
    """
    file = Path(folder) / MANIFEST_FILE
    try:
        manifest = json.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{folder} is not a study folder (no {MANIFEST_FILE})")
                        ) from None
    except (OSError, ValueError) as exc:
        raise DataError(DataProblem("study", "", None, None,
                                    f"cannot read {file}: {exc}")) from None
    if not isinstance(manifest, dict) or manifest.get("format") != MANIFEST_FORMAT:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{file} is not a vfs study manifest"))
    return manifest


def prepare_folder(out: Path, manifest: dict[str, Any], resume: bool,
                    overwrite: bool) -> dict[str, Any]:
    """Check / create the output folder; return the manifest to use.

    Raises
    ------
    ParameterError
        ``out`` is a file or a non-empty folder that is no study, holds a study
        and neither ``resume`` nor ``overwrite`` is set, or a resume with other
        inputs (:data:`RESUME_KEYS`).
    """
    has_study = (out / MANIFEST_FILE).exists()
    # a study killed before its manifest was in place leaves at most a temporary file
    non_empty = out.exists() and (not out.is_dir() or any(
        not (p.name.startswith(".") and ".tmp-" in p.name) for p in out.iterdir()))
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{out} exists and is not a folder")
    if non_empty and not has_study:
        raise ParameterError(f"{out} is a non-empty folder that is not a study; choose another "
                             "--out (nothing is overwritten there)")
    if resume and has_study:
        old = read_manifest(out)
        # a parallel study puts its data hash into the manifest before its first chunk
        # (vfs.study.run); one that stopped before has none and nothing to keep
        unhashed = not old.get("data_hash") and not any((out / CHUNK_DIR).glob("*.parquet"))
        diffs = [k for k in RESUME_KEYS if old.get(k) != manifest.get(k)
                 and not (k == "data_hash" and unhashed)]
        if diffs:
            lines = [f"  {k}: study has {old.get(k)!r}, now {manifest.get(k)!r}" for k in diffs]
            raise ParameterError(f"cannot resume {out}: the study was started with other "
                                 "inputs:\n" + "\n".join(lines)
                                 + "\n(use --overwrite to start over)")
        merged = {**manifest, "created": old.get("created", manifest["created"])}
        merged["history"] = [*old.get("history", []), {"resumed": now()}]
        for tmp in [*out.glob(".*.tmp-*"), *(out / CHUNK_DIR).glob(".*.tmp-*")]:
            tmp.unlink(missing_ok=True)  # leftovers of an interrupted write
        return merged
    if has_study and not overwrite and _nothing_to_keep(out):
        overwrite = True  # a study stopped before its first chunk: a rerun starts it anew
    if has_study and not overwrite:
        raise ParameterError(f"{out} already holds a study; use --resume to continue it or "
                             "--overwrite to replace it")
    if has_study:
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    return manifest


def _nothing_to_keep(out: Path) -> bool:
    """True for a study folder that ended ``failed`` or ``interrupted`` before writing a
    chunk (e.g. refused for bad input): a rerun after the fix need not say ``--overwrite``.
    """
    try:
        status = read_manifest(out).get("status")
    except (OSError, ValueError, VfsError):
        return False
    return status in ("failed", "interrupted") and not any((out / CHUNK_DIR).glob("*.parquet"))


@dataclass(frozen=True)
class StudyResult:
    """Outcome of :func:`run_study` (or :func:`load_study`).

    Attributes
    ----------
    path : Path
        Study folder.
    table : pandas.DataFrame or None
        ``runs.parquet``: one row per (case, system); None while the study is
        incomplete.
    manifest : dict
        Contents of ``study.json``.
    """

    path: Path
    table: pd.DataFrame | None
    manifest: dict[str, Any]

    @property
    def complete(self) -> bool:
        """All chunks done and ``runs.parquet`` written."""
        return self.manifest.get("status") == "complete" and self.table is not None

    def summary(self) -> str:
        """A few lines for people: cases, systems, crashes avoided, time."""
        m = self.manifest
        s = m.get("summary", {})
        lines = [f"study {self.path}: {m.get('n_cases')} cases, systems "
                 f"{', '.join(m.get('system_names', []))} (equip {m.get('equip')}), "
                 f"status {m.get('status')}"]
        if not self.complete:
            lines.append(f"  {s.get('chunks_done', 0)} of {m.get('n_chunks')} chunks done; "
                         "continue with --resume")
        for name, row in s.get("systems", {}).items():
            lines.append(f"  {name:>16s}: {row['crashes']} crashes of {row['cases']} cases"
                         + (f", {row['avoided']} of {row['baseline_crashes']} baseline crashes "
                            "avoided" if name != BASELINE else "")
                         + (f", {row['errors']} failed" if row["errors"] else ""))
        if "elapsed_s" in s:
            lines.append(f"  {s['cases_run']} cases simulated in {s['elapsed_s']:.1f} s "
                         f"({s['cases_per_s']:.0f} cases/s, "
                         f"{len(m.get('system_names', [])) + 1} runs per case)")
        return "\n".join(lines)


def counts_summary(runs: pd.DataFrame, names: Sequence[str]) -> dict[str, Any]:
    """Crashes and avoided crashes per system (cases where both runs succeeded)."""
    base = runs[runs["system"] == BASELINE].set_index("case_id")
    out: dict[str, Any] = {}
    for name in (BASELINE, *names):
        t = runs[runs["system"] == name].set_index("case_id")
        ok = (t["error"] == "") & (base["error"].reindex(t.index) == "")
        b_crash = base["collided"].reindex(t.index).fillna(False).to_numpy(bool) & ok.to_numpy()
        t_crash = t["collided"].fillna(False).to_numpy(bool) & ok.to_numpy()
        out[name] = {"cases": int(ok.sum()), "errors": int((t["error"] != "").sum()),
                     "crashes": int(t_crash.sum()), "baseline_crashes": int(b_crash.sum()),
                     "avoided": int((b_crash & ~t_crash).sum())}
    return out


def combine_chunks(folder: Path, case_ids: np.ndarray, systems: Sequence[str]) -> pd.DataFrame:
    """The runs table from the chunk files, checked for completeness and duplicates."""
    files = sorted((folder / CHUNK_DIR).glob("chunk_*.parquet"))
    # the chunk frames live only until concatenated (memory: a 100,000-case study)
    table = normalise_runs(pd.concat([pd.read_parquet(f) for f in files], ignore_index=True),
                           None)
    expected = pd.MultiIndex.from_product([pd.Index(case_ids, name="case_id"),
                                           pd.Index(list(systems), name="system")])
    got = pd.MultiIndex.from_frame(table[["case_id", "system"]])
    if got.has_duplicates or len(got) != len(expected) or not got.equals(expected):
        dup = int(got.duplicated().sum())
        missing = len(expected.difference(got))
        raise SimulationError(f"chunks in {folder / CHUNK_DIR} do not add up to the study: "
                              f"{dup} duplicate and {missing} missing (case, system) rows")
    return table.reset_index(drop=True)


def load_study(folder: str | os.PathLike[str]) -> StudyResult:
    """Read a study folder (manifest and, if complete, ``runs.parquet``).

    Raises
    ------
    DataError
        If the folder is not a study.
    """
    path = Path(folder)
    manifest = read_manifest(path)
    runs = path / RUNS_FILE
    table = read_parquet_with_units(runs) if runs.exists() and \
        manifest.get("status") == "complete" else None
    return StudyResult(path, table, manifest)


def read_runs(source: str | os.PathLike[str]) -> pd.DataFrame:
    """The runs of a study (``runs.parquet``) with units and descriptions in ``attrs``.

    Parameters
    ----------
    source : path
        A study folder or a runs Parquet file.

    Returns
    -------
    DataFrame
        One row per case and run (the baseline and each system), SI units;
        ``df.attrs["units"]["impact_speed1"] == "m/s"``, ``df.attrs["descriptions"]``
        likewise (``vfs db schema runs`` prints them).

    Raises
    ------
    DataError
        The folder is no study or the study is not complete.
    """
    path = Path(source)
    if path.is_dir():
        manifest = read_manifest(path)
        if manifest.get("status") != "complete" or not (path / RUNS_FILE).exists():
            raise DataError(DataProblem("study", "", None, None,
                                        f"{path}: the study is not complete (status "
                                        f"{manifest.get('status')!r}); no {RUNS_FILE} yet"))
        path = path / RUNS_FILE
    if not path.is_file():
        raise DataError(DataProblem("runs", "", None, None, f"{path}: no such file"))
    return read_parquet_with_units(path)


__all__ = [
    "StudyResult",
    "read_runs",
    "case_ids_hash",
    "combine_chunks",
    "counts_summary",
    "data_hash",
    "environment_versions",
    "load_study",
    "now",
    "prepare_folder",
    "read_manifest",
]
