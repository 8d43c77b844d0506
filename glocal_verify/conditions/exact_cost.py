"""The exact-cost model: estimated seconds of a checker in exact rational arithmetic.

One model for ``verify --exact``'s size estimate (:func:`glocal_verify.conditions.cost.estimate_verify`)
and for the scheduler of ``verify``'s exact re-decisions
(:func:`glocal_verify.conditions.registry.exact_estimate`), which does not start a
re-decision whose estimate is far beyond the budget. The constants are tunables of
:mod:`glocal_verify.config`.
"""

from __future__ import annotations

from glocal_verify import config

__all__ = ["ZDA_PATHS", "exact_seconds", "zda_certificate_seconds"]


#: the ZDA paths of :func:`exact_seconds`
ZDA_PATHS = ("fast", "dense")


def zda_certificate_seconds(n: int) -> float:
    """Seconds of the minor certificate of the exact ZDA analysis (a characteristic polynomial
    modulo a prime): ``zda_certificate_seconds_n3`` N^3.

    Parameters
    ----------
    n : int
        Agents.
    """
    from glocal_verify.analysis.stealthy.zda_screens import minor_tables_seconds

    return minor_tables_seconds(n)


def exact_seconds(condition: str, n: int, *, zda_path: str | None = None) -> float:
    """Estimated seconds of one condition's checker in exact arithmetic on N agents.

    The one exact-cost model: ``verify --exact``'s size estimate (:func:`estimate_verify`) and
    the scheduler of ``verify``'s exact re-decisions (which does not start one whose estimate
    is far beyond the budget) both read it. With the tunables of :mod:`glocal_verify.config`:

    * ``central.observer``: ``exact_central_seconds_n4`` N^4 (the rational characteristic
      polynomial by the matrix determinant lemma and its Routh test);
    * ``stealthy.zda``, ``switching.avoids-attack``: on the proved zero polynomial (``zda_path``
      ``"fast"``, or None when unknown, as from the sizes alone) ``exact_zda_seconds_n3`` N^3;
      when the pencil needs the dense V* iteration over Q (``"dense"``: not left-invertible, or
      a zero multiplicity the bounds leave open) the minor certificate
      (:func:`zda_certificate_seconds`) plus ``exact_zda_dense_seconds_n4`` N^4;
    * every other global condition: ``exact_global_seconds_n3`` N^3; the local ones are
      estimated per design and case by :func:`estimate_verify`.

    Parameters
    ----------
    condition : str
        Condition id.
    n : int
        Agents.
    zda_path : {"fast", "dense"}, optional
        The exact ZDA analysis' path, when known.
    """
    nf = float(n)
    if condition == "central.observer":
        return float(config.get("exact_central_seconds_n4")) * nf**4
    if condition in ("stealthy.zda", "switching.avoids-attack"):
        if zda_path not in (None, *ZDA_PATHS):
            raise ValueError(f"zda_path must be one of {ZDA_PATHS} or None, not {zda_path!r}")
        if zda_path == "dense":
            return zda_certificate_seconds(n) + float(config.get("exact_zda_dense_seconds_n4")) * nf**4
        return float(config.get("exact_zda_seconds_n3")) * nf**3
    return float(config.get("exact_global_seconds_n3")) * nf**3
