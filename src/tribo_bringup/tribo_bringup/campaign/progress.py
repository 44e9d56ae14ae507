"""Progress of a campaign run: a bar with the ETA and one status line per finished session.

On a terminal the bar is redrawn in place (carriage return) under the status lines; into a
file or pipe a bar line is printed at most every :data:`PIPE_EVERY_S` seconds.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: Shortest interval between two bar lines when the output is not a terminal [s].
PIPE_EVERY_S = 10.0
BAR_WIDTH = 24


def fmt_seconds(s: float) -> str:
    """Format a duration [s] as ``1 h 02 min``, ``3 min 05 s`` or ``12.3 s``.

    Parameters
    ----------
    s : float
        Duration [s].

    Returns
    -------
    str
        Short text.
    """
    if s != s or s < 0:
        return '?'
    if s >= 3600:
        return f'{int(s // 3600)} h {int(s % 3600 // 60):02d} min'
    if s >= 60:
        return f'{int(s // 60)} min {int(s % 60):02d} s'
    return f'{s:.1f} s'


class Progress:
    """Progress bar (tasks, sessions, elapsed, ETA) and per-session status lines.

    Parameters
    ----------
    tasks : int
        Tasks to run.
    sessions : int
        Sessions to analyse.
    stream : TextIO or None
        Where to write (default stderr); None writes nothing.
    """

    def __init__(self, tasks: int, sessions: int, stream: TextIO | None = sys.stderr) -> None:
        self.tasks = tasks
        self.sessions = sessions
        self.tasks_done = 0
        self.sessions_done = 0
        self.failed = 0
        self.stream = stream
        self.t0 = time.monotonic()
        self._tty = bool(stream is not None and stream.isatty())
        self._last_bar = -PIPE_EVERY_S

    def eta(self) -> float:
        """Return the estimated time to the end [s] (from the tasks' rate so far; NaN before).

        Returns
        -------
        float
            Seconds.
        """
        if self.tasks_done == 0:
            return float('nan')
        rate = (time.monotonic() - self.t0) / self.tasks_done
        return rate * (self.tasks - self.tasks_done)

    def bar(self) -> str:
        """Return the bar line.

        Returns
        -------
        str
            ``[#####....] 12/40 tasks, 5/24 sessions (1 failed), 30.2 s, ETA 1 min 03 s``.
        """
        frac = self.tasks_done / self.tasks if self.tasks else 1.0
        n = round(frac * BAR_WIDTH)
        failed = f' ({self.failed} failed)' if self.failed else ''
        return (
            f'[{"#" * n}{"." * (BAR_WIDTH - n)}] {self.tasks_done}/{self.tasks} tasks, '
            f'{self.sessions_done}/{self.sessions} sessions{failed}, '
            f'{fmt_seconds(time.monotonic() - self.t0)}, ETA {fmt_seconds(self.eta())}'
        )

    def _draw(self, force: bool = False) -> None:
        if self.stream is None:
            return
        now = time.monotonic()
        if self._tty:
            self.stream.write('\r\x1b[K' + self.bar())
        elif force or now - self._last_bar >= PIPE_EVERY_S:
            self.stream.write(self.bar() + '\n')
            self._last_bar = now
        self.stream.flush()

    def task_done(self) -> None:
        """Count one finished task and redraw the bar."""
        self.tasks_done += 1
        self._draw()

    def session_done(self, line: str, ok: bool) -> None:
        """Print one session's status line above the bar.

        Parameters
        ----------
        line : str
            The status text (session id, result or error).
        ok : bool
            False for a failed session.
        """
        self.sessions_done += 1
        self.failed += not ok
        if self.stream is None:
            return
        prefix = '\r\x1b[K' if self._tty else ''
        width = len(str(self.sessions))
        self.stream.write(f'{prefix}[{self.sessions_done:>{width}}/{self.sessions}] {line}\n')
        self._draw()

    def say(self, line: str) -> None:
        """Print a message line above the bar.

        Parameters
        ----------
        line : str
            The text.
        """
        if self.stream is None:
            return
        prefix = '\r\x1b[K' if self._tty else ''
        self.stream.write(f'{prefix}{line}\n')
        self.stream.flush()

    def close(self) -> None:
        """Print the final bar line."""
        if self.stream is None:
            return
        if self._tty:
            self.stream.write('\r\x1b[K' + self.bar() + '\n')
            self.stream.flush()
        else:
            self._draw(force=True)
