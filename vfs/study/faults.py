"""What a study does on a fault: SIGTERM, a full disk, cases that failed.

* :func:`stop_on_signals` turns SIGTERM (``kill``, a batch scheduler's time
  limit) into :class:`Terminated`, a :class:`KeyboardInterrupt`, and SIGINT into
  a :class:`KeyboardInterrupt`, each once: the study then stops (manifest
  ``interrupted``, lock released, workers killed) instead of dying with the
  manifest saying ``running``; the workers ignore both (Ctrl-C reaches the whole
  process group), so the study process alone handles them.
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
from vfs.errors import Terminated

#: Exit code of ``vfs study`` when runs failed (and ``--allow-failed`` is not given).
EXIT_FAILED_CASES = 4
#: Exit code after SIGTERM (128 + 15, as a shell reports a process killed by it).
EXIT_TERMINATED = Terminated.exit_status  # 128 + SIGTERM


#: The signal received inside :func:`stop_on_signals` (0: none yet), read by
#: :func:`raise_if_signalled`; and the depth of :func:`deferred_signals` blocks.
_received = {"signal": 0, "defer": 0}


def signal_received() -> int:
    """The signal (SIGINT or SIGTERM) that stopped the study in this block; 0 if none."""
    return int(_received["signal"])


def raise_if_signalled(cause: BaseException | None = None) -> None:
    """Raise the interrupt of the signal received inside :func:`stop_on_signals`, if any.

    A process pool whose workers died of a group's SIGTERM reports itself
    broken; the study then stops as interrupted, not as failed.
    """
    sig = signal_received()
    if sig == signal.SIGTERM:
        raise Terminated(f"signal {sig} (SIGTERM)") from cause
    if sig:
        raise KeyboardInterrupt from cause


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """Inside this block SIGINT raises :class:`KeyboardInterrupt` and SIGTERM
    :class:`Terminated`, once: later signals (Ctrl-C pressed again, a scheduler's
    second SIGTERM) are ignored while the study stops, writes its manifest and
    says how to resume, so that the clean-up is not cut short (main thread only).

    The previous handlers are restored on exit.  In another thread (where Python
    cannot install signal handlers) the block does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        if _received["signal"]:
            return  # handled once
        _received["signal"] = signum
        if _received["defer"]:
            return  # raised at the end of the deferred_signals block
        if signum == signal.SIGTERM:
            raise Terminated(f"signal {signum} (SIGTERM)")
        raise KeyboardInterrupt

    _received["signal"] = _received["defer"] = 0
    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
        _received["signal"] = 0


@contextmanager
def deferred_signals() -> Iterator[None]:
    """Inside :func:`stop_on_signals`, a signal that arrives in this block is raised at its
    end, not in the middle: e.g. while the process pool starts a worker, which would
    otherwise be left half started (it prints a traceback when the pool's semaphores are
    gone).
    """
    _received["defer"] += 1
    try:
        yield
    finally:
        _received["defer"] -= 1
    if not _received["defer"]:
        raise_if_signalled()


#: The name of :func:`stop_on_signals` before it handled SIGINT too.
terminate_as_interrupt = stop_on_signals


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


__all__ = ["EXIT_FAILED_CASES", "EXIT_TERMINATED", "Terminated", "deferred_signals",
           "failed_runs", "raise_if_signalled", "record_fault", "signal_received",
           "stop_on_signals", "terminate_as_interrupt"]
