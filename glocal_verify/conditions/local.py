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

Scale. (iii) is decided on the structure of the pencil (:mod:`glocal_verify.analysis.cluster_pencil`):
zero forcing from the measured agents (a combinatorial proof), else the n-sized reduced pencil
Q(s) = (s I + alpha L)[R, U], s = lam^2 + gamma lam, whose zeros are lifted to the 2n pencil
and verified there by their backward error; the dense analysis of the 2n pencil is kept for
small clusters (at most :data:`DENSE_MAX_AGENTS` agents) and as the reference of the tests.
The UIO check decides detectability structurally (:func:`glocal_verify.observers.uio_existence.cluster_detectability`,
cross-checking the generic observable split) and designs one observer per distinct cluster
block: the two suspected sets of an observer, and the modes that do not change its cluster,
share it. On clusters of at least
:data:`~glocal_verify.observers.uio_modal.MODAL_MIN_AGENTS` agents (option
``local_uio_method``: ``auto``, ``modal`` or ``dense``) the design and its Hurwitz
certificate come from one symmetric eigenproblem of the interior block L[P_i \\ dP_i, P_i \\ dP_i]
(:mod:`glocal_verify.conditions.local_uio_modal`), shared by every observer of the cluster and
every mode with the same block, instead of 2n-sized Schur forms, eigen-decompositions and SVDs.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
from typing import Any, Mapping, Sequence

import numpy as np

from glocal_verify.analysis.cluster_modal import state_rounding_bound
from glocal_verify.analysis.local_cases import (
    LocalCase,
    _exact_int,
    exact_A_float,
    local_cases,
    pencil_matrices_exact,
)
from glocal_verify.conditions.local_pencil import (
    DENSE_MAX_AGENTS,
    PENCIL_METHODS,
    _num,
    pencil_verdict,
    pencil_verdict_exact,
)
from glocal_verify.conditions.local_uio_modal import UIO_METHODS, modal_applicable, uio_one_modal
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    result,
)
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import ClusterModel, LocalObserver, System
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.pencil_exact import (
    hurwitz_enclosure,
    rank_bounds,
    rounding_error,
)
from glocal_verify.numerics.threads import single_threaded
from glocal_verify.numerics.tolerance import (
    DEFAULT_TOLERANCE,
    Decision,
    Tolerance,
)
from glocal_verify.observers.uio import design_uio
from glocal_verify.observers.uio_existence import (
    UIOExistence,
    cluster_detectability,
    uio_existence,
    uio_existence_exact,
)
from glocal_verify.results import ConditionResult, Finding, Status
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "check_k_connected",
    "check_rank",
    "check_pencil",
    "check_uio",
    "rank_verdict",
    "PENCIL_METHODS",
    "DENSE_MAX_AGENTS",
    "uio_verdict",
    "boundary_attacks_invisible",
    "uio_without_pencil",
]

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
    out = []
    for case in local_cases(system):
        cm, obs = case.model, case.observer
        nb = system.neighbours(obs.center)
        deg = len(nb)
        cut = len(cm.cut_edges)
        rE = len(cm.boundary)
        need = cut + len(case.suspected)
        need_r = rE + len(case.suspected)
        measured = sorted(set(obs.positions) | set(obs.velocities), key=cm.nodes.index)
        witness = {
            "degree": deg,
            "neighbours": nb,
            "inter_cluster_edges": cut,
            "rank_E": rE,
            "suspected": list(case.suspected),
            "required": need,
            "required_with_rank_E": need_r,
            "holds_with_rank_E": deg >= need_r,
            "measured": measured,
        }
        status = Status.HOLDS if deg >= need else Status.FAILS
        out.append(result("local.k-connected", ctx, status, scope=case.scope, margin=deg - need, witness=witness, numeric_decision=False))
    return out


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
    out = []
    for case in local_cases(system):
        status, margin, witness = rank_verdict(case, ctx.tol, ctx.exact)
        out.append(result("local.rank", ctx, status, scope=case.scope, margin=margin, witness=witness, **_certificate_args(witness)))
    return out


