"""Conditions of Theorem III.3 (``th:Attack_detectability_switching``) and Lemma A.2.

For a safe mode q with dL_q = L_q - L_1, the switching components D_c are the connected
components (>= 2 nodes) of the graph whose edges are the nonzero off-diagonal entries of dL_q
(Definition A.1). dL_q is block diagonal over the D_c and zero elsewhere, so every subspace
question below splits into one small question per component.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from . import exact as ex
from .linalg import Decision
from .model import System
from .registry import CheckContext, checker, result
from .results import ConditionResult, Status
from .spec import Label

__all__ = [
    "check_image_kernel",
    "check_distinct_eigenvalues",
    "check_coverage",
    "image_kernel_component",
]


def _component_block(system: System, mode: str, comp: tuple[Label, ...]) -> tuple[list[int], np.ndarray]:
    idx = system.idx(comp)
    dL = system.delta_laplacian(mode)
    return idx, np.array(dL[np.ix_(idx, idx)])


def image_kernel_component(
    system: System, mode: str, comp: tuple[Label, ...], ctx: CheckContext
) -> dict[str, Any]:
    """Theorem III.3 (i) restricted to one switching component D_c.

    Numeric: Q = orthonormal eigenvectors of the nonzero eigenvalues of dL[D_c, D_c]
    (eigenvalues are zero below ``rtol * ||dL_q||_2``); the condition holds on D_c iff
    sigma_min(S_M Q) > 0, decided against ``rtol`` (Q is orthonormal, so the scale is 1).
    Exact: rank(dL_c[M, :]) = rank(dL_c) over Q.

    Returns a dict with ``status``, ``sigma_min``, ``rank``, ``monitored`` and, on failure,
    ``vector`` (a y in Im(dL_q) with S_M y = 0).
    """
    monitored = set(system.monitored)
    mon = [a for a in comp if a in monitored]
    idx, block = _component_block(system, mode, comp)
    w, V = np.linalg.eigh(block)
    scale = float(np.max(np.abs(w))) if len(w) else 0.0
    dec = [ctx.tol.decide(x, scale) for x in w]
    nz = [k for k, d in enumerate(dec) if d is Decision.NONZERO]
    rank_undecided = any(d is Decision.UNDECIDED for d in dec)
    Q = V[:, nz]
    rows = [comp.index(a) for a in mon]
    SQ = Q[rows, :]
    if Q.shape[1] == 0:
        sigma, vec = 1.0, None
    elif SQ.shape[0] == 0:
        sigma, vec = 0.0, Q[:, 0]
    else:
        _, s, Vh = np.linalg.svd(SQ, full_matrices=True)
        s_full = np.zeros(Q.shape[1])
        s_full[: len(s)] = s
        k = int(np.argmin(s_full))
        sigma = float(s_full[k])
        vec = Q @ Vh[k] if sigma <= ctx.tol.upper else None
    info: dict[str, Any] = {"nodes": list(comp), "rank": len(nz), "monitored": mon, "sigma_min": sigma}
    if ctx.exact:
        Lc = system.delta_laplacian_exact(mode)
        block_q = [[Lc[i][j] for j in idx] for i in idx]
        r = ex.rank(block_q)
        rows_q = [block_q[i] for i in rows]
        r2 = ex.rank(rows_q, ncols=len(comp)) if rows_q else 0
        info["rank"] = r
        if r2 == r:
            info["status"] = Status.HOLDS
        else:
            info["status"] = Status.FAILS
            # z in ker(S_M dL_c) with dL_c z != 0 gives y = dL_c z in the intersection
            kern = ex.nullspace(rows_q, ncols=len(comp)) if rows_q else [
                [Fraction(int(i == j)) for i in range(len(comp))] for j in range(len(comp))
            ]
            for z in kern:
                y = ex.matvec(block_q, z)
                if any(v != 0 for v in y):
                    info["vector"] = dict(zip(comp, y))
                    break
        return info
    d = ctx.tol.decide(sigma, 1.0)
    if rank_undecided or d is Decision.UNDECIDED:
        info["status"] = Status.UNDECIDED
    elif d is Decision.ZERO:
        info["status"] = Status.FAILS
    else:
        info["status"] = Status.HOLDS
    if info["status"] is not Status.HOLDS and vec is not None:
        vec = vec / np.max(np.abs(vec))
        info["vector"] = {a: float(x) for a, x in zip(comp, vec)}
    return info


def _combine(statuses: list[Status]) -> Status:
    if any(s is Status.FAILS for s in statuses):
        return Status.FAILS
    if any(s is Status.UNDECIDED for s in statuses):
        return Status.UNDECIDED
    return Status.HOLDS


@checker("switching.image-kernel")
def check_image_kernel(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3 (i): Im(dL_q) ∩ ker([S_{M_x}; S_{M_v}]) = {0}.

    .. math:: \\operatorname{Im}(\\Delta L_q) \\cap \\ker \\begin{bmatrix} S_{M_x} \\\\ S_{M_v}
              \\end{bmatrix} = \\{0\\} \\iff \\operatorname{rank}(S_M \\Delta L_q)
              = \\operatorname{rank}(\\Delta L_q)

    (the paper writes "= emptyset"; an intersection of subspaces always holds 0). Decided per
    switching component (see :func:`image_kernel_component`). A necessary consequence: a
    component whose block has rank r needs at least r monitored agents.

    Margin
        min over components of sigma_min(S_M Q_c), Q_c an orthonormal basis of Im(dL_c):
        the smallest fraction of a unit vector of Im(dL_q) seen by the monitors, in [0, 1];
        0 when the condition fails. Always computed in floating point.
    Witness
        Per component: nodes, rank, monitored agents, sigma_min; on failure ``vector``:
        y in Im(dL_q) with S_M y = 0 (labels of D_c; zero elsewhere) and ``monitors_needed``.
    """
    out = []
    for mode in system.safe_modes:
        comps = system.switching_components(mode)
        infos = [image_kernel_component(system, mode, c, ctx) for c in comps]
        status = _combine([i["status"] for i in infos]) if infos else Status.HOLDS
        margin = min((i["sigma_min"] for i in infos), default=1.0)
        if status is Status.FAILS:
            margin = 0.0 if ctx.exact else margin
        witness: dict[str, Any] = {
            "components": [{k: v for k, v in i.items() if k not in ("status", "vector")} for i in infos]
        }
        bad = [i for i in infos if i["status"] is not Status.HOLDS]
        if bad:
            b = bad[0]
            witness["failing_component"] = b["nodes"]
            witness["monitors_needed"] = b["rank"]
            if "vector" in b:
                witness["vector"] = b["vector"]
        if not comps:
            witness["note"] = "the mode changes no link: Im(dL_q) = {0}"
        out.append(result("switching.image-kernel", ctx, status, scope={"mode": mode}, margin=margin, witness=witness))
    return out


