"""``python -m vfs``: the command line."""

import sys

from vfs.cli import main

sys.exit(main())
