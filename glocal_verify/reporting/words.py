"""Small helpers for the words of reports and command-line messages."""

from __future__ import annotations

__all__ = ["counted"]


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
