"""No orphans: worker processes end when the study process that started them dies.

A study killed with ``kill -9`` cannot shut its process pool down, and the
pool's workers (which block on their task queue) would otherwise live on as
orphans.  :func:`exit_with_parent` is the workers' initializer
(:mod:`vfs.study.executors`); it arms two independent mechanisms:

* on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills the worker
  when its parent ends.  With the ``forkserver`` start method the parent is
  the fork server, which would only end after its workers; so the server is
  armed the same way (:mod:`vfs.study.forkserver_guard`, on its preload
  list) and the chain study process -> fork server -> workers ends at once;
* everywhere, a daemon thread that polls every ``poll_s`` seconds whether the
  study process still runs and the worker's parent is still the same process,
  and ends the worker with ``os._exit`` when not.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time

from vfs.errors import quiet_numpy_warnings

#: ``PR_SET_PDEATHSIG`` of ``<linux/prctl.h>``.
PR_SET_PDEATHSIG = 1

#: Exit status of a worker ended because its study process died.
ORPHAN_EXIT_STATUS = 70

#: Seconds between two checks of the watchdog thread.
DEFAULT_POLL_S = 0.5

#: Environment variable through which the executor names the study process to its fork
#: server (:mod:`vfs.study.forkserver_guard`).
STUDY_PID_VARIABLE = "VFS_STUDY_PID"

#: Signals that only the study process handles (Ctrl-C reaches the whole process group).
PARENT_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def ignore_parent_signals(terminate: bool = False) -> None:
    """Ignore :data:`PARENT_SIGNALS` in this process (a fork server or a worker), then
    unblock them (the executor starts the fork server with them blocked).

    Parameters
    ----------
    terminate : bool
        Let SIGTERM end this process (its default action, no traceback) instead of
        ignoring it: a worker, which the pool itself ends with SIGTERM when broken.
    """
    for sig in PARENT_SIGNALS:
        signal.signal(sig, signal.SIG_DFL if terminate and sig == signal.SIGTERM
                      else signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, PARENT_SIGNALS)


def pid_alive(pid: int) -> bool:
    """True while process ``pid`` exists (on this host), also when owned by another user."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by another user
        return True
    except OSError:  # e.g. an invalid pid on Windows
        return False
    return True


def set_parent_death_signal(sig: int = signal.SIGKILL) -> bool:
    """Ask the Linux kernel to send ``sig`` to this process when its parent ends.

    Returns
    -------
    bool
        True when armed; False on other systems or when ``prctl`` is not
        reachable (the watchdog of :func:`exit_with_parent` still works).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def _watch(study_pid: int, parent_pid: int, poll_s: float) -> None:
    while True:
        time.sleep(poll_s)
        if os.getppid() != parent_pid or not pid_alive(study_pid):
            os._exit(ORPHAN_EXIT_STATUS)  # no cleanup: nobody is left to receive results


def exit_with_parent(study_pid: int, poll_s: float = DEFAULT_POLL_S) -> None:
    """Worker initializer: end this process when the study process ``study_pid`` ends.

    Parameters
    ----------
    study_pid : int
        Process id of the study (the process that created the pool).
    poll_s : float
        Seconds between two checks of the watchdog thread.
    """
    ignore_parent_signals(terminate=True)  # Ctrl-C is the study process's to handle
    quiet_numpy_warnings()  # a worker's stderr is the user's terminal
    parent_pid = os.getppid()
    set_parent_death_signal()
    if not pid_alive(study_pid) or not pid_alive(parent_pid):  # died before we were armed
        os._exit(ORPHAN_EXIT_STATUS)
    threading.Thread(target=_watch, args=(study_pid, parent_pid, poll_s), daemon=True,
                     name="vfs-exit-with-parent").start()


__all__ = ["DEFAULT_POLL_S", "ORPHAN_EXIT_STATUS", "PARENT_SIGNALS", "PR_SET_PDEATHSIG",
           "STUDY_PID_VARIABLE", "exit_with_parent", "ignore_parent_signals", "pid_alive",
           "set_parent_death_signal"]
