"""The error ledger: every evaluated model variant and its cross-validated error.

``vfs diagnose`` and ``vfs calibrate`` append one JSON line per model they
cross-validate to ``ledger.jsonl`` in the results folder (the default model,
each diagnosed candidate, each calibrated combination).  ``vfs ledger
FOLDER`` shows the table and the *chain*: the error falling from the default
model through each added effect, as a table and a waterfall figure
(:func:`vfs.report.ledger.plot_waterfall`).

A record::

    {"date": "2026-...", "source": "calibrate", "kind": "calibrated",
     "model": "tyre_impulse+yaw_inertia",
     "effects": [{"name": "tyre_impulse", "parameters": {...}}, ...],
     "cv_rmse": {"delta_v": 0.98, ...}, "cv_rmse_overall": 1.02,
     "outputs": [...], "scales": {...}, "n_cases": 270, "folds": 5, "seed": 0,
     "database": "results/db", "fingerprint": "3f2a..."}

``kind`` is ``default``, ``candidate`` (one effect, fitted per fold, may be
switched off) or ``calibrated`` (the chosen effects fitted jointly).  Records
are comparable when their ``fingerprint`` (cases, recorded outcomes, outputs
and scales) and folds/seed agree; the chain uses the records of the newest
fingerprint.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd

from vfs.errors import DataError, DataProblem

#: File name of the ledger inside a results folder.
LEDGER_FILE = "ledger.jsonl"


def ledger_path(folder: str | Path) -> Path:
    """The ledger file of a results folder (``folder`` may also name the file)."""
    p = Path(folder)
    return p if p.suffix == ".jsonl" else p / LEDGER_FILE


def make_record(cv: Any, data: Any, kind: str, source: str, folds: int, seed: int,
                database: str = "", note: str = "") -> dict[str, Any]:
    """A ledger record of a cross-validated model (:class:`vfs.diagnosis.calibrate.CVResult`)."""
    rmse = cv.rmse().tolist()
    return {
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "source": source,
        "kind": kind,
        "model": cv.label,
        "effects": cv.fitted_parameters() if cv.space.free or cv.space.effects else [],
        "cv_rmse": {g: _num(v) for g, v in zip(data.group_names, rmse, strict=True)},
        "cv_rmse_overall": _num(cv.overall_rmse()),
        "outputs": list(data.group_names),
        "scales": {g: float(v) for g, v in zip(data.group_names, data.scales, strict=True)},
        "n_cases": int(data.n),
        "folds": int(folds),
        "seed": int(seed),
        "database": database,
        "fingerprint": data.fingerprint(),
        "note": note,
    }


def _num(v: float) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def append_records(folder: str | Path, records: Iterable[Mapping[str, Any]]) -> Path:
    """Append records (one JSON line each) to the ledger of ``folder``."""
    path = ledger_path(folder)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", encoding="utf-8") as fh:
        for r in records:
            fh.write(json.dumps(dict(r), default=str) + "\n")
    return path


def read_ledger(folder: str | Path) -> list[dict[str, Any]]:
    """All records of a ledger, oldest first.

    Raises
    ------
    DataError
        If there is no ledger or a line is not valid JSON.
    """
    path = ledger_path(folder)
    if not path.is_file():
        raise DataError(DataProblem(str(path), "", None, None,
                                    "no ledger here (vfs diagnose / vfs calibrate write it)"))
    out = []
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines()):
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError as exc:
            raise DataError(DataProblem(path.name, "", i, None,
                                        f"not a JSON record: {exc}")) from None
    return out


def _effect_names(r: Mapping[str, Any]) -> frozenset[str]:
    if r.get("kind") == "default":
        return frozenset()
    names = [e["name"] for e in r.get("effects") or []]
    if not names and r.get("model") not in (None, "", "default"):
        names = str(r["model"]).split("+")
    return frozenset(names)


def ledger_table(records: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """One row per record: date, source, kind, model, overall and per-output CV RMSE."""
    rows = []
    for r in records:
        row = {"date": r.get("date", ""), "source": r.get("source", ""),
               "kind": r.get("kind", ""), "model": r.get("model", ""),
               "cv_rmse_overall": r.get("cv_rmse_overall"),
               "fingerprint": r.get("fingerprint", "")}
        for g, v in (r.get("cv_rmse") or {}).items():
            row[g] = v
        rows.append(row)
    return pd.DataFrame(rows)


def ledger_chain(records: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The error chain: the default model, then one added effect per step.

    Uses the records comparable with the newest one (same fingerprint, folds
    and seed).  From the newest default record, each step takes a model with
    exactly one more effect than the previous step (calibrated combinations
    before diagnosed candidates, then the lowest CV RMSE, then the newest);
    it stops when no such model exists.
    """
    if not records:
        return []
    last = records[-1]
    key = (last.get("fingerprint"), last.get("folds"), last.get("seed"))
    comp = [r for r in records
            if (r.get("fingerprint"), r.get("folds"), r.get("seed")) == key]
    defaults = [r for r in comp if r.get("kind") == "default"]
    if not defaults:
        return []
    chain = [dict(defaults[-1])]
    current: frozenset[str] = frozenset()
    while True:
        nxt = [(i, r) for i, r in enumerate(comp)
               if r.get("kind") != "default" and len(_effect_names(r)) == len(current) + 1
               and current < _effect_names(r) and r.get("cv_rmse_overall") is not None]
        if not nxt:
            break
        # calibrated first, then lowest error, then newest
        i, best = min(nxt, key=lambda t: (t[1].get("kind") != "calibrated",
                                          t[1]["cv_rmse_overall"], -t[0]))
        added = sorted(_effect_names(best) - current)
        chain.append({**best, "added": added[0]})
        current = _effect_names(best)
    return chain


def chain_table(chain: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """The chain as a table: step, added effect, CV RMSE, change, per-output CV RMSE."""
    rows = []
    first = chain[0]["cv_rmse_overall"] if chain else None
    prev = None
    for k, r in enumerate(chain):
        v = r.get("cv_rmse_overall")
        row = {"step": k, "model": r.get("model", ""),
               "added": r.get("added", "(default model)"), "kind": r.get("kind", ""),
               "cv_rmse_overall": v,
               "change_vs_previous_%": None if prev in (None, 0) or v is None
               else 100.0 * (v / prev - 1.0),
               "change_vs_default_%": None if first in (None, 0) or v is None
               else 100.0 * (v / first - 1.0)}
        for g, gv in (r.get("cv_rmse") or {}).items():
            row[g] = gv
        rows.append(row)
        prev = v
    return pd.DataFrame(rows)


def format_chain(chain: Sequence[Mapping[str, Any]]) -> str:
    """The chain as text for the terminal."""
    if not chain:
        return "no default-model record in the ledger: run vfs diagnose or vfs calibrate"
    lines = [f"{'step':>4}  {'model':40s} {'CV RMSE':>9} {'vs prev':>9} {'vs default':>11}"]
    for _, r in chain_table(chain).iterrows():
        prev = r["change_vs_previous_%"]
        dflt = r["change_vs_default_%"]
        lines.append(f"{int(r['step']):>4}  {str(r['model'])[:40]:40s} "
                     f"{r['cv_rmse_overall']:9.4f} "
                     f"{'' if pd.isna(prev) else f'{prev:+.1f} %':>9} "
                     f"{'' if pd.isna(dflt) else f'{dflt:+.1f} %':>11}")
    return "\n".join(lines)


__all__ = ["LEDGER_FILE", "append_records", "chain_table", "format_chain", "ledger_chain",
           "ledger_path", "ledger_table", "make_record", "read_ledger"]
