"""Cluster-level conditions of Proposition III.2 (``prop:attack_detectability_local``).

For every cluster P_i and every local observer (centre c, measured sets resolved by
:meth:`~glocal_verify.model.System.observers`) the checkers below evaluate, in the normal mode
(the mode in which Algorithm 1 runs the local detectors), the cluster model of eq.
``cluster_dyn2`` as ``CONDITIONS.md`` defines it:

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import numpy as np

from . import exact as ex
from .linalg import DEFAULT_TOLERANCE, Decision, Tolerance, numeric_rank
from .model import ClusterModel, LocalObserver, System
from .registry import CheckContext, checker, finding_rule, result
from .results import ConditionResult, Finding, Status
from .spec import NORMAL_MODE, Label
from .uio import design_uio, uio_existence, uio_existence_exact

__all__ = [
    "LocalCase",
    "local_cases",
    "cluster_summary",
    "pencil_matrices",
    "pencil_matrices_exact",
    "full_pencil",
    "check_k_connected",
    "check_rank",
    "check_pencil",
    "check_uio",
    "rank_verdict",
    "pencil_verdict",
    "uio_verdict",
    "boundary_attacks_invisible",
    "uio_without_pencil",
]

SUSPECTED_KINDS = ("attack", "all")


# --------------------------------------------------------------------------------------------
# cases


@dataclass(frozen=True, slots=True)
class LocalCase:
    """One (cluster, observer, suspected set) combination.

    Attributes
    ----------
    model : ClusterModel
        Cluster matrices in ``mode``.
    observer : LocalObserver
        Centre and resolved measured sets.
    kind : str
        ``"attack"`` or ``"all"`` (the scope's ``suspected`` value).
    suspected : tuple of labels
        Suspected agents inside the cluster, in cluster order.
    mode : str
        Mode of the cluster model (the normal mode for the checkers).
    """

    model: ClusterModel
    observer: LocalObserver
    kind: str
    suspected: tuple[Label, ...]
    mode: str = NORMAL_MODE

    @property
    def scope(self) -> dict[str, Any]:
        return {"cluster": self.model.name, "observer": self.observer.center, "suspected": self.kind}

    @property
    def structural(self) -> tuple[Label, ...]:
        """Agents both suspected and on the boundary (each makes (iii) fail at every lam)."""
        b = set(self.model.boundary)
        return tuple(a for a in self.suspected if a in b)

    @property
    def C(self) -> np.ndarray:
        return self.model.C(self.observer.positions, self.observer.velocities)

    @property
    def B(self) -> np.ndarray:
        return self.model.B(self.suspected)


def local_cases(system: System, mode: str = NORMAL_MODE, cluster: str | None = None) -> list[LocalCase]:
    """All (cluster, observer, suspected) cases of ``system`` in ``mode``.

    Parameters
    ----------
    system : System
    mode : str
        Mode of the cluster models.
    cluster : str, optional
        Restrict to one cluster.
    """
    attacked = set(system.attacked)
    out = []
    for c in system.clusters:
        if cluster is not None and c.name != cluster:
            continue
        cm = system.cluster_model(c.name, mode)
        for obs in system.observers(c.name):
            if system.spec.attack is not None:
                out.append(LocalCase(cm, obs, "attack", tuple(a for a in cm.nodes if a in attacked), mode))
            out.append(LocalCase(cm, obs, "all", tuple(cm.nodes), mode))
    return out


def cluster_summary(system: System, name: str, mode: str = NORMAL_MODE) -> dict[str, Any]:
    """Decomposition facts of one cluster: agents, boundary, cut edges, their count and rank(E^i).

    Parameters
    ----------
    system : System
    name : str
        Cluster name.
    mode : str
        Mode of the cluster model.
    """
    cm = system.cluster_model(name, mode)
    return {
        "nodes": list(cm.nodes),
        "boundary": list(cm.boundary),
        "cut_edges": [[u, v, w] for u, v, w in cm.cut_edges],
        "inter_cluster_edges": len(cm.cut_edges),
        "rank_E": int(cm.E.shape[1]),
    }


def pencil_matrices(case: LocalCase) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A^i, G, C_loc) with G = [B^i, -E^i]: the local pencil of eq. ``pencil_uio``,
    [[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]], is the Rosenbrock pencil of (A^i, G, C_loc, 0)."""
    return case.model.A, np.hstack([case.B, -case.model.E]), case.C


def full_pencil(case: LocalCase, lam: complex) -> np.ndarray:
    """The matrix [[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]] of eq. ``pencil_uio`` at ``lam``.

    Parameters
    ----------
    case : LocalCase
    lam : complex
    """
    A, G, C = pencil_matrices(case)
    n, m = A.shape[0], G.shape[1]
    P = np.zeros((n + C.shape[0], n + m), dtype=complex)
    P[:n, :n] = lam * np.eye(n) - A
    P[:n, n:] = -G
    P[n:, :n] = C
    return P


def _exact_A(system: System, case: LocalCase) -> list[list[Fraction]]:
    L = system.cluster_laplacian_exact(case.model.name, case.mode)
    n = len(L)
    A = [[Fraction(0)] * (2 * n) for _ in range(2 * n)]
    for i in range(n):
        A[i][n + i] = Fraction(1)
        A[n + i][n + i] = -system.gamma_q
        for j in range(n):
            A[n + i][j] = -system.alpha_q * L[i][j]
    return A


def _exact_int(M: np.ndarray) -> list[list[Fraction]]:
    return [[Fraction(int(round(float(x)))) for x in row] for row in M]


def pencil_matrices_exact(system: System, case: LocalCase) -> tuple[list[list[Fraction]], list[list[Fraction]], list[list[Fraction]]]:
    """(A^i, G, C_loc) with rational entries (weights and gains exactly as the spec gives them).

    Parameters
    ----------
    system : System
    case : LocalCase
    """
    A = _exact_A(system, case)
    _, G, C = pencil_matrices(case)
    return A, _exact_int(G), _exact_int(C)


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
    when the velocity of every boundary agent is measured. Numeric: ranks by
    :func:`~glocal_verify.linalg.numeric_rank` (singular values of C_loc E^i relative to
    ||E^i||_2 = 1; zero below ``rtol``, nonzero above ``rtol * band``). Exact: ranks over Q.
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
        out.append(result("local.rank", ctx, status, scope=case.scope, margin=margin, witness=witness))
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
        iE = numeric_rank(cm.E, tol)
        iCE = numeric_rank(CE, tol, scale=iE.scale if iE.scale > 0 else 1.0)
        rE, rCE = iE.rank, iCE.rank
        if not (iE.decided and iCE.decided):
            status = Status.UNDECIDED
        else:
            status = Status.HOLDS if rCE == rE else Status.FAILS
    sv = np.linalg.svd(CE, compute_uv=False) if CE.size else np.zeros(0)
    margin = 1.0 if rE == 0 else (float(sv[rE - 1]) if len(sv) >= rE else 0.0)
    witness: dict[str, Any] = {"rank_E": rE, "rank_CE": rCE, "boundary": list(cm.boundary)}
    if unmeasured:
        witness["unmeasured_boundary"] = unmeasured
    return status, margin, witness


# --------------------------------------------------------------------------------------------
# (iii)


def _moves(xi: np.ndarray, nodes: Sequence[Label]) -> list[Label]:
    m = float(np.max(np.abs(xi))) if xi.size else 0.0
    if m == 0.0:
        return []
    return [a for a, v in zip(nodes, xi) if abs(v) > 1e-6 * m]


def _num(z: complex, digits: int = 12) -> complex | float:
    z = complex(z)
    re, im = round(z.real, digits), round(z.imag, digits)
    return re if im == 0.0 else complex(re, im)


def _direction_witness(case: LocalCase, lam: complex, x: np.ndarray, u: np.ndarray) -> dict[str, Any]:
    """A zero direction in user labels, normalised (largest entry 1), verified on the full pencil."""
    nodes = case.model.nodes
    n = len(nodes)
    v = np.concatenate([np.asarray(x, dtype=complex), np.asarray(u, dtype=complex)])
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) > 0:
        v = v / v[k]
    P = full_pencil(case, lam)
    res = float(np.linalg.norm(P @ v)) / max(float(np.linalg.norm(P, 2)) * float(np.linalg.norm(v)), 1e-300)
    xv, uv = v[: 2 * n], v[2 * n :]
    mb = len(case.suspected)
    # full pencil columns: [x, u_B, u_E] with -B^i u_B + E^i u_E; G = [B, -E] gives the same
    return {
        "lambda": _num(lam),
        "positions": {a: _num(c, 9) for a, c in zip(nodes, xv[:n]) if abs(c) > 1e-12},
        "velocities": {a: _num(c, 9) for a, c in zip(nodes, xv[n:]) if abs(c) > 1e-12},
        "attack_input": {a: _num(c, 9) for a, c in zip(case.suspected, uv[:mb]) if abs(c) > 1e-12},
        "coupling_input": {a: _num(c, 9) for a, c in zip(case.model.boundary, uv[mb:]) if abs(c) > 1e-12},
        "moves": _moves(xv[:n] if np.any(np.abs(xv[:n]) > 0) else xv[n:], nodes),
        "residual": res,
    }


