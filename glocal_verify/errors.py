"""Exception classes of glocal-verify.

Every error the library raises on purpose derives from :class:`GlocalVerifyError`.
Subclasses also derive from the builtin they refine, so callers may catch either.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = [
    "GlocalVerifyError",
    "SpecError",
    "ModelError",
    "UnknownConditionError",
    "NotApplicableError",
    "ConfigError",
    "ArgumentError",
    "shorten",
    "did_you_mean",
]

#: longest key path a message quotes whole (a longer one keeps its start and its end)
PATH_CHARS = 120
#: longest line an error message is cut to, whatever the user typed
LINE_CHARS = 400


def shorten(text: str, limit: int = LINE_CHARS) -> str:
    """``text`` on one line of at most ``limit`` characters: its first line, and when that is
    longer, its start and its end around ``...`` (a key path's last part often says the most).

    Parameters
    ----------
    text : str
    limit : int
        At least 20.

    Examples
    --------
    >>> shorten("a" * 30 + "b" * 30, 20)
    'aaaaaaaa...bbbbbbbbb'
    """
    first = text.splitlines()[0] if text else ""
    if len(first) <= limit:
        return first
    head = (limit - 3) // 2
    return f"{first[:head]}...{first[len(first) - (limit - 3 - head):]}"

def did_you_mean(word: str, choices: Iterable[str], *, otherwise: str = "") -> str:
    """The hint of an unknown name: ``"; did you mean a, b?"`` naming the closest ``choices``
    (at most three, :func:`difflib.get_close_matches`), else ``otherwise`` (e.g. the known names).

    Parameters
    ----------
    word : str
        The unknown name.
    choices : iterable of str
    otherwise : str
        The text when no choice is close.
    """
    import difflib

    close = difflib.get_close_matches(word, list(choices), n=3, cutoff=0.5)
    return f"; did you mean {', '.join(close)}?" if close else otherwise


class GlocalVerifyError(Exception):
    """Root of every exception raised by glocal-verify."""


class SpecError(ValueError, GlocalVerifyError):
    """A system specification is malformed or inconsistent.

    Parameters
    ----------
    path : str
        Key path inside the specification, e.g. ``clusters[2].observers[0].center``.
    problem : str
        What is wrong at that place.
    source : str, optional
        File the specification came from, if any.
    """

    def __init__(self, path: str, problem: str, source: str | None = None) -> None:
        self.path = path
        self.problem = problem
        self.source = source
        where = f"{shorten(source, PATH_CHARS)}: " if source else ""
        shown = shorten(path, PATH_CHARS)
        super().__init__(shorten(f"{where}{shown}: {problem}" if path else f"{where}{problem}"))


class ModelError(ValueError, GlocalVerifyError):
    """A model request does not fit the system (unknown mode, cluster, node ...)."""


class UnknownConditionError(KeyError, GlocalVerifyError):
    """A condition id is not in the catalogue; the message lists the closest ids."""

    def __str__(self) -> str:  # KeyError quotes its argument; keep the plain text
        return str(self.args[0]) if self.args else ""


class NotApplicableError(ValueError, GlocalVerifyError):
    """A check cannot be run on this system (e.g. a switching check without safe modes)."""


class ConfigError(ValueError, GlocalVerifyError):
    """An unknown tunable, or a value outside its domain (:mod:`glocal_verify.config`)."""


class ArgumentError(ValueError, TypeError, GlocalVerifyError):
    """An argument of a library call is outside its documented domain: a wrong type, a value
    out of range (NaN, a negative tolerance, an astronomical budget) or an unknown choice.

    A :class:`ValueError` and a :class:`TypeError`, so that callers catching either keep
    working; the message names the argument, e.g. ``max_attackers: expected an integer >= 1,
    got None``.
    """
