"""Progress of long steps and the ``vfs`` logger, in one place.

Every step that can take more than a few seconds (a study's cases, the bootstrap of a report,
the replay of case pages, the comparison, a diagnosis, uncertainty samples) reports through
:func:`progress`: a tqdm bar when standard error is a terminal, otherwise a line through the
``vfs`` logger at most every :data:`INTERVAL_S` seconds and one when a step that long ends, so
that a piped or logged run (CI, ``nohup``, a cluster job) shows where it is.  One-off news ("writing
the figures") goes through :func:`note`.

The command line sets the level (``-v`` debug, ``-q`` warnings only; :mod:`vfs.cli.common`);
from Python, configure the ``vfs`` logger as usual (``logging.basicConfig(level="INFO")``).
Without that, Python shows warnings only, and a bar only on a terminal.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from types import TracebackType
from typing import Any

#: The package's logger (``logging.getLogger("vfs")``); modules log through children of it.
LOGGER = logging.getLogger("vfs")
#: Seconds between two progress lines when no bar is shown.
INTERVAL_S = 10.0


def bar_wanted() -> bool:
    """A bar on a terminal (standard error is a tty, not CI, the logger shows INFO)."""
    return (sys.stderr.isatty() and not os.environ.get("CI")
            and LOGGER.isEnabledFor(logging.INFO))


def note(message: str, *args: Any) -> None:
    """One progress line (INFO on the ``vfs`` logger)."""
    LOGGER.info(message, *args)


def _duration(seconds: float) -> str:
    seconds = max(seconds, 0.0)
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds // 60:.0f} min {seconds % 60:02.0f} s"
    return f"{seconds // 3600:.0f} h {seconds % 3600 // 60:02.0f} min"


class Progress:
    """Progress of one step of ``total`` units: a bar on a terminal, lines otherwise.

    Parameters
    ----------
    total : float
        Units the step has (cases, samples, resamples).
    desc : str
        What the step does, in plain words ("replaying the listed cases").
    unit : str
        The unit's name ("case").
    bar : bool, optional
        Force the bar on or off; default :func:`bar_wanted`.
    interval_s : float
        Seconds between two lines when no bar is shown [s].
    """

    def __init__(self, total: float, desc: str, unit: str = "step", *,
                 bar: bool | None = None, interval_s: float = INTERVAL_S) -> None:
        self.total = float(total)
        self.desc = desc
        self.unit = unit
        self.done = 0.0
        self.interval_s = interval_s
        self.started = time.perf_counter()
        self._last = self.started
        self._bar: Any = None
        if bar if bar is not None else bar_wanted():
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=desc, unit=unit, file=sys.stderr,
                             smoothing=0.1, dynamic_ncols=True,
                             bar_format="{l_bar}{bar}| {n:.0f}/{total_fmt} "
                                        "[{elapsed}<{remaining}, {rate_fmt}]")

    def update(self, n: float = 1.0) -> None:
        """``n`` more units done."""
        self.done += n
        if self._bar is not None:
            self._bar.update(n)
            return
        now = time.perf_counter()
        if now - self._last >= self.interval_s and self.done < self.total:
            self._last = now
            elapsed = now - self.started
            left = elapsed * (self.total - self.done) / self.done if self.done > 0 else 0.0
            note("%s: %.0f of %.0f %ss (%.0f %%), %s so far, about %s left", self.desc,
                 self.done, self.total, self.unit, 100.0 * self.done / max(self.total, 1.0),
                 _duration(elapsed), _duration(left))

    def close(self) -> None:
        """End the step: one closing line when no bar is shown and the step lasted at least
        ``interval_s`` (a short step stays silent).
        """
        if self._bar is not None:
            self._bar.close()
            self._bar = None
            return
        if time.perf_counter() - self.started < self.interval_s:
            return
        note("%s: %.0f %ss done in %s", self.desc, self.done, self.unit,
             _duration(time.perf_counter() - self.started))

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if kind is None:
            self.close()
        elif self._bar is not None:
            self._bar.close()


def progress(total: float, desc: str, unit: str = "step", **options: Any) -> Progress:
    """A :class:`Progress` for one step (use it as a context manager)."""
    return Progress(total, desc, unit, **options)


__all__ = ["INTERVAL_S", "LOGGER", "Progress", "bar_wanted", "note", "progress"]