def _structural_witness(case: LocalCase) -> dict[str, Any]:
    agents = list(case.structural)
    a = agents[0]
    nodes = case.model.nodes
    n = len(nodes)
    x = np.zeros(2 * n)
    u = np.zeros(len(case.suspected) + len(case.model.boundary))
    u[case.suspected.index(a)] = 1.0
    u[len(case.suspected) + case.model.boundary.index(a)] = 1.0
    d = _direction_witness(case, 0.0, x, u)
    d.pop("lambda")
    return {
        "structural": True,
        "suspected_and_boundary": agents,
        "reason": (
            f"agent{'s' if len(agents) > 1 else ''} {', '.join(map(str, agents))} "
            f"{'are' if len(agents) > 1 else 'is'} both suspected and on the boundary: the columns of -B^i and E^i "
            "at its velocity row are opposite, so the pencil loses rank at every lam (the attack is "
            "indistinguishable from the neighbour coupling and T B e_k = 0 in the UIO error)"
        ),
        "direction": d,
    }


def _relative_sigma_min(case: LocalCase, lam: complex) -> float:
    P = full_pencil(case, lam)
    if P.shape[0] < P.shape[1]:
        return 0.0  # wide: a kernel vector exists at every lam
    s = np.linalg.svd(P, compute_uv=False)
    return float(s[P.shape[1] - 1] / s[0]) if s[0] > 0 else 0.0