def rank_verdict(case: LocalCase, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> tuple[Status, float, dict[str, Any]]:
    """Verdict of (ii) for one case: ``(status, margin, witness)`` (see :func:`check_rank`).

    Parameters
    ----------
    case : LocalCase
    tol : Tolerance
    exact : bool
        Ranks over Q instead of singular values.
    """
    cm = case.model
    C = case.C
    unmeasured = [a for a in cm.boundary if a not in case.observer.velocities]
    CE = C @ cm.E
    if exact:
        rE = ex.rank(_exact_int(cm.E), cm.E.shape[1]) if cm.E.shape[1] else 0
        rCE = ex.rank(_exact_int(CE), CE.shape[1]) if CE.size else 0
        status = Status.HOLDS if rCE == rE else Status.FAILS
    else:
        # certified ranks: Weyl lower bound (SVD backward error; E and C_loc E are exact 0/1
        # matrices, no data rounding) against the structural rank of the exact support
        exact_data = bool(np.all(cm.E == np.round(cm.E)) and np.all(CE == np.round(CE)))
        bE, bCE = rank_bounds(cm.E), rank_bounds(CE)
        rE, rCE = bE.lower, bCE.lower
        bound = max(bE.error_bound, bCE.error_bound)
        cert: dict[str, Any] = {"error_bound": bound, "by": "Weyl bound of the SVD (backward error 8 max(m, n) eps ||M||_F) and the structural rank"}
        if not (exact_data and bE.decided and bCE.decided):
            status = Status.UNDECIDED
            cert["note"] = (
                f"rank(E^i) in [{bE.lower}, {bE.upper}], rank(C_loc E^i) in [{bCE.lower}, {bCE.upper}]: the certified bounds "
                f"(error bound {bound:.3g}) do not meet" + ("" if exact_data else "; C_loc E^i is not an exact 0/1 matrix")
            )
        else:
            status = Status.HOLDS if rCE == rE else Status.FAILS
    sv = np.linalg.svd(CE, compute_uv=False) if CE.size else np.zeros(0)
    margin = 1.0 if rE == 0 else (float(sv[rE - 1]) if len(sv) >= rE else 0.0)
    witness: dict[str, Any] = {"rank_E": rE, "rank_CE": rCE, "boundary": list(cm.boundary)}
    if not exact:
        witness["certificate"] = cert
    if unmeasured:
        witness["unmeasured_boundary"] = unmeasured
    return status, margin, witness


def _certificate_args(witness: Mapping[str, Any]) -> dict[str, Any]:
    """``error_bound`` and ``note`` for :func:`~glocal_verify.conditions.registry.result` from a
    verdict's ``certificate`` witness entry (none in exact mode)."""
    cert = witness.get("certificate")
    if not isinstance(cert, Mapping):
        return {}
    eb = cert.get("error_bound")
    return {"error_bound": None if eb is None else float(eb), "note": str(cert.get("note", ""))}


# --------------------------------------------------------------------------------------------
# (iii)



@checker("local.pencil")
def check_pencil(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition III.2 (iii): the pencil of eq. ``pencil_uio`` has full column rank for every lam.

    .. math::

        P(\\lambda) = \\begin{bmatrix} \\lambda I - A^i & -B^i & E^i \\\\ C_{loc} & 0 & 0
        \\end{bmatrix},\\qquad \\operatorname{rank} P(\\lambda) = 2 N_i + |\\bar F_i| +
        \\operatorname{rank} E^i \\quad \\forall \\lambda \\in \\mathbb C

    i.e. full normal column rank and no finite zero. Numeric: :func:`pencil_verdict` (tolerance
    rule of :func:`glocal_verify.numerics.pencil.analyze_pencil`; every zero verified on the full
    pencil, by an SVD (dense method) or by the backward error of its lifted direction
    (structured method)). Exact: :func:`pencil_verdict_exact` over Q. The method (option
    ``local_pencil_method``: ``auto``, ``structured`` or ``dense``; auto is dense for clusters
    of at most :data:`DENSE_MAX_AGENTS` agents) is recorded in the witness.

    Certification (numeric): a verdict of either method stands only when it is proved for the
    exact pencil (``certificate`` in the witness; see ``_certify`` in
    :mod:`glocal_verify.conditions.local_pencil`): ``holds`` by zero forcing on the exact support
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
            status, margin, witness = pencil_verdict_exact(system, case, method=method)
        else:
            status, margin, witness = pencil_verdict(system, case, ctx.tol, method=method)
        witness = {"mode": case.mode, "suspected_agents": list(case.suspected), **witness}
        out.append(result("local.pencil", ctx, status, scope=case.scope, margin=margin, witness=witness, **_certificate_args(witness)))
    return out


# --------------------------------------------------------------------------------------------
# UIO


def _structured_detectability(cm: ClusterModel, obs: LocalObserver, existence: UIOExistence, tol: Tolerance, w: dict[str, Any]) -> UIOExistence:
    """Cross-check the generic detectability of (C, A_1) with the structured test of
    :func:`glocal_verify.observers.uio_existence.cluster_detectability` (valid under (ii)); an undecided generic
    split is settled by it, a disagreement makes the verdict undecided."""
    if existence.rank_condition is not Status.HOLDS:
        return existence
    idx = {a: k for k, a in enumerate(cm.nodes)}
    sd, p0, how = cluster_detectability(cm.L, [idx[a] for a in cm.boundary], [idx[a] for a in obs.positions], tol)
    w["detectability"] = {"structured": sd.value, "by": how, "generic": existence.detectable.value}
    if sd is existence.detectable or sd is Status.UNDECIDED:
        return existence
    if existence.detectable is Status.UNDECIDED:
        mode = existence.unstable_mode
        if sd is Status.FAILS and p0 is not None:
            mode = (0j, np.concatenate([p0, np.zeros_like(p0)]).astype(complex))
        w["detectability"]["note"] = "the generic observable split was undecided; the structured test decides"
        return dataclasses.replace(existence, status=sd, detectable=sd, unstable_mode=mode)
    w["detectability"]["note"] = "the structured and the generic detectability tests disagree"
    return dataclasses.replace(existence, status=Status.UNDECIDED, detectable=Status.UNDECIDED)


def _uio_key(system: System, cm: ClusterModel, C: np.ndarray, obs: LocalObserver, tol: Tolerance, exact: bool, method: str = "auto") -> str:
    """Digest of everything the per-mode UIO verdict depends on (matrices by value, method).

    A^i = [[0, I], [-alpha L, -gamma I]] is a function of L[P_i, P_i], alpha and gamma, all
    in the key, so it is not hashed again; the digest of L is kept per cluster and mode on
    ``system.analysis`` (hashing the 2n x 2n A^i of every case cost seconds at n = 1333).
    """
    h = hashlib.sha256(method.encode())
    digest = system.analysis.get(("cluster-block-digest", cm.name, cm.mode), lambda: hashlib.sha256(np.ascontiguousarray(cm.L).tobytes()).hexdigest())
    h.update(repr((cm.L.shape, digest)).encode())
    for M in (cm.E, C):
        h.update(repr(M.shape).encode())
        h.update(np.ascontiguousarray(M).tobytes())
    h.update(repr((cm.nodes, cm.boundary, obs.positions, obs.velocities, obs.poles, system.gamma, system.alpha, tol.rtol, tol.band, exact)).encode())
    if exact:
        h.update(repr((system.cluster_laplacian_exact(cm.name, cm.mode), system.alpha_q, system.gamma_q)).encode())
    else:
        # a numeric certificate proves its verdict for every exact A^i within the rounding
        # bound it used of fl(A^i): two modes with the same floats share it only when the
        # bound is the same (then it covers both exact blocks)
        h.update(repr(state_rounding_bound(system, cm.name, cm.mode)).encode())
    return h.hexdigest()


def _uio_one(
    system: System,
    case: LocalCase,
    mode: str,
    tol: Tolerance,
    exact: bool,
    cache: dict[str, tuple[Status, float, dict[str, Any]]] | None = None,
    method: str = "auto",
) -> tuple[Status, float, dict[str, Any]]:
    cm = system.cluster_model(case.model.name, mode)
    obs = case.observer
    C = cm.C(obs.positions, obs.velocities)
    key = _uio_key(system, cm, C, obs, tol, exact, method) if cache is not None else ""
    if cache is not None and key in cache:
        st, mg, w0 = cache[key]
        return st, mg, copy.deepcopy(w0)
    got = uio_one_modal(system, cm, obs, C, mode, tol) if modal_applicable(cm, obs, exact, method) else None
    out = got if got is not None else _uio_one_uncached(system, case, cm, C, mode, tol, exact)
    if not exact and out[0] is not Status.HOLDS:
        out = _uio_certify_negative(case, cm, C, *out)
    if cache is not None:
        cache[key] = (out[0], out[1], copy.deepcopy(out[2]))
    return out


def _uio_certificate(system: System, case: LocalCase, cm: ClusterModel, C: np.ndarray, mode: str, K1: np.ndarray) -> dict[str, Any]:
    """Certify that a UIO exists for the exact cluster model in ``mode`` from a numeric design.

    The UIO exists iff rank(C E) = rank(E) and (C, (I - h C) A) is detectable, h = E (C E)^+.
    C_loc and E^i are exact 0/1 matrices; when C E has orthonormal columns, (C E)^+ = (C E)^T
    and h = E (C E)^T is exact in floating point. The rank condition is certified by
    :func:`~glocal_verify.numerics.pencil_exact.rank_bounds`; detectability by the designed gain
    K1 itself: F_exact = (I - h C) A_exact - K1 C Hurwitz (a certificate that the unobservable
    modes are stable), with ||fl(F) - F_exact||_2 bounded by the rounding of A^i (rational
    differences), the rounding of the products (gamma_n bounds) and of the subtraction, and the
    eigenvalues enclosed by :func:`~glocal_verify.numerics.pencil_exact.hurwitz_enclosure`.
    """
    E = cm.E
    n = E.shape[0]
    CE = C @ E
    out: dict[str, Any] = {"certified": False, "error_bound": None, "by": "rank bounds and Hurwitz enclosure of (I - hC)A - K1 C"}
    exact01 = bool(np.all(C == np.round(C)) and np.all(E == np.round(E)))
    bE, bCE = rank_bounds(E), rank_bounds(CE)
    if not (exact01 and bE.decided and bCE.decided and bE.lower == bCE.lower):
        out["note"] = f"rank condition not certified (rank E in [{bE.lower}, {bE.upper}], rank CE in [{bCE.lower}, {bCE.upper}])"
        return out
    if CE.shape[1] and not np.array_equal(CE.T @ CE, np.eye(CE.shape[1])):
        out["note"] = "C_loc E^i has no orthonormal columns: h = E (C E)^+ is not exact in floating point"
        return out
    h = E @ CE.T if CE.shape[1] else np.zeros((n, C.shape[0]))
    P = np.eye(n) - h @ C
    sub = LocalCase(cm, case.observer, case.kind, case.suspected, mode)
    A_ex, A, support = exact_A_float(system, sub)
    eps = float(np.finfo(float).eps)
    g = n * eps / (1.0 - n * eps)
    A1 = P @ A
    K1C = K1 @ C
    Fm = A1 - K1C
    dA = rounding_error(A, A_ex, support=support)
    delta = float(np.linalg.norm(P, 2)) * dA * (1 + 4 * eps) + g * float(np.linalg.norm(np.abs(P) @ np.abs(A))) + g * float(np.linalg.norm(np.abs(K1) @ np.abs(C)))
    delta = (delta + eps * float(np.linalg.norm(Fm))) * (1.0 + 8 * eps)
    enc = hurwitz_enclosure(Fm, delta)
    out["error_bound"] = enc.radius
    out["spectral_abscissa_upper"] = enc.max_real_upper
    if enc.certified is True:
        out["certified"] = True
    else:
        out["note"] = (
            f"F = (I - hC)A - K1 C is not certified Hurwitz: max Re + enclosure radius = {enc.max_real_upper:.3g} "
            f"(radius {enc.radius:.3g}, ||fl F - F_exact|| <= {delta:.3g})"
        )
    return out


def _uio_certify_negative(case: LocalCase, cm: ClusterModel, C: np.ndarray, st: Status, mg: float, w: dict[str, Any]) -> tuple[Status, float, dict[str, Any]]:
    """A numeric ``fails`` of local.uio is certified only through the rank condition (exact 0/1
    matrices, :func:`~glocal_verify.numerics.pencil_exact.rank_bounds`); an unstable unobservable
    mode is a rank-loss claim that floating point cannot prove: undecided."""
    bE, bCE = rank_bounds(cm.E), rank_bounds(C @ cm.E)
    cert: dict[str, Any] = {"certified": False, "error_bound": max(bE.error_bound, bCE.error_bound)}
    if bE.decided and bCE.decided and bCE.lower < bE.lower:
        cert.update(certified=True, by="certified rank bounds: rank(C E) < rank(E)")
        w["certificate"] = cert
        return Status.FAILS, mg, w
    if st is Status.FAILS:
        cert["note"] = "the rank condition holds; an unstable unobservable mode (a rank loss of the PBH pencil) has no floating-point proof"
    else:
        cert["note"] = "existence or the numeric design could not be decided"
    w.setdefault("certificate", cert)
    return Status.UNDECIDED, mg, w


@single_threaded
def _uio_one_uncached(system: System, case: LocalCase, cm: ClusterModel, C: np.ndarray, mode: str, tol: Tolerance, exact: bool) -> tuple[Status, float, dict[str, Any]]:
    obs = case.observer
    w: dict[str, Any] = {}
    exact_status: Status | None = None
    if exact:
        sub = LocalCase(cm, obs, case.kind, case.suspected, mode)
        A, _, Cq = pencil_matrices_exact(system, sub)
        ee = uio_existence_exact(A, _exact_int(cm.E), Cq)
        w["rank_condition"] = ee.rank_condition.value
        if ee.unobservable_dim >= 0:
            w["unobservable_dim"] = ee.unobservable_dim
            w["unobservable_charpoly"] = [str(c) for c in ee.unobservable_charpoly]
        if ee.status is Status.FAILS:
            if ee.rank_condition is Status.FAILS:
                w["unmeasured_boundary"] = [a for a in cm.boundary if a not in obs.velocities]
            else:
                roots = np.roots([float(c) for c in reversed(ee.unobservable_charpoly)])
                w["unstable_unobservable_modes"] = [_num(r, 9) for r in roots if r.real >= -1e-9]
        exact_status = ee.status
    existence = _structured_detectability(cm, obs, uio_existence(cm.A, cm.E, C, tol), tol, w)
    if exact_status is Status.FAILS or existence.status is not Status.HOLDS:
        if existence.rank_condition is Status.FAILS:
            w["unmeasured_boundary"] = [a for a in cm.boundary if a not in obs.velocities]
        if existence.unstable_mode is not None:
            lam, vec = existence.unstable_mode
            n = len(cm.nodes)
            vec = vec / vec[int(np.argmax(np.abs(vec)))]
            # full double precision; only exact zeros are left out
            w["unstable_unobservable_mode"] = {
                "eigenvalue": _num(lam, 9),
                "positions": {a: (complex(c).real if complex(c).imag == 0 else complex(c)) for a, c in zip(cm.nodes, vec[:n]) if c != 0},
                "velocities": {a: (complex(c).real if complex(c).imag == 0 else complex(c)) for a, c in zip(cm.nodes, vec[n:]) if c != 0},
            }
        w["unobservable_eigenvalues"] = [_num(m, 9) for m in existence.unobservable_eigenvalues]
        st = existence.status if exact_status is None else exact_status
        if st is Status.HOLDS:  # exact existence, numeric split undecided: design below
            pass
        else:
            margin = float(existence.margin) if math.isfinite(existence.margin) else 0.0
            return st, margin, w
    poles = None if obs.poles is None else [float(p) for p in obs.poles]
    try:
        _, d = design_uio(cm.A, cm.E, C, poles=poles, gamma=system.gamma, tol=tol, existence=existence if existence.status is Status.HOLDS else None)
    except Exception as exc:  # noqa: BLE001 - a design failure is a verdict, with its reason
        w["design_error"] = str(exc)
        return (Status.HOLDS if exact else Status.UNDECIDED), float(existence.margin), w
    checks = {
        "decoupling": tol.decide(d["decoupling_residual"], 1.0),
        "error_free_of_state": tol.decide(d["error_residual"], 1.0),
    }
    hurwitz_ok = d["hurwitz"] is Status.HOLDS
    w.update(
        {
            "observable_dim": int(existence.split.Qo.shape[1]) if existence.split else 0,
            "unobservable_eigenvalues": [_num(m, 9) for m in existence.unobservable_eigenvalues],
            "poles": [_num(p, 9) for p in d["poles"]],
            "eigenvalues_F": [_num(p, 9) for p in sorted(d["eigenvalues"], key=lambda z: (z.real, z.imag))],
            "hurwitz_margin": d["hurwitz_margin"],
            "hurwitz_certificate": {"status": d["hurwitz"].value, "ratio": d["hurwitz_ratio"]},
            "decoupling_residual": d["decoupling_residual"],
            "error_residual": d["error_residual"],
        }
    )
    if d["notes"]:
        w["notes"] = list(d["notes"])
    design_ok = checks["decoupling"] is Decision.ZERO and checks["error_free_of_state"] is Decision.ZERO and hurwitz_ok
    if design_ok:
        if not exact:
            w["certificate"] = _uio_certificate(system, case, cm, C, mode, d["K1"])
            if not w["certificate"]["certified"]:
                return Status.UNDECIDED, float(d["hurwitz_margin"]), w
        return Status.HOLDS, float(d["hurwitz_margin"]), w
    w["verification_failed"] = [k for k, v in checks.items() if v is not Decision.ZERO] + ([] if hurwitz_ok else ["hurwitz"])
    # the observer exists (decided above); the numeric design did not verify
    return (Status.HOLDS if exact else Status.UNDECIDED), float(d["hurwitz_margin"]), w


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
    :func:`uio_verdict`). Exact mode decides existence over Q (rank condition, Routh
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
    out = []
    cache: dict[str, tuple[Status, float, dict[str, Any]]] = {}
    method = str(ctx.options.get("local_uio_method", "auto"))
    if method not in UIO_METHODS:
        raise NotApplicableError(f"local_uio_method must be one of {', '.join(UIO_METHODS)}, not {method!r}")
    for case in local_cases(system):
        status, margin, witness = uio_verdict(system, case, ctx.tol, ctx.exact, cache=cache, method=method)
        out.append(result("local.uio", ctx, status, scope=case.scope, margin=margin, witness=witness, **_certificate_args(witness)))
    return out


def uio_verdict(
    system: System,
    case: LocalCase,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact: bool = False,
    *,
    cache: dict[str, tuple[Status, float, dict[str, Any]]] | None = None,
    method: str = "auto",
) -> tuple[Status, float, dict[str, Any]]:
    """Verdict of local.uio for one case over every mode: ``(status, margin, witness)``.

    Parameters
    ----------
    system : System
    case : LocalCase
    tol : Tolerance
    exact : bool
        Decide existence over Q (the design stays numeric).
    cache : dict, optional
        Per-mode results keyed by a digest of everything they depend on (cluster matrices
        A^i, E^i, L[P_i, P_i] and C_loc by value, observer, gains, tolerance, exactness):
        the suspected sets of one observer, and the modes that leave the cluster block
        unchanged (a safe mode usually changes one cluster), share one design.
    method : str
        ``auto`` (default: the modal design and certificate of
        :mod:`glocal_verify.conditions.local_uio_modal` for numeric checks of clusters of at least
        :data:`~glocal_verify.conditions.local_uio_modal.MODAL_MIN_AGENTS` agents with default
        poles, the dense one otherwise), ``modal`` (whenever it applies) or ``dense``.
    """
    per_mode: dict[str, Any] = {}
    statuses = []
    margins = []
    for mode in system.modes:
        st, mg, w = _uio_one(system, case, mode, tol, exact, cache, method)
        if "eigenvalues_F" in w:
            bnd = set(system.cluster_model(case.model.name, mode).boundary) if mode != case.mode else set(case.model.boundary)
            inv = [a for a in case.suspected if a in bnd]
            if inv:
                w["attack_invisible"] = inv
        per_mode[mode] = {"status": st.value, **w}
        statuses.append(st)
        margins.append(mg)
    if any(s is Status.FAILS for s in statuses):
        status = Status.FAILS
    elif any(s is Status.UNDECIDED for s in statuses):
        status = Status.UNDECIDED
    else:
        status = Status.HOLDS
    witness: dict[str, Any] = {"normal": per_mode[NORMAL_MODE]}
    if len(system.modes) > 1:
        witness["modes"] = {m: v for m, v in per_mode.items() if m != NORMAL_MODE}
        bad = [m for m, s in zip(system.modes, statuses) if s is not Status.HOLDS]
        if bad:
            witness["failing_modes"] = bad
    margin = min(margins) if margins else math.inf
    if not exact:
        certs = [(m, v["certificate"]) for m, v in per_mode.items() if isinstance(v.get("certificate"), dict)]
        bounds = [c["error_bound"] for _, c in certs if c.get("error_bound") is not None]
        notes = [f"{m}: {c['note']}" for m, c in certs if c.get("note")]
        witness["certificate"] = {"error_bound": max(bounds) if bounds else None, "note": "; ".join(notes) if status is Status.UNDECIDED else ""}
    return status, margin, witness


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
