"""What a study does on a fault: SIGTERM, a full disk, cases that failed.

* :func:`terminate_as_interrupt` turns SIGTERM (``kill``, a batch scheduler's
  time limit) into :class:`Terminated`, a :class:`KeyboardInterrupt`: the study
  then stops as on Ctrl-C (manifest ``interrupted``, lock released, workers
  shut down) instead of dying with the manifest saying ``running``.
* :func:`record_fault` writes the ``failed`` / ``interrupted`` manifest even on a
  full disk: when the atomic write (a new file) fails, the manifest file is
  rewritten in place, in the blocks it already holds.
* :func:`failed_runs` counts the runs that failed inside the simulation, for the
  exit status of ``vfs study`` (:data:`EXIT_FAILED_CASES` unless
  ``--allow-failed``).
"""

from __future__ import annotations

import json
import os
import signal
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import Any

from vfs.atomic import json_default, strict_json, write_json

#: Exit code of ``vfs study`` when runs failed (and ``--allow-failed`` is not given).
EXIT_FAILED_CASES = 4
#: Exit code after SIGTERM (128 + 15, as a shell reports a process killed by it).
EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """SIGTERM received: the study stops as on Ctrl-C (status ``interrupted``)."""


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Inside this block SIGTERM raises :class:`Terminated` (main thread only).

    The previous handler is restored on exit.  In another thread (where Python
    cannot install signal handlers) the block does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        raise Terminated(f"signal {signum} (SIGTERM)")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def record_fault(path: str | os.PathLike[str], manifest: Mapping[str, Any]) -> bool:
    """Write ``manifest`` to ``path``; on a full disk, overwrite the old file in place.

    The atomic write needs a new file (new blocks); the old manifest's blocks
    are already allocated, so rewriting it in place (padded with spaces, which
    JSON ignores) succeeds where the disk has no block left, as long as the new
    text fits in them (the error text is capped at 500 characters).

    Returns
    -------
    bool
        True if the manifest was written.
    """
    try:
        write_json(path, manifest)
        return True
    except OSError:
        pass
    text = json.dumps(strict_json(dict(manifest)), indent=None,
                      default=json_default).encode("utf-8")
    target = Path(path)
    try:
        old = target.stat().st_size
        with open(target, "r+b") as file:
            file.write(text + b" " * max(0, old - len(text)))
            file.flush()
            os.fsync(file.fileno())
        return True
    except OSError:
        return False


def failed_runs(manifest: Mapping[str, Any]) -> int:
    """Runs (case x system) of a finished study that failed inside the simulation."""
    systems = manifest.get("summary", {}).get("systems", {})
    return int(sum(int(row.get("errors", 0)) for row in systems.values()))


__all__ = ["EXIT_FAILED_CASES", "EXIT_TERMINATED", "Terminated", "failed_runs",
           "record_fault", "terminate_as_interrupt"]