def _sample_points(system: System) -> list[complex]:
    pts: list[complex] = [0.0, 1.0, 1j, complex(-system.gamma / 2.0, 0.7)]
    if system.spec.attack is not None and system.spec.attack.lambda0 is not None:
        pts.append(complex(system.spec.attack.lambda0))
    return pts


def pencil_verdict(
    system: System, case: LocalCase, tol: Tolerance = DEFAULT_TOLERANCE, *, margin: bool = True
) -> tuple[Status, float, dict[str, Any]]:
    """Numeric verdict of (iii) for one case: ``(status, margin, witness)``.

    Parameters
    ----------
    system : System
    case : LocalCase
    tol : Tolerance
        Passed to :func:`glocal_verify.pencil.analyze_pencil`.
    margin : bool
        Compute the sampled margin (one SVD of the full pencil per sample point); when False
        the margin returned is NaN.

    Notes
    -----
    Structural failures (suspected and boundary agent) are decided combinatorially. Otherwise
    the Rosenbrock pencil of (A^i, [B^i, -E^i], C_loc, 0) is analysed by
    :func:`glocal_verify.pencil.analyze_pencil` (normal rank and finite zeros). Every zero it
    reports is re-verified on the full pencil of eq. ``pencil_uio``: its smallest singular value
    relative to the largest must not be certainly nonzero at ``tol``; a zero that fails this
    makes the verdict undecided (it is never dropped silently).
    """
    from .pencil import analyze_pencil, direction_at

    if case.structural:
        return Status.FAILS, 0.0, _structural_witness(case)
    A, G, C = pencil_matrices(case)
    pa = analyze_pencil(A, G, C, None, tol=tol)
    margin_value = min(_relative_sigma_min(case, lam) for lam in _sample_points(system)) if margin else float("nan")
    witness: dict[str, Any] = {
        "normal_rank": int(pa.normal_rank),
        "columns": int(A.shape[0] + G.shape[1]),
        "full_normal_column_rank": bool(pa.full_normal_column_rank),
        "zeros": [],
    }
    undecided = not pa.decided
    if not pa.full_normal_column_rank:
        lam = _lambda0(system)
        d = direction_at(A, G, C, None, lam, tol=tol)
        witness["note"] = "the pencil loses rank at every complex lam: a stealthy direction exists for every lam0"
        if d is not None:
            witness["direction"] = _direction_witness(case, lam, d[0], d[1])
        sm = _relative_sigma_min(case, lam)
        witness["sigma_min_at_lambda"] = sm
        if tol.decide(sm, 1.0) is Decision.NONZERO:
            undecided = True
            witness["verification"] = "the full pencil does not lose rank at the sample lam"
        status = Status.UNDECIDED if undecided else Status.FAILS
        return status, 0.0, witness
    for z in pa.zeros:
        w = _direction_witness(case, z.value, z.x, z.u)
        sm = _relative_sigma_min(case, z.value)
        w["sigma_min"] = sm
        w["growth"] = "unbounded" if z.value.real > 0 else ("persistent" if z.value.real == 0 else "decaying")
        if tol.decide(sm, 1.0) is Decision.NONZERO or not z.verified:
            w["verified"] = False
            undecided = True
        else:
            w["verified"] = True
        if z.multiplicity > 1:
            w["multiplicity"] = z.multiplicity
        witness["zeros"].append(w)
    if pa.zeros:
        witness["zeros"] = witness["zeros"][:12]
        status = Status.UNDECIDED if (undecided and not any(w["verified"] for w in witness["zeros"])) else Status.FAILS
        return status, 0.0, witness
    return (Status.UNDECIDED if undecided else Status.HOLDS), margin_value, witness


