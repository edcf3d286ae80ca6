"""Progress on a terminal: a bar for counted work, a status line for long steps.

Both draw on a terminal stream (stderr) only, and only when it is a terminal: results go to
stdout and must never share a line with them, so a command clears the line
(:meth:`ProgressBar.clear`, :meth:`Status.clear`) before it prints a result and lets it be
drawn again after.

The bar, for ``meshwm bench`` and ``meshwm verify`` over many files:

One format for both::

     40% [##########..............] 2/5 files, 1.3/s    2 s,    2 s left  spot Table 2

``done/total``, the unit and the rate when a unit is given, the seconds so far and, while
running, the seconds left; then the label of the last unit of work, if any.  The line is
redrawn in place (``\\r``) at most 10 times a second, always at the end, and ends with a
newline.

The status line, for a step that takes seconds with nothing to count (``meshwm embed``'s
stages: reading, marking each mesh, measuring distances, writing)::

    marking 'chair' (2/3): 2930 vertices ... 12 s

redrawn every second by a background thread so the seconds move.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from types import TracebackType
from typing import TextIO

__all__ = ["ProgressBar", "Status", "progress_bar"]

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

    def clear(self) -> None:
        """Blank the line drawn so far (before a result is printed on the same terminal)."""
        if self.shown:
            self.stream.write("\r" + " " * self.shown + "\r")
            self.stream.flush()
            self.shown = 0
            self.last = -1.0  # the next call draws again at once

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


def _is_terminal(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a real stream
        return False


class Status:
    """A one-line status on a terminal: what is being done and for how many seconds.

    Parameters
    ----------
    stream : text stream, optional
        Where to draw (default ``sys.stderr``).
    enabled : bool, optional
        Draw at all; default: only when ``stream`` is a terminal.
    interval : float, optional
        Seconds between redraws of the elapsed time (default 1).

    Use it as a context manager; :meth:`stage` starts a new step, :meth:`clear` blanks the
    line (the context's exit does too), :meth:`echo` prints a result line to stdout without
    mixing it with the status.

    Examples
    --------
    >>> import io
    >>> stream = io.StringIO()
    >>> with Status(stream, enabled=True) as status:
    ...     status.stage("reading spot.ply")
    >>> stream.getvalue().startswith("\\rreading spot.ply ...    0 s")
    True
    >>> stream.getvalue().endswith("\\r")  # blanked: nothing left on the line
    True
    >>> quiet = io.StringIO()
    >>> with Status(quiet) as status:  # not a terminal: draws nothing
    ...     status.stage("reading")
    >>> quiet.getvalue()
    ''
    """

    def __init__(
        self, stream: TextIO | None = None, *, enabled: bool | None = None, interval: float = 1.0
    ) -> None:
        self.stream = stream or sys.stderr
        self.enabled = _is_terminal(self.stream) if enabled is None else enabled
        self.interval = interval
        self.label = ""
        self.started = time.perf_counter()
        self.shown = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __enter__(self) -> Status:
        if self.enabled:
            self._thread = threading.Thread(target=self._tick, daemon=True)
            self._thread.start()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        self.clear()

    def _tick(self) -> None:
        while not self._stop.wait(self.interval):
            self._draw()

    def _draw(self) -> None:
        with self._lock:
            if not self.enabled or not self.label:
                return
            line = f"{self.label} ... {time.perf_counter() - self.started:4.0f} s"
            try:
                self.stream.write("\r" + line.ljust(self.shown))
                self.stream.flush()
            except (OSError, ValueError):  # the terminal went away: stop drawing
                self.enabled = False
                return
            self.shown = len(line)

    def stage(self, label: str) -> None:
        """Start a step called ``label`` (its seconds count from now)."""
        with self._lock:
            self.label = label
            self.started = time.perf_counter()
        self._draw()

    def clear(self) -> None:
        """Blank the status line."""
        with self._lock:
            if self.enabled and self.shown:
                try:
                    self.stream.write("\r" + " " * self.shown + "\r")
                    self.stream.flush()
                except (OSError, ValueError):
                    self.enabled = False
            self.shown = 0

    def echo(self, text: str) -> None:
        """Print ``text`` on stdout, the status blanked first and drawn again after."""
        self.clear()
        print(text, flush=True)
        self._draw()
