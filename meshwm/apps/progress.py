"""A one-line progress bar on a terminal stream, for ``meshwm bench`` and ``meshwm verify``.

One format for both::

     40% [##########..............] 2/5 files, 1.3/s    2 s,    2 s left  spot Table 2

``done/total``, the unit and the rate when a unit is given, the seconds so far and, while
running, the seconds left; then the label of the last unit of work, if any.  The line is
redrawn in place (``\\r``) at most 10 times a second, always at the end, and ends with a
newline.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["ProgressBar", "progress_bar"]

#: The longest label shown; longer ones are cut.
LABEL_WIDTH = 48


class ProgressBar:
    """A one-line progress bar on a terminal stream: ``progress(done, total, label)``.

    Parameters
    ----------
    stream : text stream, optional
        Where to draw (default ``sys.stderr``); meant for a terminal.
    width : int, optional
        Characters between the brackets (default 24).
    unit : str, optional
        What is counted ("files"); when given, the line shows it and the rate per second.
    interval : float, optional
        The least time between two redraws, in seconds (default 0.1); the last one is always
        drawn.

    Examples
    --------
    >>> import io
    >>> stream = io.StringIO()
    >>> bar = ProgressBar(stream, width=4)
    >>> bar(4, 4, "done")
    >>> stream.getvalue()[:23]
    '\\r100% [####] 4/4    0 s'
    """

    def __init__(
        self,
        stream: TextIO | None = None,
        width: int = 24,
        *,
        unit: str = "",
        interval: float = 0.1,
    ) -> None:
        self.stream = stream or sys.stderr
        self.width = width
        self.unit = unit
        self.interval = interval
        self.started = time.perf_counter()
        self.last = -1.0
        self.shown = 0  # length of the line on screen, to blank a longer one

    def __call__(self, done: int, total: int, label: str = "") -> None:
        """Draw ``done`` of ``total`` with ``label`` (skipped within ``interval`` of the last)."""
        now = time.perf_counter()
        if done < total and now - self.last < self.interval:
            return
        self.last = now
        line = self.line(done, total, label, now - self.started)
        self.stream.write("\r" + line.ljust(self.shown))
        self.shown = len(line)
        if done >= total:
            self.stream.write("\n")
            self.shown = 0
        self.stream.flush()

    def line(self, done: int, total: int, label: str, elapsed: float) -> str:
        """The text of the bar after ``elapsed`` seconds (no ``\\r``, no padding)."""
        frac = done / total if total else 1.0
        filled = round(self.width * frac)
        count = f"{done}/{total}"
        if self.unit:
            count += f" {self.unit}, {done / max(elapsed, 1e-9):.1f}/s"
        eta = f", {elapsed / frac - elapsed:4.0f} s left" if 0 < frac < 1 else ""
        text = (
            f"{100 * frac:3.0f}% [{'#' * filled}{'.' * (self.width - filled)}] {count} "
            f"{elapsed:4.0f} s{eta}"
        )
        return f"{text}  {label[:LABEL_WIDTH]}" if label else text


def progress_bar(total: int, stream: TextIO, *, unit: str = "files") -> Callable[[int], None]:
    """A :class:`ProgressBar` of a fixed ``total``: call it with the count done so far.

    Examples
    --------
    >>> import io
    >>> stream = io.StringIO()
    >>> show = progress_bar(2, stream)
    >>> show(2)
    >>> stream.getvalue().startswith("\\r100% [") and stream.getvalue().endswith("\\n")
    True
    """
    bar = ProgressBar(stream, width=30, unit=unit)

    def show(done: int) -> None:
        bar(done, total)

    return show
