"""A line on stderr at least every 10 seconds while a command works.

Commands print a line per phase (``checking local.pencil ...``, ``audit: 400/1200 attack
sets``), but one phase can run for minutes: the spectra of a thousand safe modes, a complete
graph of 1,414 agents being read. :class:`Heartbeat` watches what goes to stderr and, after
:data:`SILENCE_SECONDS` without a line, prints one saying the command is still at work and since
when::

    glocal-verify: still working, 20 s since "checking switched-observability ..."

The line is written whole and on a fresh line (:func:`glocal_verify.runtime.lines.write_line`).

It wraps ``sys.stderr`` for the duration of the command (every write, from any code, counts
as a sign of life) and runs one daemon thread. A phase stuck inside a single long C call that
holds Python's lock (an exact computation in python-flint) delays the line until the call
returns.
"""

from __future__ import annotations

import sys
import threading
import time
from types import TracebackType
from typing import Any, TextIO

from glocal_verify.runtime.lines import write_line

__all__ = ["SILENCE_SECONDS", "Heartbeat"]

#: seconds without a line on stderr after which the heartbeat prints one (checked twice a
#: second, so a line comes within 10 s)
SILENCE_SECONDS = 9.0


class _WatchedStream:
    """``sys.stderr`` as seen by the command: writes go through, their time is noted."""

    def __init__(self, inner: TextIO, beat: Heartbeat) -> None:
        self._inner = inner
        self._beat = beat

    def write(self, text: str) -> int:
        with self._beat.lock:
            n = self._inner.write(text)
            self._beat.noted(text)
        return n

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


class Heartbeat:
    """Print a still-working line after each :data:`SILENCE_SECONDS` of silence on stderr.

    Parameters
    ----------
    prog : str
        Prefix of the lines (the command's name).
    what : str
        What the command is doing before its first line (e.g. ``"verify"``).
    enabled : bool
        False (``--quiet``): the block runs unchanged.
    silence : float
        Seconds of silence before a line.
    """

    def __init__(self, prog: str, what: str, *, enabled: bool = True, silence: float = SILENCE_SECONDS) -> None:
        self.prog = prog
        self.what = what
        self.enabled = enabled
        self.silence = float(silence)
        self.lock = threading.RLock()
        self.last_time = self.line_time = time.monotonic()
        self.last_line = ""
        self._partial = ""
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._saved: TextIO | None = None
        self._stream: _WatchedStream | None = None

    def noted(self, text: str) -> None:
        """Record a write to stderr (called with :attr:`lock` held)."""
        if not text:
            return
        self.last_time = self.line_time = time.monotonic()
        self._partial += text
        lines = [ln.strip() for ln in self._partial.replace("\r", "\n").split("\n")]
        self._partial = self._partial.rsplit("\n", 1)[-1][-500:]
        done = [ln for ln in lines[:-1] if ln]
        if done:
            self.last_line = done[-1][:120]

    def _run(self) -> None:
        while not self._stop.wait(min(0.5, self.silence)):
            with self.lock:
                now = time.monotonic()
                if now - self.last_time < self.silence or self._stream is None:
                    continue
                since = now - self.line_time
                if self.last_line:
                    text = f'{self.prog}: still working, {since:.0f} s since "{self.last_line}"'
                else:
                    text = f"{self.prog}: {self.what}: still working, {since:.0f} s so far"
                try:
                    write_line(text, self._stream._inner, fresh=True)
                except (OSError, ValueError):  # stderr closed (a hang-up): nothing to tell
                    return
                self.last_time = now  # the next line after another silence, not the same total

    def __enter__(self) -> Heartbeat:
        if not self.enabled:
            return self
        self._saved = sys.stderr
        self._stream = _WatchedStream(sys.stderr, self)
        sys.stderr = self._stream  # type: ignore[assignment]
        self._thread = threading.Thread(target=self._run, name="glocal-verify heartbeat", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        if not self.enabled:
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with self.lock:
            if sys.stderr is self._stream and self._saved is not None:
                sys.stderr = self._saved
            self._stream = None