@checker("switching.distinct-eigenvalues")
def check_distinct_eigenvalues(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3 (ii): L_q has N distinct eigenvalues.

    Numeric: eigenvalues of the symmetric L_q (``eigh``); two consecutive eigenvalues are
    equal if their gap is at most ``rtol * ||L_q||_2``, distinct above ``rtol * band *
    ||L_q||_2``, undecided in between. Exact: the characteristic polynomial p is squarefree,
    gcd(p, p') = 1 over Q.

    Margin
        The smallest gap between consecutive eigenvalues (floating point), 0 on failure in
        exact mode.
    Witness
        On success the closest pair (1-based positions in ascending order and values). On
        failure (numeric) a repeated eigenvalue, its multiplicity and two orthonormal
        eigenvectors; (exact) ``repeated_factor`` = gcd(p, p') and, for each rational root,
        a rational basis of the eigenspace.
    """
    out = []
    for mode in system.safe_modes:
        w, U = system.eigh(mode)
        scale = float(np.max(np.abs(w))) if len(w) else 0.0
        gaps = np.diff(w)
        k = int(np.argmin(gaps)) if len(gaps) else 0
        margin = float(gaps[k]) if len(gaps) else float("inf")
        witness: dict[str, Any] = {}
        if ctx.exact:
            p = ex.charpoly(system.laplacian_exact(mode))
            if ex.is_squarefree(p):
                status = Status.HOLDS
                witness = {"closest_pair": [k + 1, k + 2], "eigenvalues": [float(w[k]), float(w[k + 1])]}
            else:
                status = Status.FAILS
                margin = 0.0
                g = ex.repeated_factor(p)
                witness = {"repeated_factor": ex.poly_str(g), "charpoly_degree": int(p.degree())}
                spaces = []
                L = system.laplacian_exact(mode)
                for root, _mult in g.roots() if hasattr(g, "roots") else []:
                    mu = ex.to_fraction(root)
                    M = [[L[i][j] - (mu if i == j else 0) for j in range(system.n)] for i in range(system.n)]
                    basis = ex.nullspace(M)
                    spaces.append({"eigenvalue": mu, "basis": [system.vector_by_label(b) for b in basis]})
                if spaces:
                    witness["rational_eigenspaces"] = spaces
        else:
            decisions = [ctx.tol.decide(g, scale) for g in gaps]
            if any(d is Decision.ZERO for d in decisions):
                status = Status.FAILS
                j = next(i for i, d in enumerate(decisions) if d is Decision.ZERO)
                mult = 2
                while j + mult - 1 < len(decisions) and decisions[j + mult - 1] is Decision.ZERO:
                    mult += 1
                witness = {
                    "eigenvalue": float(np.mean(w[j : j + mult])),
                    "multiplicity": mult,
                    "eigenvectors": [system.vector_by_label(U[:, j]), system.vector_by_label(U[:, j + 1])],
                }
            elif any(d is Decision.UNDECIDED for d in decisions):
                status = Status.UNDECIDED
                j = next(i for i, d in enumerate(decisions) if d is Decision.UNDECIDED)
                witness = {"closest_pair": [j + 1, j + 2], "eigenvalues": [float(w[j]), float(w[j + 1])], "gap": float(gaps[j])}
            else:
                status = Status.HOLDS
                witness = {"closest_pair": [k + 1, k + 2], "eigenvalues": [float(w[k]), float(w[k + 1])]}
        out.append(result("switching.distinct-eigenvalues", ctx, status, scope={"mode": mode}, margin=margin, witness=witness))
    return out


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
    monitored = set(system.monitored)
    out = []
    for mode in system.safe_modes:
        comps = system.switching_components(mode)
        rows = [{"nodes": list(c), "monitored": [a for a in c if a in monitored]} for c in comps]
        uncovered = [r["nodes"] for r in rows if not r["monitored"]]
        status = Status.FAILS if uncovered else Status.HOLDS
        witness: dict[str, Any] = {"components": rows}
        if uncovered:
            witness["uncovered"] = uncovered
        margin = min((len(r["monitored"]) for r in rows), default=0)
        out.append(result("switching.coverage", ctx, status, scope={"mode": mode}, margin=margin, witness=witness, numeric_decision=False))
    return out
