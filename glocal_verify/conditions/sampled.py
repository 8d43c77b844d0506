"""The ``sampled.*`` checkers: the paper's conditions re-decided for the sampled implementation.

With ``[implementation]`` the detectors sample at period h and held signals are constant over a
period; :mod:`glocal_verify.analysis.sampled.loop` gives the exact discretisation mode by mode
(2 x 2 blocks per Laplacian eigenvalue). Each checker reads like its continuous counterpart:

* ``sampled.stability`` -- the sampled loop converges to consensus (a sampled-data controller
  is stable only for ``gamma h < 2`` and ``h < 2 gamma / (alpha mu_max)``);
* ``sampled.no-aliasing`` -- Theorem III.3 (ii) for the sampled loop: distinct eigenvalues of
  ``L_q`` stay distinct after sampling (no two modes alias, no block becomes a multiple of I);
* ``sampled.observability`` -- Lemma II.3 for the sampled loop: ``N(Phi_q, C) = N(A_q, C)``;
* ``sampled.zda`` -- Proposition II.4 (ii) for the sampled pencil; sampling creates zeros;
* ``sampled.local-uio`` -- Proposition III.2: a sampled-data UIO of each local observer.

Without ``[implementation]`` they give no result (listed as not evaluated).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from glocal_verify.analysis.sampled.loop import sampled_aliasing, sampled_observability, sampled_stability
from glocal_verify.analysis.sampled.zda import sampled_zda
from glocal_verify.conditions.registry import CheckContext, checker, result
from glocal_verify.conditions.premises import missing_input
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.certified_rows import power_certificate
from glocal_verify.numerics.hurwitz import schur_cohn, unobservable_schur_stable
from glocal_verify.observers.sampled import DecouplingError, design_sampled_uio, sampled_cluster_model, to_float
from glocal_verify.results import ConditionResult, Status

__all__ = [
    "check_sampled_stability",
    "check_sampled_no_aliasing",
    "check_sampled_observability",
    "check_sampled_zda",
    "check_sampled_local_uio",
]


def _period(system: System) -> dict[str, Any]:
    impl = system.spec.implementation
    assert impl is not None
    return {"period": impl.period, "controller": impl.controller}


@checker("sampled.stability")
def check_sampled_stability(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """The sampled loop is stable apart from its consensus.

    .. math:: |z| < 1 \\text{ for every eigenvalue z of } \\Phi_q \\text{ but one } z = 1 \\text{ per component}

    Numeric: the certified enclosures of the block eigenvalues
    (:func:`~glocal_verify.analysis.sampled.loop.sampled_stability`); exact: the sampled
    controller by Jury's test over Q (``gamma h < 2`` and ``L_q < 2 gamma / (alpha h)``, the
    latter by Descartes' rule on the characteristic polynomial), the continuous loop always.

    Margin
        ``1 - max |z|`` (a distance: fragile when tiny).
    Witness
        spectral radius, its certified radius, the largest stable period (sampled controller).
    """
    if missing_input(system, "sampled.stability") is not None:
        return []
    out = []
    for q in system.modes:
        st = sampled_stability(system, q, exact=ctx.exact)
        w = {**_period(system), "spectral_radius": st.spectral_radius, "error_bound": st.error_bound, "largest_stable_period": st.limit_period}
        out.append(result("sampled.stability", ctx, st.status, scope={"mode": q}, margin=st.margin, witness=w, error_bound=st.error_bound))
    return out


@checker("sampled.no-aliasing")
def check_sampled_no_aliasing(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3 (ii) for the sampled loop: sampling aliases no two modes.

    For distinct eigenvalues ``mu_a != mu_b`` of ``L_q``, the blocks :math:`\\Phi(\\mu_a)` and
    :math:`\\Phi(\\mu_b)` share no eigenvalue, and no block is a multiple of I. Numeric: the
    certified enclosures separate every pair (else undecided); exact: the sampled controller
    aliases only at ``gamma h = 2``; a continuous loop sampled at a rational period never
    aliases (Lindemann-Weierstrass, :mod:`glocal_verify.analysis.sampled.loop`).

    Margin
        The smallest distance between sampled eigenvalues of distinct modes (or of an
        off-diagonal block entry from 0).
    Witness
        The closest pair (``mu``, ``z``), for the continuous loop the nearest pathological
        period ``h* = 2 pi k / |omega_a -/+ omega_b|``; on overlap the pairs involved.
    """
    if missing_input(system, "sampled.no-aliasing") is not None:
        return []
    out = []
    for q in system.modes:
        al = sampled_aliasing(system, q, exact=ctx.exact)
        w = {**_period(system), "closest": al.closest, "overlaps": [list(p) for p in al.overlaps], "method": al.method}
        out.append(result("sampled.no-aliasing", ctx, al.status, scope={"mode": q}, margin=al.margin, witness=w, error_bound=al.error_bound))
    return out


