"""The ``glocal-verify`` command's entry point, and ``python -m glocal_verify``.

The stop signals are handled from the first line of the toolkit's own code: before the
command line's modules (and numpy, scipy ...) are imported, ``SIGINT``, ``SIGTERM`` and
``SIGHUP`` end the process with the command's one stop line and exit code 130, 143 or 129,
never a traceback from inside an import. Once the command runs,
:func:`glocal_verify.cli.entry_point` installs the handlers that stop the work cleanly.

This module imports only the standard library before it hands over.
"""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType, MappingProxyType

__all__ = ["entry_point"]

#: the one line of each stop signal during start-up (the same words as the command's own)
_EARLY_LINES = MappingProxyType({
    signal.SIGINT: b"glocal-verify: interrupted\n",
    signal.SIGTERM: b"glocal-verify: terminated (SIGTERM)\n",
    signal.SIGHUP: b"glocal-verify: hung up (SIGHUP)\n",
})


def _stop_during_start_up(signum: int, frame: FrameType | None) -> None:
    try:
        os.write(2, _EARLY_LINES.get(signal.Signals(signum), b"glocal-verify: stopped\n"))
    finally:
        os._exit(128 + signum)


def entry_point() -> int:
    """Run the command line (:func:`glocal_verify.cli.entry_point`) with the stop signals
    handled from the start (module docstring); return its exit code."""
    for sig in _EARLY_LINES:
        try:
            if signal.getsignal(sig) is not signal.SIG_IGN:  # ignored on purpose (nohup): keep it
                signal.signal(sig, _stop_during_start_up)
        except (ValueError, OSError):  # pragma: no cover - no signals in this interpreter
            pass
    from glocal_verify.cli import entry_point as run

    return run()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(entry_point())
