"""Cluster-level conditions of Proposition III.2 (``prop:attack_detectability_local``).

For every cluster P_i and every local observer (centre c, measured sets resolved by
:meth:`~glocal_verify.model.System.observers`) the checkers below evaluate, in the normal mode
(the mode in which Algorithm 1 runs the local detectors), the cluster model of eq.
``cluster_dyn2`` as ``docs/conditions.md`` defines it:

.. math::

    A^i = \\begin{bmatrix} 0 & I \\\\ -\\alpha L[P_i, P_i] & -\\gamma I \\end{bmatrix},\\quad
    E^i = \\begin{bmatrix} 0 \\\\ S_{\\partial P_i}^\\top \\end{bmatrix},\\quad
    B^i = \\begin{bmatrix} 0 \\\\ S_{\\bar F_i}^\\top \\end{bmatrix},\\quad
    C_{loc} = \\operatorname{blkdiag}(S_{pos}, S_{vel}).

Each condition is reported for two suspected sets (scope key ``suspected``):

* ``"attack"`` -- the spec's attacked actuators inside the cluster (present whenever the spec
  has an attack, even if none of its actuators is in the cluster);
* ``"all"`` -- Remark III.2.1's worst case, every agent of the cluster.

An agent both suspected and on the boundary gives [-B^i, E^i] two opposite columns: the pencil
of (iii) loses rank at every lam, and the attack on that agent enters the UIO error through
T B e_k = 0, i.e. not at all. With the worst case this happens whenever the cluster has a
boundary agent; the witnesses name the agent and a finding says so.

Scale. (iii) is decided on the structure of the pencil (:mod:`glocal_verify.analysis.local.cluster_pencil`):
zero forcing from the measured agents (a combinatorial proof), else the n-sized reduced pencil
Q(s) = (s I + alpha L)[R, U], s = lam^2 + gamma lam, whose zeros are lifted to the 2n pencil
and verified there by their backward error; the dense analysis of the 2n pencil is kept for
small clusters (at most ``dense_max_agents`` (:mod:`glocal_verify.config`) agents) and as the reference of the tests.
The UIO check decides detectability structurally (:func:`glocal_verify.observers.uio_existence.cluster_detectability`,
cross-checking the generic observable split) and designs one observer per distinct cluster
block: the two suspected sets of an observer, and the modes that do not change its cluster,
share it. On clusters of at least
``modal_min_agents`` (:mod:`glocal_verify.config`) agents (option
``local_uio_method``: ``auto``, ``modal`` or ``dense``) the design and its Hurwitz
certificate come from one symmetric eigenproblem of the interior block L[P_i \\ dP_i, P_i \\ dP_i]
(:mod:`glocal_verify.observers.uio_modal_verdict`), shared by every observer of the cluster and
every mode with the same block, instead of 2n-sized Schur forms, eigen-decompositions and SVDs.

The rules live in :mod:`glocal_verify.analysis.local.structure` ((i), (ii)),
:mod:`glocal_verify.analysis.local.pencil` ((iii)) and :mod:`glocal_verify.observers.uio_verdict`
(the UIO, which designs the observer it certifies); the checkers below report them per case.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

from glocal_verify.analysis.local.cases import local_cases
from glocal_verify.analysis.local.pencil import pencil_verdict, pencil_verdict_exact
from glocal_verify.analysis.local.structure import k_connected_verdict, rank_verdict
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    verdict_result,
)
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.observers.uio_modal_verdict import UIO_METHODS
from glocal_verify.observers.uio_verdict import uio_verdict
from glocal_verify.results import ConditionResult, Finding, Status, Verdict

__all__ = [
    "check_k_connected",
    "check_rank",
    "check_pencil",
    "check_uio",
    "boundary_attacks_invisible",
    "uio_without_pencil",
]

#: the suspected sets of every local case (scope key ``suspected``)
SUSPECTED_KINDS = ("attack", "all")


# --------------------------------------------------------------------------------------------
# (i)


@checker("local.k-connected")
def check_k_connected(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition III.2 (i): the observer centre is k-connected with k >= |E_cut| + |F_i|.

    .. math:: \\deg(c) \\ge |\\mathcal E_{cut}(P_i)| + |\\bar F_i \\cap P_i|

    deg(c) counts the neighbours of the centre in the normal-mode graph (the whole graph:
    the paper's |N_i| = k). The paper counts inter-cluster edges; several cut edges at one
    boundary agent share one column of E^i, so the witness also gives the count with
    rank(E^i) = |dP_i| in place of the edge count (``holds_with_rank_E``). Combinatorial: no
    tolerance; numeric and exact agree by construction.

    Margin
        deg(c) - (|E_cut| + |suspected|) (negative when the condition fails).
    Witness
        ``degree``, ``neighbours``, ``inter_cluster_edges``, ``rank_E``, ``suspected``,
        ``required`` (the paper's count), ``required_with_rank_E``, ``holds_with_rank_E`` and
        ``measured`` (agents the observer measures).
    """
    return [verdict_result("local.k-connected", ctx, k_connected_verdict(system, case), scope=case.scope) for case in local_cases(system)]


