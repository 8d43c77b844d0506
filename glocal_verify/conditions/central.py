"""The ``central.observer`` checker and the finding that the paper's observer requirement is infeasible.

Holds when the designed gain H (:func:`~glocal_verify.observers.central.design_central_observer`)
makes ``A_1 - H C`` stable on the observable part; the fixed unobservable eigenvalues are
reported in the witness. With privacy (``[1; 0]`` in ``ker C``), ``0`` is an eigenvalue of
``A_q - H C`` for every H, so the paper's "Hurwitz in all modes" is infeasible: a finding.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import flint
import numpy as np

from glocal_verify.analysis.unobservable import (
    exact_A,
    exact_C,
    exact_N,
    certified_unobservable,
)
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    result,
)
from glocal_verify.model import System
from glocal_verify.observers.central import (
    CentralObserver,
    certify_observable_stability,
    design_central_observer,
    observer_charpoly_exact,
    routh_hurwitz_poly,
)
from glocal_verify.results import ConditionResult, Finding, Status

__all__ = [
    "check_central_observer",
    "hurwitz_infeasible_finding",
]

def _exact_observable_hurwitz(system: System, obsv: CentralObserver) -> tuple[bool, str]:
    """Exactly: is the observable part of A_1 - H C Hurwitz, for H rounded to its binary rationals?"""
    n2 = 2 * system.n
    A = exact_A(system, obsv.mode)
    C = exact_C(system)
    p = C.nrows()
    Hq = flint.fmpq_mat(n2, p, [flint.fmpq(*Fraction(float(x)).as_integer_ratio()) for x in obsv.H.ravel()])
    chi = observer_charpoly_exact(system, Hq, obsv.mode)  # det(sI - A + Hq C) by the modal structure
    X = exact_N(system, obsv.mode)
    if X.ncols():
        # A X = X B: B = (X^T X)^{-1} X^T A X, the restriction of A (= A - HC) to N
        XT = X.transpose()
        B = (XT * X).inv() * (XT * A * X)
        chi_u = B.charpoly()
        q, r = divmod(chi, chi_u)
        if not r.is_zero():
            return False, "internal: the unobservable characteristic polynomial does not divide"
    else:
        q = chi
    ok = routh_hurwitz_poly(q)
    return ok, f"observable characteristic polynomial of degree {q.degree()} {'is' if ok else 'is not'} Hurwitz (Routh)"


# --------------------------------------------------------------------------------------------
# checker and finding


def _cplx(z: complex) -> list[float] | float:
    z = complex(z)
    return float(z.real) if z.imag == 0 else [float(z.real), float(z.imag)]


@checker("central.observer")
def check_central_observer(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Centralised observer (eq. ``obs_cent``): ``A_1 - H C`` is stable on the observable part.

    .. math:: \\max \\operatorname{Re} \\lambda\\big((A_1 - H C)|_{\\mathbb R^{2N} / \\mathcal N(A_1, C)}\\big) < 0

    with H from :func:`design_central_observer` (Riccati gain; ``options["central_poles"]`` for
    pole placement). The fixed eigenvalues (A_1 on the unobservable subspace) are reported,
    not judged. Scope: global (the gain is designed for the normal mode).

    Numeric (certified): :func:`~glocal_verify.observers.central.certify_observable_stability`,
    a Bauer-Fike bound on the eigenvalues of the observable quotient of ``A_1 - H C`` (exact
    A_1, the designed float H) over the proven unobservable subspace; holds iff every disc lies
    in ``Re < 0``, fails iff an isolated disc lies in ``Re > 0``, undecided otherwise (and
    when the unobservable subspace is not proven), with ``error_bound`` = the radius. A small
    stability margin is robustness (``margin``), never a failure by itself. Exact: the gain is rounded to its binary rationals; the characteristic
    polynomial of ``A_1 - H C`` over Q (:func:`~glocal_verify.observers.central.observer_charpoly_exact`:
    the matrix determinant lemma on the N-sized transfer numerators, no 2N x 2N matrix)
    divided by that of A_1 on the rational unobservable subspace is tested with the exact
    Routh-Hurwitz criterion (the Routh array of
    :func:`~glocal_verify.observers.central.routh_hurwitz`, on integer rows with their contents removed).

    Margin
        The stability margin ``-max Re`` on the observable part (floating point).
    Witness
        ``design`` (method, designed and observable states, ``||H||``), the slowest observable
        eigenvalues, the fixed eigenvalues, and per mode ``||(A_q - H C)[1; 0]||`` when
        ``[1; 0] in ker C`` (a zero in every mode: see the finding).
    """
    poles = ctx.options.get("central_poles")
    try:
        obsv = design_central_observer(system, poles=poles, tol=ctx.tol)
    except (ValueError, np.linalg.LinAlgError) as err:
        if poles is not None and "cumulative sizes" in str(err):
            raise
        # the floating-point design broke down (e.g. a Riccati equation too ill-conditioned)
        why = f"the observer design failed in floating point: {err}"
        if ctx.exact:
            # the observable quotient of (A_1, C) is observable, so some injection gain places its
            # eigenvalues anywhere (pole placement); the condition holds, only this design failed
            return [result("central.observer", ctx, Status.HOLDS, margin=None, witness={
                "reason": "the observable part of (A_1, C) is observable: an output injection gain making it "
                "Hurwitz exists (pole-placement theorem); " + why})]
        return [result("central.observer", ctx, Status.UNDECIDED, margin=None, witness={"design_error": str(err)},
                       error_bound=math.inf, note=why)]
    n = system.n
    w = system.spectrum(obsv.mode).values
    scale = max(
        (float(np.linalg.norm([[0.0, 1.0], [-system.alpha * mu, -system.gamma]], 2)) for mu in (w[0], w[-1])),
        default=1.0,
    )
    order = np.argsort(-obsv.observable_eigenvalues.real)
    slow = [_cplx(z) for z in obsv.observable_eigenvalues[order][:6]]
    witness: dict[str, Any] = {
        "design": {
            "method": obsv.method,
            "designed_states": obsv.designed_states,
            "observable_states": obsv.observable_states,
            "unobservable_states": obsv.unobservable.dim,
            "gain_norm": float(np.linalg.norm(obsv.H, 2)) if obsv.H.size else 0.0,
        },
        "slowest_observable_eigenvalues": slow,
        "fixed_eigenvalues": [_cplx(z) for z in obsv.fixed_eigenvalues[:12]],
        "fixed_count": len(obsv.fixed_eigenvalues),
    }
    if not system.monitored_positions:
        e = np.zeros(2 * n)
        e[:n] = 1.0 / math.sqrt(n)
        He = obsv.H @ (system.C() @ e)
        witness["consensus_null_residual"] = {
            q: float(np.linalg.norm(np.concatenate([He[:n], -system.alpha * (system.laplacian_sparse(q) @ e[:n]) - He[n:]])))
            for q in system.modes
        }
    m = -obsv.stability_margin if math.isfinite(obsv.stability_margin) else -math.inf
    bound: float | None = None
    note = ""
    if ctx.exact:
        ok, why = _exact_observable_hurwitz(system, obsv)
        status = Status.HOLDS if ok else Status.FAILS
        witness["exact"] = why
    elif not math.isfinite(m) and certified_unobservable(system, obsv.mode).dim_upper == 2 * n:
        status = Status.HOLDS
        witness["note"] = "the observable part is empty"
        bound, note = 0.0, ""
    else:
        cert = certify_observable_stability(system, obsv)
        status = {"stable": Status.HOLDS, "unstable": Status.FAILS, "undecided": Status.UNDECIDED}[cert.decision]
        witness["certificate"] = {"max_real": cert.max_real, "bauer_fike_radius": cert.radius}
        bound, note = cert.radius, cert.note
    if ctx.exact:
        bound, note = None, ""
    rel = obsv.stability_margin / scale if math.isfinite(obsv.stability_margin) and scale > 0 else obsv.stability_margin
    witness["relative_margin"] = rel
    return [result("central.observer", ctx, status, margin=obsv.stability_margin, witness=witness, error_bound=bound, note=note)]


