"""The rule of ``central.observer``: the designed centralised observer is stable on the observable part.

The gain H comes from :func:`~glocal_verify.observers.central.design_central_observer` (a
Riccati gain, or pole placement); the verdict is on ``A_1 - H C`` restricted to the
observable quotient, certified by a Bauer-Fike bound in floating point
(:func:`~glocal_verify.observers.central.certify_observable_stability`) or decided over Q by
the Routh-Hurwitz test of its characteristic polynomial (H rounded to its binary rationals).
The rule lives in this layer, above :mod:`glocal_verify.analysis`, because it designs the
observer it certifies.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.analysis.unobservable.subspace import (
    certified_unobservable,
    exact_A,
    exact_C,
    exact_N,
)
from glocal_verify.model import System
from glocal_verify.numerics.hurwitz import routh_hurwitz_poly
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.observers.central import (
    CentralObserver,
    certify_observable_stability,
    design_central_observer,
    observer_charpoly_exact,
)
from glocal_verify.results import Status, Verdict

__all__ = ["INJECTION_THEOREM", "central_observer_verdict", "observable_hurwitz_exact"]


def observable_hurwitz_exact(system: System, obsv: CentralObserver) -> tuple[bool, str]:
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


#: the proof of a stiffness-injection design, one line for the witness
INJECTION_THEOREM = (
    "H = [0; alpha S_Mx^T] gives A_1 - H C = [[0, I], [-K, -gamma I]] with K = alpha (L_1 + S_Mx^T S_Mx) >= 0: "
    "lam^2 + gamma lam + x*Kx = 0 for an eigenvector [x; lam x], so Re lam < 0 except lam = 0 on [x; 0], x in ker K, "
    "which is unobservable and has no Jordan chain (exact, every N)"
)


def _cplx(z: complex) -> list[float] | float:
    z = complex(z)
    return float(z.real) if z.imag == 0 else [float(z.real), float(z.imag)]


def central_observer_verdict(
    system: System, poles: Sequence[complex] | None = None, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False
) -> Verdict:
    """Is ``A_1 - H C`` stable on the observable part, for the designed gain H? (``central.observer``).

    .. math:: \\max \\operatorname{Re} \\lambda\\big((A_1 - H C)|_{\\mathbb R^{2N} / \\mathcal N(A_1, C)}\\big) < 0

    Numeric (certified): the Bauer-Fike discs of the observable quotient (exact A_1, the
    designed float H) over the proven unobservable subspace: holds iff every disc lies in
    ``Re < 0``, fails iff an isolated disc lies in ``Re > 0``, undecided otherwise, with
    ``error_bound`` the radius. Exact: the characteristic polynomial of ``A_1 - H C`` over Q
    divided by that of A_1 on the rational unobservable subspace, by the Routh-Hurwitz test.
    A design that breaks down in floating point is undecided (numeric) or holds (exact: the
    observable quotient is observable, so some gain stabilises it). Above
    ``central_certify_max_states`` observable states the design is the stiffness injection,
    whose stability is a theorem (:data:`INJECTION_THEOREM`): holds, numeric and exact alike.

    Parameters
    ----------
    system : System
    poles : sequence of complex, optional
        Poles for a pole-placement design (default: the Riccati gain).
    tol : Tolerance
    exact : bool

    Returns
    -------
    Verdict
        Margin the stability margin ``-max Re`` on the observable part; witness the design,
        the slowest observable and the fixed eigenvalues and, without position monitor, the
        per-mode ``||(A_q - H C)[1; 0]||``.
    """
    try:
        obsv = design_central_observer(system, poles=poles, tol=tol)
    except (ValueError, np.linalg.LinAlgError) as err:
        if poles is not None and "cumulative sizes" in str(err):
            raise
        # the floating-point design broke down (e.g. a Riccati equation too ill-conditioned)
        why = f"the observer design failed in floating point: {err}"
        if exact:
            # the observable quotient of (A_1, C) is observable, so some injection gain places its
            # eigenvalues anywhere (pole placement); the condition holds, only this design failed
            return Verdict(Status.HOLDS, witness={
                "reason": "the observable part of (A_1, C) is observable: an output injection gain making it "
                "Hurwitz exists (pole-placement theorem); " + why}, exact=True)
        return Verdict(Status.UNDECIDED, witness={"design_error": str(err)}, error_bound=math.inf, note=why)
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
    if obsv.method == "injection":
        # a theorem on damped second-order systems (design_central_observer, "Injection design"):
        # exact for every symmetric L_1 >= 0 and alpha, gamma, k > 0, whatever the size
        status = Status.HOLDS
        witness["certificate"] = {"by": INJECTION_THEOREM}
        bound, note = 0.0, ""
        if exact:
            witness["exact"] = INJECTION_THEOREM
    elif exact:
        ok, why = observable_hurwitz_exact(system, obsv)
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
    if exact:
        bound, note = None, ""
    rel = obsv.stability_margin / scale if math.isfinite(obsv.stability_margin) and scale > 0 else obsv.stability_margin
    witness["relative_margin"] = rel
    return Verdict(status, margin=obsv.stability_margin, error_bound=bound, witness=witness, exact=exact, note=note)
