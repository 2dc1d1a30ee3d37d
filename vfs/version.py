"""The installed version of vfs (from the distribution's metadata, so it exists once).

The distribution is called ``vfs-accident`` (the name ``vfs`` on the package index belongs to
another project); the import package and the command are ``vfs``.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

#: The name of vfs's distribution (``pip install vfs-accident``; ``import vfs``).
DISTRIBUTION = "vfs-accident"


def _installed_version() -> str:
    for name in (DISTRIBUTION, "vfs"):  # "vfs": an install made before the rename
        try:
            return version(name)
        except PackageNotFoundError:
            continue
    return "0+unknown"  # running from a source tree without install


__version__: str = _installed_version()



def source_commit() -> str:
    """The git commit of the vfs source tree ("<hash>", "<hash>+changes" when the tree has
    uncommitted changes), or "" when vfs does not run from a git checkout (an installed
    wheel).  Recorded in every study (``study.json``) and shown in the reports' provenance.
    """
    import subprocess
    from pathlib import Path

    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "-C", str(here), "rev-parse", "--short=12", "HEAD"],
                              capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain",
                                "--untracked-files=no", "--", str(here)],
                               capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return ""
    return head.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")


__all__ = ["DISTRIBUTION", "__version__", "source_commit"]