@finding_rule
def hurwitz_infeasible_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """eq. ``obs_cent``: "A_sigma - H C Hurwitz in all modes" is infeasible when privacy holds.

    With ``M_x`` empty, ``C [1; 0] = 0`` and ``A_q [1; 0] = [0; -alpha L_q 1] = 0``, so
    ``(A_q - H C)[1; 0] = 0`` for every H and every mode q: 0 is always an eigenvalue. The rule
    fires when ``central.observer`` was checked on such a system; its data are the per-mode norms
    ``||A_q [1; 0]||`` (exactly 0: Laplacian rows sum to zero).
    """
    if not any(r.id == "central.observer" for r in results) or system.monitored_positions:
        return []
    n = system.n
    e = np.ones(n) / math.sqrt(n)
    data = {q: float(np.linalg.norm(system.alpha * (system.laplacian_sparse(q) @ e))) for q in system.modes}
    return [
        Finding(
            "central.hurwitz-infeasible",
            "No observer gain makes A_sigma - H C Hurwitz when Lemma III.1's privacy holds",
            "The paper asks an LMI for a constant H with (A_sigma - H C) Hurwitz in all modes. With no position "
            "monitored, [1; 0] is in ker C and A_q [1; 0] = 0, so (A_q - H C)[1; 0] = 0 for every H: 0 is an "
            "eigenvalue in every mode. The toolkit designs H stable on the observable part and reports the fixed "
            "eigenvalues. Minimal example: two agents, one edge, agent 2's velocity monitored.",
            "eq. obs_cent with Lemma III.1",
            {"A_q_times_consensus_norm": data, "C_times_consensus": 0},
        )
    ]
