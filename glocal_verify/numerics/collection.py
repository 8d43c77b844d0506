"""Python's cyclic garbage collector during long loops that build many long-lived objects, and freed memory given back.

An audit keeps millions of objects alive while it runs (the minor tables' polynomials, the
local verdicts, one row with its witness per set). CPython's full collection scans every live
object, and it runs again each time the objects created since the last one reach a quarter of
those alive: at N = 200, k = 2 seven full collections cost about a tenth of the whole audit,
and collected nothing an audit had made.

:func:`deferred_full_collections` raises the threshold of the oldest generation for the
``with`` block, so the young generations are still collected (short-lived reference cycles
are freed as before) but no full collection starts inside the block; the thresholds are
restored afterwards, when the next full collection sees whatever the block left. It changes
no result. The thresholds are process-wide: blocks nest (each restores what it found), but
two threads that enter and leave overlapping blocks may restore each other's values.

:func:`release_freed_memory` hands the C heap's free pages back to the system after a unit of
work (an audit chunk). The exact arithmetic's polynomials and the batched arrays are freed
after each chunk, but glibc keeps the holes they leave in its heap: an audit worker at
N = 1000 grew by about 16 MB per chunk to 2.1 GB, while the objects alive stayed constant
(measured with tracemalloc); with ``malloc_trim`` after each chunk it stayed at 0.5 GB.
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import sys
from typing import Iterator

__all__ = ["deferred_full_collections", "release_freed_memory"]

#: the oldest generation's threshold inside the block: young collections between full ones
_DEFERRED = 1_000_000_000


@contextlib.contextmanager
def deferred_full_collections() -> Iterator[None]:
    """Run the block without full garbage collections (young generations are still collected).

    Collection switched off (``gc.disable()`` or a zero threshold) stays off.
    """
    old = gc.get_threshold()
    if old[0] == 0:
        yield
        return
    gc.set_threshold(old[0], old[1] if len(old) > 1 else 10, _DEFERRED)
    try:
        yield
    finally:
        gc.set_threshold(*old)


def release_freed_memory() -> bool:
    """Return the free pages of the C heap to the system (glibc's ``malloc_trim(0)``).

    Changes no object, only the process's resident size. Returns whether it was done (False
    where the C library has no ``malloc_trim``: another libc, or not Linux).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        trim = ctypes.CDLL(None).malloc_trim  # the process's own symbols (find_library would start a subprocess)
    except (OSError, AttributeError):
        return False
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    trim(0)
    return True