# --------------------------------------------------------------------------------------------
# (ii)


@checker("local.rank")
def check_rank(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition III.2 (ii): rank(C_loc E^i) = rank(E^i).

    .. math:: \\operatorname{rank}(C_{loc} E^i) = \\operatorname{rank}(E^i)

    E^i has one unit column per boundary agent on its velocity row, so (ii) holds exactly
    when the velocity of every boundary agent is measured. Numeric: certified ranks
    (:func:`~glocal_verify.numerics.pencil_exact.rank_bounds`): a singular value counts as
    nonzero when it exceeds the SVD backward error 8 max(m, n) eps ||M||_F (E^i and C_loc E^i
    are exact 0/1 matrices, so there is no data rounding), and the rank is bounded above by
    the structural rank of the exact support; the verdict is undecided unless both bounds
    meet for both matrices (``certificate`` in the witness, ``error_bound`` in the result).
    Exact: ranks over Q.
    (ii) does not involve the suspected set; it is reported in every scope.

    Margin
        The rank(E^i)-th singular value of C_loc E^i relative to ||E^i||_2 (1 when it holds,
        0 when it fails; 1 when the cluster has no boundary agent).
    Witness
        ``rank_E``, ``rank_CE``, ``boundary`` and, on failure, ``unmeasured_boundary``: the
        boundary agents whose velocity the observer does not measure.
    """
    return [verdict_result("local.rank", ctx, rank_verdict(case, ctx.tol, ctx.exact), scope=case.scope) for case in local_cases(system)]


# --------------------------------------------------------------------------------------------
# (iii)


@checker("local.pencil")
def check_pencil(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition III.2 (iii): the pencil of eq. ``pencil_uio`` has full column rank for every lam.

    .. math::

        P(\\lambda) = \\begin{bmatrix} \\lambda I - A^i & -B^i & E^i \\\\ C_{loc} & 0 & 0
        \\end{bmatrix},\\qquad \\operatorname{rank} P(\\lambda) = 2 N_i + |\\bar F_i| +
        \\operatorname{rank} E^i \\quad \\forall \\lambda \\in \\mathbb C

    i.e. full normal column rank and no finite zero. Numeric: :func:`~glocal_verify.analysis.local.pencil.pencil_verdict` (tolerance
    rule of :func:`glocal_verify.numerics.pencil.analyze_pencil`; every zero verified on the full
    pencil, by an SVD (dense method) or by the backward error of its lifted direction
    (structured method)). Exact: :func:`~glocal_verify.analysis.local.pencil.pencil_verdict_exact` over Q. The method (option
    ``local_pencil_method``: ``auto``, ``structured`` or ``dense``; auto is dense for clusters
    of at most ``dense_max_agents`` (:mod:`glocal_verify.config`) agents) is recorded in the witness.

    Certification (numeric): a verdict of either method stands only when it is proved for the
    exact pencil (``certificate`` in the witness; see
    :func:`~glocal_verify.analysis.local.cases.certify_pencil_verdict`): ``holds`` by zero forcing on the exact support
    (and lam = 0 by a Weyl bound sigma_min(P(0)) > ||fl P(0) - P(0)||_2 + 8 max(m, n) eps
    ||P(0)||_F when only lam != 0 is forced), ``fails`` combinatorially (suspected boundary
    agent) or by the structural rank of the exact support (generically, or at lam in {0,
    -gamma}). A zero verified by a small backward error, or the absence of zeros found by
    QZ, is not a proof: ``undecided`` with ``error_bound`` and ``note``, escalated by
    ``verify``. The margin below is robustness (a relative distance), not the decision.

    Margin
        (holds) dense: the smallest singular value of P(lam) relative to its largest over the
        sample points lam in {0, 1, i, -gamma/2 + 0.7 i, lambda0}; structured: the same
        quantity for the reduced pencil Q(lam^2 + gamma lam). An upper-bound-like scale of the
        distance to failure, not a certificate; 0 on failure.
    Witness
        On a structural failure ``suspected_and_boundary`` and a direction; on normal-rank
        deficiency a direction at lambda0 (or 0.5); on finite zeros each zero with its
        direction (``positions``, ``velocities``, ``attack_input``, ``coupling_input``,
        ``moves``), growth class, ``residual`` ||P v|| / (||P|| ||v||) and, dense, ``sigma_min``;
        structured: ``zero_forcing`` and the ``reduced`` pencil's sizes.
    """
    method = str(ctx.options.get("local_pencil_method", "auto"))
    out = []
    for case in local_cases(system):
        if ctx.exact:
            v = pencil_verdict_exact(system, case, method=method)
        else:
            v = pencil_verdict(system, case, ctx.tol, method=method)
        out.append(verdict_result("local.pencil", ctx, _with_case(v, case.mode, case.suspected), scope=case.scope))
    return out


def _with_case(v: Verdict, mode: str, suspected: Sequence[object]) -> Verdict:
    """The verdict with its case (mode, suspected agents) first in the witness."""
    return dataclasses.replace(v, witness={"mode": mode, "suspected_agents": list(suspected), **v.witness})


# --------------------------------------------------------------------------------------------
# UIO


@checker("local.uio")
def check_uio(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Existence, design and verification of the unknown-input observer (Chen, Patton & Zhang 1996).

    .. math::

        \\operatorname{rank}(C E) = \\operatorname{rank}(E),\\quad (C, A_1)\\ \\text{detectable},
        \\quad A_1 = (I - hC) A,\\ h = E (CE)^{+}

    The design (:func:`glocal_verify.observers.uio.design_uio`, eqs. ``uio_conds_1``-``uio_conds_3``)
    places the observable poles of (A_1, C) (the observer's ``poles`` or the defaults of
    :func:`glocal_verify.observers.uio_existence.default_poles`) and is verified: ||(h C - I) E||_F / ||E||_F and
    ||T A - F T - K C||_F / (||A||_F + ||F||_F) must be zero at ``rtol`` (the error equation of
    eq. ``obs_decent_error`` is then free of the neighbour states) and F must be Hurwitz with
    certified Hurwitz by :func:`glocal_verify.observers.uio_existence.hurwitz_certificate` (every eigenvalue at
    least ``band`` times its uncertainty rtol ||F||_2 kappa_i left of the axis). The paper asks F Hurwitz in every mode, so the
    observer is designed and verified for the normal mode and every safe mode (F_q per mode);
    the verdict holds only if all do. Detectability is decided twice: by the generic observable
    split of (A_1, C) and by the structured PBH test of
    :func:`glocal_verify.observers.uio_existence.cluster_detectability` (only lam = 0 can be an unstable unobservable
    mode of the cluster model; zero forcing or one n-sized SVD); an undecided split is settled
    by the structured test, a disagreement is undecided (witness ``detectability``). One design
    per distinct cluster block is made and shared (suspected sets, unchanged modes; see
    :func:`~glocal_verify.observers.uio_verdict.uio_verdict`). Exact mode decides existence over Q (rank condition, Routh
    test of the unobservable part's characteristic polynomial); the design stays numeric.
    Existence does not involve B^i; the suspected set only adds ``attack_invisible``: suspected
    boundary agents, whose attack the observer cancels together with the coupling (T B e_k = 0).

    Certification (numeric): ``holds`` needs, per mode, the rank condition certified by
    Weyl/structural rank bounds and F_exact = (I - h C) A_exact - K1 C certified Hurwitz for
    the designed K1 (an eigenvalue enclosure from the residual of the computed
    eigen-decomposition, Bauer-Fike, including ||fl F - F_exact||_2 from the rational data:
    ``_uio_certificate``; on large clusters the modal certificate of
    :func:`glocal_verify.observers.uio_modal.modal_certificate`: a residual bound of F_exact in
    the modal basis of the interior block, a lower bound of the basis' smallest singular value
    and a resolvent bound of the block triangular modal form, perturbation times resolvent
    below 1); this proves detectability of the exact pair. ``fails`` is certified
    only through the rank condition; an unstable unobservable mode is a rank-loss claim
    without a floating-point proof (``undecided``, escalated by ``verify``). The margin stays a
    robustness measure.

    Margin
        min over modes of -max Re eig(F_q) (negative: the most unstable unobservable mode).
    Witness
        Per mode: poles, eigenvalues of F, residuals, unobservable eigenvalues; on failure the
        unmeasured boundary agents or the unstable unobservable mode (eigenvalue and vector).
    """
    cache: dict[str, Verdict] = {}
    method = str(ctx.options.get("local_uio_method", "auto"))
    if method not in UIO_METHODS:
        raise NotApplicableError(f"local_uio_method must be one of {', '.join(UIO_METHODS)}, not {method!r}")
    return [
        verdict_result("local.uio", ctx, uio_verdict(system, case, ctx.tol, ctx.exact, cache=cache, method=method), scope=case.scope)
        for case in local_cases(system)
    ]


# --------------------------------------------------------------------------------------------
# findings


@finding_rule
def boundary_attacks_invisible(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Remark III.2.1's worst case B^i = I fails (iii) structurally at every boundary agent."""
    hits = [r for r in results if r.id == "local.pencil" and r.witness.get("structural")]
    if not hits:
        return []
    data = [{**dict(r.scope), "agents": r.witness["suspected_and_boundary"]} for r in hits]
    worst = [d for d in data if d["suspected"] == "all"]
    return [
        Finding(
            "local.boundary-attack-invisible",
            "A suspected boundary agent makes Proposition III.2 (iii) fail at every lam; Remark III.2.1's B^i = I is unusable",
            "An agent with an inter-cluster edge that is also suspected gives [-B^i, E^i] two opposite columns: the "
            "pencil of eq. pencil_uio loses rank for every lam, and in the UIO the attack enters through T B e_k = 0, "
            "i.e. it is cancelled with the neighbour coupling and no local residual can see it. Remark III.2.1 proposes "
            "replacing B^i by the identity (all agents suspected); this fails whenever the cluster has a boundary agent"
            + (f" (here in {len(worst)} worst-case scope(s))" if worst else "")
            + ". Only the interior agents P_i \\ dP_i can be protected by a local UIO.",
            "Proposition III.2 (iii), Remark III.2.1",
            {"cases": data},
        )
    ]



@finding_rule
def uio_without_pencil(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Remark III.2.1 calls (i)-(iii) equivalent to the UIO existence conditions; (iii) involves B^i, UIO existence does not."""
    pen = {tuple(sorted(r.scope.items(), key=str)): r for r in results if r.id == "local.pencil"}
    cases = []
    for r in results:
        if r.id != "local.uio" or r.status is not Status.HOLDS:
            continue
        p = pen.get(tuple(sorted(r.scope.items(), key=str)))
        if p is not None and p.status is Status.FAILS:
            cases.append(dict(r.scope))
    if not cases:
        return []
    return [
        Finding(
            "local.uio-without-detection",
            "A UIO exists while Proposition III.2 (iii) fails: (i)-(iii) are not equivalent to UIO existence",
            "Remark III.2.1 states that conditions (i)-(iii) are equivalent to the necessary and sufficient conditions "
            "for the existence of the UIO (Chen, Patton & Zhang 1996). UIO existence depends on (A^i, E^i, C) only; "
            "(iii) also involves B^i. In these scopes the UIO exists and is verified, yet the pencil loses rank: the "
            "observer runs but a stealthy attack on the suspected agents stays invisible in its residual.",
            "Remark III.2.1, Proposition III.2",
            {"scopes": cases},
        )
    ]

