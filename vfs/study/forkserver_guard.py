"""Imported by the fork server of the process engine: it dies with the study process.

The ``forkserver`` start method forks the pool's workers from a server
process, so a worker's parent is that server, not the study process; and the
server only ends by itself once every worker has ended.  Importing this module
(it is on the server's preload list, :mod:`vfs.study.executors`) arms
``PR_SET_PDEATHSIG`` in the server, so on Linux ``kill -9`` of the study
process kills the server at once, which in turn kills each worker (armed by
:func:`vfs.study.orphans.exit_with_parent`).  The executor puts it on the
preload list only when the pool is created by the study process's main thread:
the signal follows the *thread* that started the server.
"""

from __future__ import annotations

from vfs.study.orphans import set_parent_death_signal

#: Whether the parent-death signal is armed in this process (False off Linux).
ARMED = set_parent_death_signal()

__all__ = ["ARMED"]
