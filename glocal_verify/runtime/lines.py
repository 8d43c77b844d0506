"""Lines on stderr: each written whole, and a stop line never glued to another.

A command tells the user where it is with lines on stderr (a phase, an estimate, ``audit:
400/1200 attack sets``, ``wrote <path>``, the heartbeat). ``print(text, file=sys.stderr)``
writes the text and its newline in two calls; a stop signal landing between them left the
newline unwritten, and the one stop line (``glocal-verify: hung up (SIGHUP)``) went on the same
line as the progress text. Two rules make that impossible:

* :func:`write_line` writes a line and its newline in one call, then flushes: every line of
  the toolkit goes through it;
* :func:`tracked_stderr` has ``sys.stderr`` remember whether its last write ended a line
  (:class:`LineStream`), and ``write_line(..., fresh=True)`` -- the stop line, the heartbeat --
  starts on a fresh line when it did not (a progress bar left mid-line, a write cut short by
  the signal, a library's own ``print``). The mark is set before each write and settled
  after it, so a write cut short counts as one that did not end its line: the worst case is
  one blank line, never a glued one.

Layer: runtime; imports only the standard library.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from typing import Any, TextIO

__all__ = ["LineStream", "tracked_stderr", "write_line"]


class LineStream:
    """A text stream that remembers whether its last write ended a line.

    Parameters
    ----------
    inner : text stream
        Where the writes go; every other attribute (``flush``, ``isatty``, ``fileno`` ...) is
        the inner stream's.

    Attributes
    ----------
    at_line_start : bool
        The last write ended with a newline (or nothing was written yet). False while a write
        is under way, so that a write cut short by a signal counts as an unfinished line.
    """

    def __init__(self, inner: TextIO) -> None:
        self._inner = inner
        self.at_line_start = True

    def write(self, text: str) -> int:
        if not text:
            return self._inner.write(text)
        self.at_line_start = False
        n = self._inner.write(text)
        self.at_line_start = text.endswith("\n")
        return n

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


def _at_line_start(stream: Any) -> bool:
    """Whether ``stream`` (a :class:`LineStream`, or a wrapper of one) is at the start of a line."""
    return bool(getattr(stream, "at_line_start", True))


def write_line(text: str, stream: TextIO | None = None, *, fresh: bool = False) -> None:
    """Write ``text`` and its newline in one call, then flush.

    Parameters
    ----------
    text : str
        One line, without its newline.
    stream : text stream, optional
        Default ``sys.stderr`` as it is at the call (so that a wrapper such as the heartbeat's
        sees the line).
    fresh : bool
        Start on a fresh line when the stream's last write did not end one (known when
        ``sys.stderr`` is tracked, :func:`tracked_stderr`): for a line that may come at any
        moment, such as the stop line of a signal.

    Raises
    ------
    OSError, ValueError
        The stream is closed or gone (after a hang-up); callers that must not fail catch them.
    """
    out: Any = sys.stderr if stream is None else stream
    if fresh and not _at_line_start(out):
        text = "\n" + text
    out.write(text + "\n")
    out.flush()


@contextlib.contextmanager
def tracked_stderr() -> Iterator[LineStream]:
    """``sys.stderr`` as a :class:`LineStream` inside the block (restored on leaving it).

    Yields
    ------
    LineStream
    """
    saved = sys.stderr
    stream = LineStream(saved)
    sys.stderr = stream  # type: ignore[assignment]
    try:
        yield stream
    finally:
        if sys.stderr is stream:
            sys.stderr = saved
