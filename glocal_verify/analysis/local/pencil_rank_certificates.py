"""Certificates of Proposition III.2 (iii) at every lam != 0 that need no choice of rows.

The maximal minors of :func:`~glocal_verify.analysis.local.cases.minor_certificate` choose rows
of the reduced pencil; the two proofs here do not, so factors of parts of the cluster's graph
shared by the structured minors cannot hide them:

- :func:`observability_certificate` -- every input agent measured: a block Krylov rank modulo a
  prime (Hautus);
- :func:`zero_count_certificate` -- any observer: the modular zero count of the cluster's
  pencil in s (left-invertible, no finite zero).

Both are exact (reduction modulo a prime never raises a rank or a count's proof); lam = 0 is
left to the caller. :func:`~glocal_verify.analysis.local.cases.minor_certificate` tries them
after its own tables.
"""

from __future__ import annotations

from fractions import Fraction
from typing import TYPE_CHECKING

from glocal_verify.model import System

if TYPE_CHECKING:
    from glocal_verify.analysis.local.cases import LocalCase

__all__ = ["measured_inputs_unknown", "observability_certificate", "zero_count_certificate"]


def measured_inputs_unknown(case: LocalCase) -> tuple[set[int], set[int], list[int]]:
    """(M, I, U) in cluster indices: the agents the observer measures (positions or
    velocities: lam != 0), the input agents (suspected and boundary) and the unmeasured ones.

    Parameters
    ----------
    case : LocalCase
    """
    cm, obs = case.model, case.observer
    idx = {a: k for k, a in enumerate(cm.nodes)}
    measured = {idx[a] for a in obs.positions} | {idx[a] for a in obs.velocities}
    inputs = {idx[a] for a in case.suspected} | {idx[a] for a in cm.boundary}
    return measured, inputs, [i for i in range(len(cm.nodes)) if i not in measured]


def observability_certificate(system: System, case: LocalCase) -> str | None:
    """Prove Proposition III.2 (iii) at every lam != 0 by a block Krylov rank modulo a prime, or return None.

    When every input agent (suspected or boundary) is measured, I' = I ∩ U is empty and the
    reduced pencil of :mod:`glocal_verify.numerics.minors` is
    ``T(s) = [s I + alpha L[U, U]; alpha L[M', U]]`` (M' = M \\ I): it has full column rank
    for every complex s iff ``(-alpha L[U, U], L[M', U])`` is observable (Hautus), which the
    rank n_U of ``[C; C A; ...]`` modulo a prime proves over Q
    (:func:`~glocal_verify.numerics.krylov.krylov_rank_mod`: reduction never raises a rank).
    Unlike maximal minors it needs no choice of rows, so factors of parts of G[U] shared by
    the structured minors cannot hide the proof. lam = 0 is left to the caller.

    Parameters
    ----------
    system : System
    case : LocalCase

    Returns
    -------
    str or None
        The certificate, one line; None proves nothing (an unmeasured input agent, or a rank
        below n_U modulo the prime).
    """
    from glocal_verify.numerics.krylov import krylov_rank_mod

    cm = case.model
    measured, inputs, U = measured_inputs_unknown(case)
    if not inputs <= measured:
        return None
    if not U:
        return "every agent of the cluster is measured: T(s) has no column"
    pos = {i: k for k, i in enumerate(U)}
    out = sorted(measured - inputs)
    alpha = Fraction(system.alpha_q)
    A: dict[tuple[int, int], Fraction] = {}
    C: list[dict[int, Fraction]] = [{} for _ in out]
    orow = {m: k for k, m in enumerate(out)}
    for (i, j), v in system.cluster_laplacian_entries(cm.name, case.mode).items():
        if j not in pos:
            continue
        if i in pos:
            A[(pos[i], pos[j])] = -alpha * v
        elif i in orow:
            C[orow[i]][pos[j]] = v
    kr = krylov_rank_mod(len(U), A, C, denominators=(alpha, 1 / alpha) if alpha else ())
    if not kr.observable:
        return None
    return (
        f"the observability matrix of (alpha L[U, U], L[M', U]) ({len(U)} unmeasured agents, {len(out)} measured rows, "
        f"{kr.blocks} blocks) has rank {kr.states} modulo the prime {kr.prime}: full column rank for every lambda != 0"
    )


def zero_count_certificate(system: System, case: LocalCase) -> str | None:
    """Prove Proposition III.2 (iii) at every lam != 0 by the modular zero count of the cluster's pencil in s, or return None.

    With s = lam^2 + gamma lam, a kernel vector of the pencil of eq. ``pencil_uio`` at lam != 0
    is [xi; lam xi; u] with (s I + alpha L[P_i, P_i]) xi = S_I^T u and S_M xi = 0 (I the
    suspected and boundary agents, M the agents measured in position or velocity;
    :mod:`glocal_verify.numerics.minors`), i.e. a kernel vector of the Rosenbrock pencil of
    (-alpha L[P_i, P_i], S_I^T, S_M, 0) at s. That pencil has full column rank for every complex
    s iff it is left-invertible and has no finite invariant zero, which
    :func:`~glocal_verify.numerics.zero_count.zero_count_bound_mod_p` proves by squarings-down
    modulo a prime (a bound 0 on the number of zeros and a nonzero det(R_1 P(s))). Unlike the
    maximal minors of :func:`~glocal_verify.analysis.local.cases.minor_certificate` it needs no choice of rows and no limit on the
    unmeasured inputs: it serves observers that measure only their neighbours in clusters of
    hundreds of agents (2 n_c sparse products and O(n_c^2) operations modulo p per case).
    lam = 0 is left to the caller.

    Parameters
    ----------
    system : System
    case : LocalCase

    Returns
    -------
    str or None
        The certificate, one line; None proves nothing.
    """
    from glocal_verify.numerics.zero_count import zero_count_bound_mod_p

    measured, inputs, _ = measured_inputs_unknown(case)
    if not inputs or len(inputs) > len(measured):
        return None
    alpha = Fraction(system.alpha_q)
    A = {k: -alpha * v for k, v in system.cluster_laplacian_entries(case.model.name, case.mode).items()}
    cb = zero_count_bound_mod_p(len(case.model.nodes), A, sorted(inputs), sorted(measured))
    if cb.bound != 0 or not cb.left_invertible:
        return None
    return (
        f"the pencil in s of (-alpha L[P_i, P_i], S_I^T, S_M) ({len(inputs)} inputs, {len(measured)} measured agents) is left-invertible "
        f"with no finite zero: two squarings-down det(R P(s)) have gcd 1 modulo the prime {cb.prime} (leading term of proved order "
        f"{cb.order_at_infinity}): full column rank for every lambda != 0"
    )