def _pencil_exact(system: System, case: LocalCase) -> tuple[Status, dict[str, Any]]:
    """Exact verdict of (iii): full column rank for every lam iff (A^i, [B^i, -E^i], C_loc) is
    left-invertible and V* = {0} (:func:`glocal_verify.pencil.analyze_pencil_exact`)."""
    from .pencil import analyze_pencil_exact, direction_at

    if case.structural:
        return Status.FAILS, _structural_witness(case)
    A, G, C = pencil_matrices_exact(system, case)
    pe = analyze_pencil_exact(A, G, C, None)
    witness: dict[str, Any] = {
        "normal_rank": pe.normal_rank,
        "columns": len(A) + (len(G[0]) if G else 0),
        "full_normal_column_rank": bool(pe.full_normal_column_rank),
        "v_star_dim": len(pe.v_star),
        "r_star_dim": pe.r_star_dim,
        "zero_polynomial": str(pe.zero_polynomial),
    }
    if pe.full_normal_column_rank and not pe.v_star:
        return Status.HOLDS, witness
    if not pe.full_normal_column_rank:
        lam = _lambda0(system)
        An, Gn, Cn = pencil_matrices(case)
        d = direction_at(An, Gn, Cn, None, lam)
        witness["note"] = "the pencil loses rank at every complex lam: a stealthy direction exists for every lam0"
        if d is not None:
            witness["direction"] = _direction_witness(case, lam, d[0], d[1])
    zs = []
    for z in pe.zeros[:12]:
        w: dict[str, Any] = _direction_witness(case, z.value, z.x, z.u) if (z.x.size or z.u.size) else {"lambda": _num(z.value)}
        w.update(
            {
                "factor": z.factor,
                "multiplicity": z.multiplicity,
                "growth": {1: "unbounded", 0: "persistent", -1: "decaying"}[z.real_sign],
                "input_direction": z.input_direction,
                "sigma_min": _relative_sigma_min(case, z.value),
            }
        )
        if z.rational is not None:
            w["lambda"] = z.rational
        zs.append(w)
    witness["zeros"] = zs
    return Status.FAILS, witness


def _lambda0(system: System) -> complex:
    a = system.spec.attack
    return complex(a.lambda0) if (a is not None and a.lambda0 is not None) else complex(0.5)


