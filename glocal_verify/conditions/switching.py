"""Conditions of Theorem III.3 (``th:Attack_detectability_switching``) and Lemma A.2.

For a safe mode q with dL_q = L_q - L_1, the switching components D_c are the connected
components (>= 2 nodes) of the graph whose edges are the nonzero off-diagonal entries of dL_q
(Definition A.1). The rules live in :mod:`glocal_verify.analysis.switching.image_kernel` ((i), Lemma A.2)
and :mod:`glocal_verify.analysis.switching.eigenstructure` ((ii), (iii)); each checker reports one of
them for every safe mode.
"""

from __future__ import annotations

from glocal_verify.analysis.switching.eigenstructure import distinct_eigenvalues_verdict, eigenvector_differences_verdict
from glocal_verify.analysis.switching.image_kernel import coverage_verdict, image_kernel_verdict
from glocal_verify.conditions.registry import CheckContext, checker, verdict_result
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = [
    "check_coverage",
    "check_distinct_eigenvalues",
    "check_eigenvector_differences",
    "check_image_kernel",
]


@checker("switching.image-kernel")
def check_image_kernel(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3 (i): Im(dL_q) ∩ ker([S_{M_x}; S_{M_v}]) = {0}.

    .. math:: \\operatorname{Im}(\\Delta L_q) \\cap \\ker \\begin{bmatrix} S_{M_x} \\\\ S_{M_v}
              \\end{bmatrix} = \\{0\\} \\iff \\operatorname{rank}(S_M \\Delta L_q)
              = \\operatorname{rank}(\\Delta L_q)

    (the paper writes "= emptyset"; an intersection of subspaces always holds 0). Decided per
    switching component (see :func:`~glocal_verify.analysis.switching.image_kernel.image_kernel_component`). A necessary consequence: a
    component whose block has rank r needs at least r monitored agents.

    Certainty
        Structural where possible (one-signed link changes: a count of monitors), otherwise
        certified singular values with the SVD backward-error bound
        ``beta = 10 max(m, n) eps ||M||_2 + u ||M||_F`` (:func:`~glocal_verify.numerics.subspace.svd_rank_bound`); a singular
        value below beta is never read as zero (undecided instead, with ``error_bound`` = beta).
    Margin
        min over components of sigma_min(S_M Q_c), Q_c an orthonormal basis of Im(dL_c):
        the smallest fraction of a unit vector of Im(dL_q) seen by the monitors, in [0, 1]
        (a relative distance: the condition fails for a perturbation of that relative size);
        0 when the condition fails. Always computed in floating point; robustness only.
    Witness
        Per component: nodes, rank, monitored agents, sigma_min; on failure ``vector``:
        y in Im(dL_q) with S_M y = 0 (labels of D_c; zero elsewhere) and ``monitors_needed``.
    """
    return [verdict_result("switching.image-kernel", ctx, image_kernel_verdict(system, mode, ctx.exact), scope={"mode": mode}) for mode in system.safe_modes]


@checker("switching.distinct-eigenvalues")
def check_distinct_eigenvalues(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3 (ii): L_q has N distinct eigenvalues.

    Numeric (certified): eigenvalues of the symmetric L_q (``eigh``) with the rigorous radius
    ``rho`` of :attr:`Spectrum.error_radius <glocal_verify.numerics.spectrum.Spectrum.error_radius>`
    (Weyl: the i-th exact eigenvalue lies in ``[w_i - rho, w_i + rho]``; ``rho`` holds the
    residual norm, its rounding, the loss of orthonormality and the rounding of L). Holds iff
    every gap ``w_{i+1} - w_i > 2 rho``. A smaller gap proves nothing: the status is undecided
    (``error_bound = 2 rho``; escalation decides exactly), except where structure proves a
    repeated eigenvalue: a disconnected graph (from the exact edge set) has 0 with
    multiplicity = number of components (fails, with the component indicators as witness).
    Before it is undecided, :func:`~glocal_verify.analysis.laplacian.twins.distinct_eigenvalues_modular`
    tries two exact certificates at the cost of a hash per agent and one characteristic
    polynomial modulo a prime: two twin modes with one eigenvalue (fails) or gcd(p, p') = 1
    modulo the prime (holds).
    Exact: the characteristic polynomial p is squarefree, gcd(p, p') = 1 over Q.

    Margin
        The smallest gap between consecutive eigenvalues (floating point, absolute; the
        witness also gives it relative to ``||L_q||_2``), 0 on failure.
    Witness
        On success the closest pair (1-based positions in ascending order and values) and the
        certified radius. On failure: a repeated eigenvalue with its multiplicity and two
        orthogonal eigenvectors (``eigenvectors``, unit, floats of exact vectors when they are
        rational; ``rational_eigenvectors`` exact); exact mode also ``repeated_factor`` =
        gcd(p, p') and, for each rational repeated root, an exact orthogonal basis of its
        eigenspace.
    """
    return [
        verdict_result("switching.distinct-eigenvalues", ctx, distinct_eigenvalues_verdict(system, mode, ctx.exact), scope={"mode": mode})
        for mode in system.safe_modes
    ]


@checker("switching.coverage")
def check_coverage(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma A.2 (``lemma:app_component_measur``): every component D_c meets M.

    .. math:: D_c \\cap M \\neq \\emptyset \\quad \\forall c

    with M = M_x ∪ M_v. Combinatorial, no tolerance. Lemma A.2 claims it follows from
    Theorem III.3 (i); the property tests check that implication.

    Margin
        min over components of |D_c ∩ M| (0 when some component is unmonitored).
    Witness
        Per component its nodes and monitored agents; on failure ``uncovered``.
    """
    return [verdict_result("switching.coverage", ctx, coverage_verdict(system, mode), scope={"mode": mode}) for mode in system.safe_modes]


@checker("switching.eigenvector-differences")
def check_eigenvector_differences(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3 (iii): eigenvectors separate every pair of one switching component.

    .. math:: [U_q]_{i,\\ell} \\neq [U_q]_{j,\\ell} \\quad \\forall \\ell \\neq 1,\\;
              \\forall i \\neq j \\in \\mathcal D_c,\\; \\forall c

    for each safe mode q, with ``U_q`` an orthonormal eigenbasis of L_q (ascending eigenvalues;
    ``l = 1`` is the eigenvalue 0 of a connected graph) and D_c the switching components.

    Only meaningful under (ii). If an eigenvalue is repeated, ``U_q`` is not unique, and the
    condition fails for some admissible ``U_q``: on an eigenspace E of dimension ``k >= 2`` the
    functional ``u -> u(i) - u(j)`` has a kernel of dimension ``>= k - 1 >= 1``; a unit vector of
    that kernel, completed to an orthonormal basis of E (and of R^N), is a diagonalizing
    ``U_q`` with ``u(i) = u(j)``. The checker then reports ``fails`` with that vector.

    Numeric (certified): (ii) first, as in ``switching.distinct-eigenvalues`` (clusters of
    the certified radius rho); a cluster makes the verdict undecided, a disconnected graph
    (exact structure: 0 repeated) makes it fail. For certified simple eigenvalues the exact
    unit eigenvector ``u_l`` (sign-aligned) satisfies ``sin angle(u_hat_l, u_l) <= s_l`` with
    the Davis-Kahan bound ``s_l = ||L u_hat_l - w_l u_hat_l|| / delta_l``
    (:meth:`Spectrum.subspace_sine <glocal_verify.numerics.spectrum.Spectrum.subspace_sine>`;
    ``delta_l`` the certified distance to the other eigenvalues, the residual widened by its
    rounding and the input error), so an entry difference moves by at most
    ``err_l = 2 s_l + 2 eta + 4 eps + 2 epsilon_U`` (``eta`` the loss of orthonormality,
    ``epsilon_U`` the error of a computed entry of a safe mode kept in factored form,
    :attr:`~glocal_verify.numerics.spectrum.Spectrum.entry_error`, 0 otherwise). Holds iff every
    ``|u_l(i) - u_l(j)| > err_l``; a difference below its bound is undecided (never read as
    zero: only exact arithmetic proves an equality), with ``error_bound = err_l``.
    Exact: ``p`` = charpoly(L_q); repeated eigenvalue iff ``gcd(p, p') != 1`` (fails). Otherwise
    with ``q_ij`` from :func:`~glocal_verify.analysis.switching.eigenstructure.eigenvector_difference_polynomial`,
    ``q_ij(mu_l) = p'(mu_l) (u_l(i) - u_l(j))^2`` and ``p'(mu_l) != 0``, so (iii) fails for (i, j)
    iff ``gcd(p(mu) / mu, q_ij) != 1``.

    Before the exact path, and when the numeric bound cannot decide, :func:`~glocal_verify.analysis.laplacian.twins.eigenvector_differences_modular`
    decides exactly by an exact twin mode (fails) or by the two gcds modulo a prime (holds).

    Margin
        ``min |u_l(i) - u_l(j)|`` over ``l != 1`` and the pairs (unit eigenvectors; floating
        point in both modes), 0 on failure.
    Witness
        On failure the pair (i, j), ``l`` (1-based, ascending eigenvalues), the eigenvalue and
        the two entries; exact: also the common factor and ``eigenvalue_exact``, the
        eigenvalue as a rational or as an algebraic number (its minimal polynomial and a
        rational enclosure ``[lo, hi]`` on which it changes sign, isolated by arb ball
        arithmetic: :func:`~glocal_verify.analysis.switching.eigenstructure.algebraic_root_witness`). A repeated eigenvalue: the reason, the
        eigenvalue (or the repeated factor) and an eigenvector with equal entries on the pair.
        On success the closest (pair, l).
    """
    return [
        verdict_result("switching.eigenvector-differences", ctx, eigenvector_differences_verdict(system, mode, ctx.exact), scope={"mode": mode})
        for mode in system.safe_modes
    ]