@checker("sampled.observability")
def check_sampled_observability(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma II.3 for the sampled loop: ``N(Phi_q, C) = N(A_q, C)`` (Kalman-Ho-Narendra).

    Holds when sampling aliases nothing (then ``A_q`` is a polynomial in ``Phi_q``); the
    sampled controller at ``gamma h = 2`` is decided by the exact dimensions over Q or by the
    exact eigenvectors ``[0; v]`` of -1 in ``ker C``
    (:func:`~glocal_verify.analysis.sampled.loop.sampled_observability`). Privacy is never weakened
    by sampling (the sampled unobservable subspace contains the continuous one); detection is.

    Margin
        The aliasing margin. Witness: the dimensions when computed, the reason.
    """
    if missing_input(system, "sampled.observability") is not None:
        return []
    out = []
    for q in system.modes:
        so = sampled_observability(system, q, exact=ctx.exact)
        w = {**_period(system), "dim_continuous": so.dim_continuous, "dim_sampled": so.dim_sampled, "reason": so.reason}
        out.append(result("sampled.observability", ctx, so.status, scope={"mode": q}, margin=so.aliasing.margin, witness=w))
    return out


@checker("sampled.zda")
def check_sampled_zda(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition II.4 (ii) for the sampled loop: a stealthy ZDA of ``(Phi_1, Gamma_F, C)``.

    .. math::

        \\begin{bmatrix} z_0 I - \\Phi_1 & -\\Gamma_F \\\\ C & 0 \\end{bmatrix}
        \\begin{bmatrix} \\tilde x_0 \\\\ u_0 \\end{bmatrix} = 0,\\quad u_0 \\ne 0

    Numeric: the dense pencil in delta form, certified at the tolerance
    (:func:`~glocal_verify.analysis.sampled.zda.sampled_zda`); the sampled controller's zero
    at -1 (``F`` not inside ``M_v``) is exact and structural. Exact: the geometric analysis
    over Q (sampled controller); the continuous loop's pencil is transcendental, so its result
    stays numeric even under ``--exact`` (it says so).

    Margin
        The growth rate ``log|z| / h`` of the fastest attack zero (``+inf`` when not
        left-invertible, ``-inf`` when none). Witness: left-invertibility, zeros (at most 50)
        with modulus and growth, the actuators with the zero at -1.
    """
    impl = system.spec.implementation
    if impl is None or missing_input(system, "sampled.zda") is not None:
        return []
    exact_ok = ctx.exact and impl.controller == "sampled"
    rctx = ctx if (not ctx.exact or exact_ok) else CheckContext(exact=False, tol=ctx.tol, options=ctx.options, fragile_below=ctx.fragile_below)
    z = sampled_zda(system, impl, tol=ctx.tol, exact=exact_ok)
    h = float(impl.period)
    mod = z.largest_modulus
    margin = math.inf if math.isinf(mod) else (math.log(mod) / h if mod > 0 else -math.inf)
    w = {
        **_period(system),
        "left_invertible": z.left_invertible,
        "zeros": [{"z": zz.value, "modulus": zz.modulus, "growth": zz.growth, "attack": zz.attack} for zz in z.zeros[:50]],
        "nyquist_zero_actuators": list(z.nyquist) if z.nyquist is not None else None,
    }
    note = z.note if z.status is Status.UNDECIDED else ""
    if ctx.exact and not exact_ok:
        note = (note + "; " if note else "") + "the continuous loop's sampled pencil is transcendental: decided numerically"
    return [result("sampled.zda", rctx, z.status, margin=margin, witness=w, note=note)]


@checker("sampled.local-uio")
def check_sampled_local_uio(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition III.2 for the sampled loop: a sampled-data UIO of each local observer.

    With a sampled controller the neighbours' positions reach a boundary agent through its
    held command: the unknown input is constant over a period and enters through
    ``E_d = [h^2/2 S_dP^T; h S_dP^T]``. The UIO exists iff ``rank(C E_d) = rank(E_d)`` and
    ``(T A_d, C)`` is detectable (Chen, Patton & Zhang's conditions in discrete time). It is
    designed (:func:`~glocal_verify.observers.sampled.design_sampled_uio`, exact decoupling)
    and its ``F`` certified Schur-stable by the power bootstrap of
    :mod:`glocal_verify.numerics.certified_rows`. Exact: the rank condition over Q, and the
    Schur-Cohn test over Q of the designed ``F`` (or, without a design, of the unobservable
    part of ``(T A_d, C)``). A continuous loop has no sampled UIO of this kind (the neighbours'
    states vary inside a period): no result.

    Margin
        ``1 - rho(F)`` (0 on failure). Witness: order, spectral radius, certificate or reason.
    """
    impl = system.spec.implementation
    if impl is None or missing_input(system, "sampled.local-uio") is not None:
        return []
    out = []
    for lo in system.observers():
        scope = {"cluster": lo.cluster, "observer": lo.center}
        base = {**_period(system)}
        try:
            m = sampled_cluster_model(system, lo, impl)
        except DecouplingError as exc:
            out.append(result("sampled.local-uio", ctx, Status.FAILS, scope=scope, margin=0.0, witness={**base, "reason": str(exc)}, numeric_decision=False))
            continue
        try:
            o = design_sampled_uio(system, lo, impl)
        except NotApplicableError as exc:
            if ctx.exact:
                ok = unobservable_schur_stable(m.Abar, m.C)
                st = Status.HOLDS if ok else Status.FAILS
                out.append(result("sampled.local-uio", ctx, st, scope=scope, margin=0.0, witness={**base, "reason": f"design failed ({exc}); exact detectability {'holds' if ok else 'fails'}"}))
            else:
                out.append(result("sampled.local-uio", ctx, Status.UNDECIDED, scope=scope, witness={**base, "reason": str(exc)}, note="no stabilising design was found numerically; --exact decides detectability"))
            continue
        rho = float(max(abs(np.linalg.eigvals(to_float(o.F)))))
        w: dict[str, Any] = {**base, "order": o.order, "spectral_radius": rho}
        if ctx.exact:
            w["method"] = "Schur-Cohn over Q"
            status = Status.HOLDS if schur_cohn(o.F.charpoly()) else Status.FAILS
        else:
            pc = power_certificate(o.F)
            w["certificate"] = {"window": pc.window, "theta": pc.theta, "kappa": pc.kappa}
            status = Status.HOLDS if pc.theta < 1 else Status.UNDECIDED
        out.append(result("sampled.local-uio", ctx, status, scope=scope, margin=1.0 - rho, witness=w))
    return out
