"""``python -m vfs``: the command line.

SIGTERM is turned into :class:`vfs.errors.Terminated` first thing (Ctrl-C is
Python's :class:`KeyboardInterrupt` already), so a signal that arrives while the
command line is still being imported ends the process with one line and exit
130 / 143, as it does later (``vfs study`` then handles both itself).
"""

import signal
import sys

from vfs.errors import Terminated


def _terminate(signum: int, frame: object) -> None:
    raise Terminated(f"signal {signum} (SIGTERM)")


signal.signal(signal.SIGTERM, _terminate)
try:
    from vfs.cli import main

    code = main()
except KeyboardInterrupt as exc:  # a signal before the command's own handling
    print("interrupted" if not isinstance(exc, Terminated) else "terminated (SIGTERM)",
          file=sys.stderr, flush=True)
    code = int(getattr(exc, "exit_status", 130))
sys.exit(code)
