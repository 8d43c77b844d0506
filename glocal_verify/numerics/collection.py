"""Python's cyclic garbage collector during long loops that build many long-lived objects.

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
"""

from __future__ import annotations

import contextlib
import gc
from typing import Iterator

__all__ = ["deferred_full_collections"]

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
