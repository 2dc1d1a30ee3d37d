"""AEB effectiveness studies: baseline and treatment runs of every case of a database.

See :mod:`vfs.study.core` and docs/study.md.
"""

from vfs.study.core import *  # noqa: F403
from vfs.study.core import __all__  # noqa: F401
