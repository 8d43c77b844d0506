"""``verify``: the checkers, the simulation by one option, and the assessment attached.

The command line (``glocal-verify verify``) and the library call the same function with the
same defaults, so ``verify(system)`` returns what the command reports: every condition
result, ``switching.detects`` simulated on networks of at most ``detects_max_agents``
(:mod:`glocal_verify.config`, the value in force) agents (``simulate="auto"``),
and :attr:`Report.assessment`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

from glocal_verify.answer.assessment import with_assessment
from glocal_verify import config
from glocal_verify.conditions.registry import check_conditions, expect_system
from glocal_verify.errors import ArgumentError
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import Report
from glocal_verify.spec.arguments import mapping_arg

__all__ = ["SIMULATE_CHOICES", "simulates", "verify"]

#: values of ``simulate``
SIMULATE_CHOICES = ("auto", "always", "never")


def simulates(system: System, simulate: str = "auto") -> bool:
    """Whether ``verify(system, simulate=...)`` runs the simulation of ``switching.detects``.

    ``auto``: on networks of at most ``detects_max_agents`` (:mod:`glocal_verify.config`) agents; ``always``; ``never``.
    """
    expect_system(system)
    if not isinstance(simulate, str) or simulate not in SIMULATE_CHOICES:
        raise ArgumentError(f"simulate: must be one of {', '.join(SIMULATE_CHOICES)}, not {simulate!r}"[:120])
    return simulate == "always" or (simulate == "auto" and system.n <= config.get("detects_max_agents"))


def verify(
    system: System,
    only: Iterable[str] | None = None,
    *,
    exact: bool = False,
    tol: Tolerance = DEFAULT_TOLERANCE,
    options: Mapping[str, Any] | None = None,
    progress: Callable[[str], None] | None = None,
    escalate: str = "auto",
    exact_budget: float | None = config.IN_FORCE,
    fragile_below: float | None = None,
    simulate: str = "auto",
) -> Report:
    """Check the conditions on ``system`` and attach the assessment (what ``glocal-verify verify`` reports).

    Parameters
    ----------
    system : System
    only : iterable of str, optional
        Condition ids or prefixes (``"switching.*"``) to run; default all.
    exact : bool
        Decide every condition over Q.
    tol : Tolerance
    options : mapping, optional
        Checker options (``lambda0``, ``max_zeros``, ``zda_method``, ``max_agents`` ...).
        ``options["simulate"]``, when given, overrides ``simulate``.
    progress : callable, optional
        Called with each condition id before it runs.
    escalate : {"auto", "never"}
        Re-decide numeric ``undecided`` results over Q within ``exact_budget``.
    exact_budget : float or None
        Seconds for all escalations of this call together (None: no limit; default the tunable
        ``exact_budget`` of :mod:`glocal_verify.config` in force, 30 s).
    fragile_below : float, optional
        Robustness tolerance of ``fragile`` (default: ``config.get("fragile_below")``).
    simulate : {"auto", "always", "never"}
        Run the simulation of ``switching.detects`` (Theorem III.3's conclusion, one simulated
        switch per safe mode): ``auto`` on at most ``detects_max_agents`` agents (the
        command line's default too). It never decides the answer; it is shown beside it.

    Returns
    -------
    Report
        With :attr:`Report.assessment` attached.
    """
    expect_system(system)
    opts = mapping_arg("options", options)
    opts.setdefault("simulate", simulates(system, simulate))
    report = check_conditions(
        system, only, exact=exact, tol=tol, options=opts, progress=progress, escalate=escalate, exact_budget=exact_budget, fragile_below=fragile_below
    )
    return with_assessment(report)
