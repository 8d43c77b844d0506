"""The JSON text of audit rows, written fast: the text of ``json.dumps(value, indent=2)``.

An audit of 500,500 sets writes about 1.4 GB of JSON. The standard library's encoder runs in
Python whenever it indents (its C encoder only writes compact text), and the rows were
indented again line by line: 84 us a row, about 65 s of the N = 1000, k = 2 audit after its
last task. :class:`IndentedJson` writes the same text directly, the common leaves inline:
36 us a row. (Keeping the text of containers that many rows share, by identity, was tried:
too few are shared whole, and the table made it 48 us.)

The text is exactly that of ``json.dumps(audit_jsonable(value), indent=2)`` indented by the
depth (checked by the tests on odd values: numpy scalars, complex numbers, non-finite floats,
non-ASCII strings, empty containers): :func:`audit_jsonable` is the one conversion both use.
"""

from __future__ import annotations

import itertools
import json.encoder
import math
from typing import Any

import numpy as np

from glocal_verify.results import Status, audit_jsonable

__all__ = ["IndentedJson"]

_quote = json.encoder.encode_basestring_ascii  # the C function json.dumps uses (ensure_ascii)


#: the keys of a list's items (none)
_NO_KEYS = itertools.repeat(None)


def _float(f: float) -> str:
    """A float as json.dumps writes it (``NaN``, ``Infinity`` and ``-Infinity`` for the others)."""
    if math.isfinite(f):
        return float.__repr__(float(f))
    return "NaN" if f != f else ("Infinity" if f > 0 else "-Infinity")


class IndentedJson:
    """Writer of ``json.dumps(audit_jsonable(value), indent=2)`` at a given depth.

    Values that are not JSON-like raise ``TypeError``, as ``json.dumps`` does.
    """

    def text(self, value: Any, depth: int = 0) -> str:
        """The text of ``value`` whose first line is indented by the caller and whose
        following lines are indented by ``2 * depth`` spaces more than json.dumps's."""
        return self._text(value, depth)

    def _text(self, x: Any, depth: int) -> str:
        if isinstance(x, str):
            return _quote(x.value if isinstance(x, Status) else x)
        if x is None:
            return "null"
        if x is True:
            return "true"
        if x is False:
            return "false"
        if isinstance(x, (float, np.floating)):
            f = float(x)
            return float.__repr__(f) if math.isfinite(f) else _quote(str(f))
        if isinstance(x, (int, np.integer)) and not isinstance(x, np.bool_):
            return int.__repr__(int(x))
        if isinstance(x, complex):  # its parts as they are: json.dumps's own names for non-finite ones
            inner = "\n" + "  " * (depth + 1)
            return "[" + inner + _float(x.real) + "," + inner + _float(x.imag) + "\n" + "  " * depth + "]"
        if isinstance(x, (dict, list, tuple)):
            return self._container(x, depth)
        raise TypeError(f"Object of type {type(x).__name__} is not JSON serializable")

    def _container(self, x: dict[Any, Any] | list[Any] | tuple[Any, ...], depth: int) -> str:
        if not x:
            return "{}" if isinstance(x, dict) else "[]"
        inner = "\n" + "  " * (depth + 1)
        parts: list[str] = []
        add = parts.append
        items = x.items() if isinstance(x, dict) else zip(_NO_KEYS, x)
        for k, v in items:
            if k is not None:
                add(_quote(str(k)) + ": ")
            t = type(v)  # the common leaves inline (exact types: subclasses take the general path)
            if t is str:
                add(_quote(v))
            elif t is float and v - v == 0.0:  # finite
                add(float.__repr__(v))
            elif t is int:
                add(int.__repr__(v))
            else:
                add(self._text(v, depth + 1))
            add("," + inner)
        parts[-1] = "\n" + "  " * depth + ("}" if isinstance(x, dict) else "]")
        return ("{" if isinstance(x, dict) else "[") + inner + "".join(parts)
