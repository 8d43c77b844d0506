"""Derived results kept on the object that owns them: :class:`Analysis` and its typed :class:`Kind` keys.

A :class:`~glocal_verify.model.System` is immutable once built, so whatever is computed from
it (modal decompositions, unobservable subspaces, ZDA analyses, exact tables ...) can be kept
with it and shared by every checker: its :class:`Analysis`. Each kind of result is declared
once, by the module that computes it, as a :class:`Kind`: a name, the owning module and the
type of its values. That module reads and writes the kind through it
(``MODAL.get(system, (mode, tol), compute)``); no other module writes it, and no code reaches
the store with a bare string key (``tests/test_architecture.py`` checks both).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Generic, Protocol, TypeVar

import numpy as np

__all__ = ["Analysis", "Kind"]

T = TypeVar("T")


class Analysis:
    """The derived results of one :class:`System`, computed on first use and kept with it.

    Every analysis that more than one checker needs (modal decompositions, unobservable and
    switched subspaces, zero-dynamics analyses, simulated detections ...) is stored here under
    a key ``(kind, *parameters)`` naming what it depends on: the mode, the tolerance, the
    actuators, the schedule. A ``System`` is immutable once built, so nothing here goes stale;
    :meth:`clear` forgets everything (e.g. to measure a cold run). The eigendecompositions
    themselves are :class:`~glocal_verify.numerics.spectrum.Spectrum` objects held by the
    system (:meth:`System.spectrum`).

    Examples
    --------
    >>> a = Analysis()
    >>> a.get(("answer",), lambda: 42)
    42
    >>> a.kinds()
    {'answer': 1}

    Package code reaches it through :class:`Kind` keys only.
    """

    def __init__(self) -> None:
        self._store: dict[Hashable, Any] = {}

    def get(self, key: Hashable, compute: Callable[[], T]) -> T:
        """The result stored under ``key``, computing and storing it first if absent.

        Parameters
        ----------
        key : hashable
            ``(kind, *parameters)``.
        compute : callable
            Called without arguments when the key is absent.
        """
        if key not in self._store:
            self._store[key] = compute()
        return self._store[key]  # type: ignore[no-any-return]

    def __contains__(self, key: object) -> bool:
        return key in self._store

    def __getitem__(self, key: Hashable) -> Any:
        return self._store[key]

    def __setitem__(self, key: Hashable, value: Any) -> None:
        self._store[key] = value

    def __iter__(self) -> Iterator[Hashable]:
        return iter(self._store)

    def __len__(self) -> int:
        return len(self._store)

    def kinds(self) -> dict[str, int]:
        """How many results of each kind are held (the first element of each key)."""
        out: dict[str, int] = {}
        for key in self._store:
            kind = str(key[0]) if isinstance(key, tuple) and key else str(key)
            out[kind] = out.get(kind, 0) + 1
        return out

    def clear(self) -> None:
        """Forget every derived result."""
        self._store.clear()

    def __repr__(self) -> str:
        inner = ", ".join(f"{k}: {v}" for k, v in self.kinds().items())
        return f"Analysis({inner})"

    def __getstate__(self) -> dict[str, Any]:
        """The portable results only: a system sent to another process (a Dask worker) keeps
        its spectra and tables, and recomputes what holds python-flint objects (which do not
        pickle)."""
        return {"_store": {k: v for k, v in self._store.items() if _portable(v)}}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._store = dict(state["_store"])


def _portable(value: Any, depth: int = 0) -> bool:
    """Whether ``value`` pickles: plain data, numpy and scipy arrays, and containers or
    dataclasses of them (python-flint objects are not)."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes, Fraction)):
        return True
    if isinstance(value, np.ndarray):
        return value.dtype != object or all(_portable(x, depth + 1) for x in value.ravel()[:64])
    if type(value).__module__.startswith("flint"):
        return False
    if depth > 6:
        return True  # deep structures are plain data here; pickling will say otherwise
    if isinstance(value, (tuple, list, set, frozenset)):
        return all(_portable(x, depth + 1) for x in value)
    if isinstance(value, dict):
        return all(_portable(k, depth + 1) and _portable(v, depth + 1) for k, v in value.items())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return all(_portable(getattr(value, f.name), depth + 1) for f in dataclasses.fields(value))
    return True



class _Owner(Protocol):
    """Anything that holds an :class:`Analysis` (a :class:`~glocal_verify.model.System`)."""

    @property
    def analysis(self) -> Analysis: ...


@dataclass(frozen=True, slots=True)
class Kind(Generic[T]):
    """One kind of derived result: its name (the first element of its keys), owner and value type.

    Declared once, at module level, by the module that computes it, e.g.
    ``MODAL: Kind[ModalDecomposition] = Kind("modal", __name__, "ModalDecomposition")``.

    Attributes
    ----------
    name : str
        The kind's name, as :meth:`Analysis.kinds` counts it.
    owner : str
        The module that declares, computes and writes it (``__name__``).
    holds : str
        The type of its values (documentation; the type parameter ``T`` checks it statically).
    """

    name: str
    owner: str
    holds: str

    def get(self, system: _Owner, params: tuple[Hashable, ...], compute: Callable[[], T]) -> T:
        """The result for ``params`` kept on ``system``, computed by ``compute`` and kept first if absent.

        Parameters
        ----------
        system : System
        params : tuple
            What the result depends on (mode, tolerance, actuators ...).
        compute : callable
            Called without arguments when the result is absent.
        """
        return system.analysis.get((self.name, *params), compute)

    def peek(self, system: _Owner, params: tuple[Hashable, ...] = ()) -> T | None:
        """The result for ``params`` if it is kept, else None (nothing is computed).

        Parameters
        ----------
        system : System
        params : tuple
        """
        key = (self.name, *params)
        return system.analysis[key] if key in system.analysis else None  # type: ignore[no-any-return]

    def put(self, system: _Owner, params: tuple[Hashable, ...], value: T) -> None:
        """Keep ``value`` for ``params`` on ``system`` (replacing what was kept).

        Parameters
        ----------
        system : System
        params : tuple
        value : T
        """
        system.analysis[(self.name, *params)] = value
