"""Small helpers for the words of answers, reports and command-line messages.

Layer: the lowest, beside :mod:`glocal_verify.results`; imports nothing of the package.
"""

from __future__ import annotations

from typing import Any, Sequence

__all__ = ["counted", "format_labels", "format_lambda", "sentence", "slug"]


def counted(count: int, noun: str, plural: str | None = None) -> str:
    """``count`` followed by ``noun`` in the number it takes: ``1 mode``, ``4 modes``, ``0 modes``.

    Parameters
    ----------
    count : int
    noun : str
        The singular.
    plural : str, optional
        The plural when it is not ``noun + "s"`` (``counted(2, "matrix", "matrices")``).

    Examples
    --------
    >>> counted(1, "mode"), counted(3, "agent"), counted(2, "safe mode")
    ('1 mode', '3 agents', '2 safe modes')
    """
    return f"{count} {noun if count == 1 else (plural or noun + 's')}"


def format_labels(xs: Sequence[Any]) -> str:
    """``"3, 4"``."""
    return ", ".join(str(x) for x in xs)


def format_lambda(lam: complex | None) -> str:
    """``"0.5"``, ``"-0.5 + 2.63i"``."""
    if lam is None:
        return "?"
    c = complex(lam)
    if c.imag == 0.0:
        return f"{c.real:g}"
    return f"{c.real:g} {'+' if c.imag > 0 else '-'} {abs(c.imag):g}i"


def slug(text: str) -> str:
    """``text`` as a file-name component: letters, digits, ``.`` and ``_`` (others become ``_``), at most 40."""
    out = "".join(ch if ch.isalnum() or ch in "._" else "_" for ch in text)[:40]
    return out or "x"


def sentence(text: str) -> str:
    """``text`` as a sentence: a capital first letter and a full stop, an identifier kept as written.

    A text that starts with a condition id, a symbol or a file name (``stealthy.zda``,
    ``x(t0)``, ``x*``, ``my.toml``: a first word holding ``.``, ``(``, ``*``, ``_``, ``@`` or
    ``/``) keeps its case; rephrase such a message rather than start it with an identifier.

    Examples
    --------
    >>> sentence("not evaluated: stealthy.zda (--only)")
    'Not evaluated: stealthy.zda (--only).'
    >>> sentence("x(t0) cannot be reconstructed.")
    'x(t0) cannot be reconstructed.'
    """
    text = text.strip()
    if not text:
        return text
    first = text.split(maxsplit=1)[0]
    if not any(ch in first for ch in ".(*_@/"):
        text = text[0].upper() + text[1:]
    return text if text.endswith((".", "!", "?", ":")) else text + "."
