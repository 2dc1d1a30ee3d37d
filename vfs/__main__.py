"""``python -m vfs``: the command line."""

import sys

try:
    from vfs.cli import main

    code = main()
except KeyboardInterrupt:  # Ctrl-C while the command line is imported
    print("interrupted", file=sys.stderr, flush=True)
    code = 130
sys.exit(code)
