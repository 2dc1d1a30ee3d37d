"""Imported first by the fork server of the process engine: signals, and death with the study.

The ``forkserver`` start method forks the pool's workers from a server
process, so a worker's parent is that server, not the study process; and the
server only ends by itself once every worker has ended.  Importing this module
(the first module on the server's preload list, :mod:`vfs.study.executors`)

* ignores SIGINT and SIGTERM in the server, and so in every worker it forks
  until the worker's initializer (:func:`vfs.study.orphans.exit_with_parent`)
  sets its own: Ctrl-C reaches the whole process group, and only the study
  process handles it (it stops the workers, writes the manifest and says how
  to resume); the executor starts the server with both signals blocked, so
  none arrives while the server imports vfs (about a second), and unblocks
  them here once they are ignored;
* where the executor names the study process (:data:`STUDY_PID_VARIABLE`, set
  when the pool is created by the study process's main thread: the
  parent-death signal follows the *thread* that started the server), arms
  ``PR_SET_PDEATHSIG`` in the server, so on Linux ``kill -9`` of the study
  process kills the server at once, which in turn kills each worker; a study
  process that died while the server was still importing is noticed here
  (the server's parent is no longer the study) and the server ends.
"""

from __future__ import annotations

import os

from vfs.study.orphans import (
    ORPHAN_EXIT_STATUS,
    STUDY_PID_VARIABLE,
    ignore_parent_signals,
    set_parent_death_signal,
)


def _arm() -> bool:
    study = os.environ.get(STUDY_PID_VARIABLE, "")
    if not study.isdigit():
        return False
    armed = set_parent_death_signal()
    if os.getppid() != int(study):  # the study died before the signal was armed
        os._exit(ORPHAN_EXIT_STATUS)
    return armed


ignore_parent_signals()  # never imported by the study process itself

#: Whether the parent-death signal is armed in this process (False off Linux).
ARMED = _arm()

__all__ = ["ARMED"]
