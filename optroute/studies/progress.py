"""A text progress bar for studies and fronts: :class:`TextProgress`, a ``progress(done, total)`` callback.

One line on standard error, rewritten in place (``\\r``) on a terminal and printed every
``every_s`` seconds otherwise (a log file gets a line now and then, not thousands):
``study 523/1000 [##########..........] 52% 61.3 cases/min, about 8 min left``.
No dependency: tqdm is not needed.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from optroute.errors import ConfigError

__all__ = ["TextProgress"]


class TextProgress:
    """``progress(done, total)`` that draws a bar on ``stream`` (standard error by default).

    Parameters
    ----------
    label : str
        Printed before the counts ("study", "front").
    stream : text stream, optional
        Default :data:`sys.stderr` (read at each call, so that pytest's capture sees it).
    width : int
        Characters of the bar.
    every_s : float
        Seconds between lines when ``stream`` is not a terminal [s]; the first and last are always printed.
    unit : str
        What is counted ("cases", "points").
    """

    def __init__(
        self,
        label: str = "study",
        *,
        stream: TextIO | None = None,
        width: int = 30,
        every_s: float = 10.0,
        unit: str = "cases",
    ) -> None:
        if not (isinstance(width, int) and width >= 1):
            raise ConfigError(f"width={width!r} must be an integer >= 1 (characters of the bar)")
        if not every_s >= 0:
            raise ConfigError(f"every_s={every_s!r} must be a number of seconds >= 0")
        self.label, self.width, self.every_s, self.unit = str(label), width, float(every_s), str(unit)
        self._stream = stream
        self._start: float | None = None
        self._first_done = 0
        self._last_print = -float("inf")
        self.lines = 0  # lines (or rewrites) written, for tests

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        if self._start is None:  # the first call gives what was already stored (a resumed study)
            self._start, self._first_done = now, int(done)
        stream = self._stream if self._stream is not None else sys.stderr
        tty = bool(getattr(stream, "isatty", lambda: False)())
        final = done >= total
        if not (tty or final or now - self._last_print >= self.every_s):
            return
        self._last_print = now
        stream.write(("\r" if tty else "") + self.text(done, total, now) + ("\n" if final or not tty else ""))
        stream.flush()
        self.lines += 1

    def text(self, done: int, total: int, now: float | None = None) -> str:
        """The line for ``done`` of ``total`` (rate and time left from the calls so far)."""
        now = time.perf_counter() if now is None else now
        frac = done / total if total > 0 else 1.0
        filled = min(self.width, int(round(frac * self.width)))
        line = f"{self.label} {done}/{total} [{'#' * filled}{'.' * (self.width - filled)}] {100 * frac:3.0f}%"
        elapsed = now - self._start if self._start is not None else 0.0
        new = done - self._first_done
        if elapsed > 0 and new > 0:
            rate = new / elapsed * 60.0
            line += f" {rate:.1f} {self.unit}/min"
            left_min = (total - done) / rate
            if done < total:
                line += f", about {left_min:.0f} min left" if left_min >= 1 else f", about {left_min * 60:.0f} s left"
        return line