@checker("local.pencil")
def check_pencil(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition III.2 (iii): the pencil of eq. ``pencil_uio`` has full column rank for every lam.

    .. math::

        P(\\lambda) = \\begin{bmatrix} \\lambda I - A^i & -B^i & E^i \\\\ C_{loc} & 0 & 0
        \\end{bmatrix},\\qquad \\operatorname{rank} P(\\lambda) = 2 N_i + |\\bar F_i| +
        \\operatorname{rank} E^i \\quad \\forall \\lambda \\in \\mathbb C

    i.e. full normal column rank and no finite zero. Numeric: see :func:`pencil_verdict`
    (tolerance rule of :func:`glocal_verify.pencil.analyze_pencil`, every zero re-verified on
    the full pencil). Exact: :func:`glocal_verify.pencil.analyze_pencil_exact` over Q.

    Margin
        (holds) the smallest singular value of P(lam) relative to its largest over the sample
        points lam in {0, 1, i, -gamma/2 + 0.7 i, lambda0}: an upper bound of the distance to
        failure; 0 on failure.
    Witness
        On a structural failure ``suspected_and_boundary`` and a direction; on normal-rank
        deficiency a direction at lambda0 (or 0.5); on finite zeros each zero with its
        direction (``positions``, ``velocities``, ``attack_input``, ``coupling_input``,
        ``moves``), growth class, ``residual`` ||P v|| / (||P|| ||v||) and ``sigma_min``.
    """
    out = []
    for case in local_cases(system):
        if ctx.exact:
            status, witness = _pencil_exact(system, case)
            margin = 0.0 if status is Status.FAILS else min(_relative_sigma_min(case, lam) for lam in _sample_points(system))
        else:
            status, margin, witness = pencil_verdict(system, case, ctx.tol)
        witness = {"mode": case.mode, "suspected_agents": list(case.suspected), **witness}
        out.append(result("local.pencil", ctx, status, scope=case.scope, margin=margin, witness=witness))
    return out


# --------------------------------------------------------------------------------------------
# UIO


def _uio_one(system: System, case: LocalCase, mode: str, tol: Tolerance, exact: bool) -> tuple[Status, float, dict[str, Any]]:
    cm = system.cluster_model(case.model.name, mode)
    obs = case.observer
    C = cm.C(obs.positions, obs.velocities)
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
    existence = uio_existence(cm.A, cm.E, C, tol)
    if exact_status is Status.FAILS or existence.status is not Status.HOLDS:
        if existence.rank_condition is Status.FAILS:
            w["unmeasured_boundary"] = [a for a in cm.boundary if a not in obs.velocities]
        if existence.unstable_mode is not None:
            lam, vec = existence.unstable_mode
            n = len(cm.nodes)
            vec = vec / vec[int(np.argmax(np.abs(vec)))]
            w["unstable_unobservable_mode"] = {
                "eigenvalue": _num(lam, 9),
                "positions": {a: _num(c, 9) for a, c in zip(cm.nodes, vec[:n]) if abs(c) > 1e-9},
                "velocities": {a: _num(c, 9) for a, c in zip(cm.nodes, vec[n:]) if abs(c) > 1e-9},
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
        _, d = design_uio(cm.A, cm.E, C, poles=poles, gamma=system.gamma, tol=tol)
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
    invisible = [a for a in case.suspected if a in cm.boundary]
    if invisible:
        w["attack_invisible"] = invisible
    design_ok = checks["decoupling"] is Decision.ZERO and checks["error_free_of_state"] is Decision.ZERO and hurwitz_ok
    if design_ok:
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

    The design (:func:`glocal_verify.uio.design_uio`, eqs. ``uio_conds_1``-``uio_conds_3``)
    places the observable poles of (A_1, C) (the observer's ``poles`` or the defaults of
    :func:`glocal_verify.uio.default_poles`) and is verified: ||(h C - I) E||_F / ||E||_F and
    ||T A - F T - K C||_F / (||A||_F + ||F||_F) must be zero at ``rtol`` (the error equation of
    eq. ``obs_decent_error`` is then free of the neighbour states) and F must be Hurwitz with
    certified Hurwitz by :func:`glocal_verify.uio.hurwitz_certificate` (every eigenvalue at
    least ``band`` times its uncertainty rtol ||F||_2 kappa_i left of the axis). The paper asks F Hurwitz in every mode, so the
    observer is designed and verified for the normal mode and every safe mode (F_q per mode);
    the verdict holds only if all do. Exact mode decides existence over Q (rank condition, Routh
    test of the unobservable part's characteristic polynomial); the design stays numeric.
    Existence does not involve B^i; the suspected set only adds ``attack_invisible``: suspected
    boundary agents, whose attack the observer cancels together with the coupling (T B e_k = 0).

    Margin
        min over modes of -max Re eig(F_q) (negative: the most unstable unobservable mode).
    Witness
        Per mode: poles, eigenvalues of F, residuals, unobservable eigenvalues; on failure the
        unmeasured boundary agents or the unstable unobservable mode (eigenvalue and vector).
    """
    out = []
    for case in local_cases(system):
        status, margin, witness = uio_verdict(system, case, ctx.tol, ctx.exact)
        out.append(result("local.uio", ctx, status, scope=case.scope, margin=margin, witness=witness))
    return out


def uio_verdict(system: System, case: LocalCase, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> tuple[Status, float, dict[str, Any]]:
    """Verdict of local.uio for one case over every mode: ``(status, margin, witness)``.

    Parameters
    ----------
    system : System
    case : LocalCase
    tol : Tolerance
    exact : bool
        Decide existence over Q (the design stays numeric).
    """
    per_mode: dict[str, Any] = {}
    statuses = []
    margins = []
    for mode in system.modes:
        st, mg, w = _uio_one(system, case, mode, tol, exact)
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
