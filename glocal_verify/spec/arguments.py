"""Domains of the arguments of library calls, checked where a call enters the library.

A spec is validated by :mod:`glocal_verify.spec.load`; the other inputs a caller passes
(``verify(..., exact_budget=...)``, ``audit(system, max_attackers)``, a
:class:`~glocal_verify.numerics.tolerance.Tolerance`) are checked by these functions, which
raise :class:`~glocal_verify.errors.ArgumentError` naming the argument and its domain, in one
line: ``max_attackers: expected an integer >= 1, got None``. Python and numpy integers and
reals are accepted; booleans, NaN and text are not.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping
from typing import Any

from glocal_verify.errors import ArgumentError

__all__ = ["integer_arg", "real_arg", "choice_arg", "id_list_arg", "instance_arg", "mapping_arg", "callable_arg"]


def _show(value: Any) -> str:
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - an object whose repr fails
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 60 else text[:50] + "..."


def integer_arg(name: str, value: Any, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` as an ``int`` in ``[lo, hi]``.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : object
    lo, hi : int, optional
        Bounds (inclusive).
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ArgumentError(f"{name}: expected an integer{_range(lo, hi)}, got {_show(value)}")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ArgumentError(f"{name}: expected an integer{_range(lo, hi)}, got {v}")
    return v


def real_arg(name: str, value: Any, lo: float | None = None, hi: float | None = None, *, allow_inf: bool = False) -> float:
    """``value`` as a ``float`` in ``[lo, hi]``; never NaN, infinite only with ``allow_inf``.

    Parameters
    ----------
    name : str
    value : object
    lo, hi : float, optional
        Bounds (inclusive).
    allow_inf : bool
        Accept ``+inf`` (when ``hi`` allows it), e.g. a time budget meaning "no limit".
    """
    what = "a real number" if not allow_inf else "a real number or inf"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentError(f"{name}: expected {what}{_range(lo, hi)}, got {_show(value)}")
    v = float(value)
    if math.isnan(v) or (math.isinf(v) and not allow_inf) or (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ArgumentError(f"{name}: expected {what}{_range(lo, hi)}, got {_show(value)}")
    return v


def choice_arg(name: str, value: Any, choices: Iterable[str]) -> str:
    """``value``, one of ``choices``.

    Parameters
    ----------
    name : str
    value : object
    choices : iterable of str
    """
    options = tuple(choices)
    if not isinstance(value, str) or value not in options:
        raise ArgumentError(f"{name}: expected one of {', '.join(repr(c) for c in options)}, got {_show(value)}")
    return value


def id_list_arg(name: str, value: Any) -> list[str] | None:
    """Condition ids: None, one id, or an iterable of ids (each a string).

    Parameters
    ----------
    name : str
    value : object
    """
    if value is None:
        return None
    if isinstance(value, str):
        return [value]
    try:
        items = list(value)
    except TypeError:
        raise ArgumentError(f"{name}: expected condition ids (a string or a list of strings), got {_show(value)}") from None
    bad = [x for x in items if not isinstance(x, str)]
    if bad:
        raise ArgumentError(f"{name}: condition ids are strings, got {_show(bad[0])}")
    return items


def instance_arg(name: str, value: Any, types: type | tuple[type, ...], expected: str) -> Any:
    """``value`` when it is an instance of ``types``.

    Parameters
    ----------
    name : str
        The argument's name (or the function's, for its first argument), for the message.
    value : object
    types : type or tuple of types
    expected : str
        What the caller should pass, in words (``"a System"``).
    """
    if not isinstance(value, types):
        raise ArgumentError(f"{name}: expected {expected}, got {_show(value) if value is None else type(value).__name__}")
    return value


def mapping_arg(name: str, value: Any) -> dict[str, Any]:
    """``value`` (None or a mapping with string keys) as a new ``dict``.

    Parameters
    ----------
    name : str
    value : object
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ArgumentError(f"{name}: expected a mapping (e.g. a dict of option names to values), got {_show(value)}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise ArgumentError(f"{name}: keys are names (strings), got {_show(bad[0])}")
    return dict(value)


def callable_arg(name: str, value: Any) -> Any:
    """``value`` when it is None or callable (a progress callback, a hook).

    Parameters
    ----------
    name : str
    value : object
    """
    if value is not None and not callable(value):
        raise ArgumentError(f"{name}: expected a function (or None), got {_show(value)}")
    return value


def _range(lo: float | None, hi: float | None) -> str:
    if lo is not None and hi is not None:
        return f" in [{lo:g}, {hi:g}]"
    if lo is not None:
        return f" >= {lo:g}"
    if hi is not None:
        return f" <= {hi:g}"
    return ""
