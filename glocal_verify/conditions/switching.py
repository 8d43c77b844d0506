"""Conditions of Theorem III.3 (``th:Attack_detectability_switching``) and Lemma A.2.

For a safe mode q with dL_q = L_q - L_1, the switching components D_c are the connected
components (>= 2 nodes) of the graph whose edges are the nonzero off-diagonal entries of dL_q
(Definition A.1). dL_q is block diagonal over the D_c and zero elsewhere, so every subspace
question below splits into one small question per component.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify.analysis.modal import eigen_residuals
from glocal_verify.conditions.registry import CheckContext, checker, result
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.tolerance import Decision
from glocal_verify.results import ConditionResult, Status
from glocal_verify.spec.types import Label

__all__ = [
    "check_image_kernel",
    "check_distinct_eigenvalues",
    "check_coverage",
    "image_kernel_component",
    "check_eigenvector_differences",
    "eigenvector_difference_polynomial",
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


# --------------------------------------------------------------------------------------------
# Theorem III.3 (iii)

_EPS = float(np.finfo(float).eps)


def _pairs(system: System, mode: str) -> list[tuple[Label, Label]]:
    out = []
    for comp in system.switching_components(mode):
        for a in range(len(comp)):
            for b in range(a + 1, len(comp)):
                out.append((comp[a], comp[b]))
    return out


def eigenvector_difference_polynomial(L: list[list[Fraction]], i: int, j: int) -> "ex.flint.fmpq_poly":
    """q_ij(mu) = (e_i - e_j)^T adj(mu I - L) (e_i - e_j), exactly.

    By the matrix determinant lemma, ``det(M + b b^T) = det M + b^T adj(M) b``; with
    ``M = mu I - L`` and ``b = e_i - e_j``,

    .. math:: q_{ij}(\\mu) = \\det(\\mu I - (L - b b^\\top)) - \\det(\\mu I - L),

    the difference of two characteristic polynomials (``L - b b^T`` is L with the weight of the
    pair {i, j} lowered by 1). For a simple eigenvalue ``mu_l`` with unit eigenvector ``u_l``,
    ``adj(mu_l I - L) = p'(mu_l) u_l u_l^T``, hence ``q_ij(mu_l) = p'(mu_l) (u_l(i) - u_l(j))^2``.

    Parameters
    ----------
    L : list of list of Fraction
        A symmetric rational matrix (a Laplacian).
    i, j : int
        0-based indices, ``i != j``.
    """
    M = [list(r) for r in L]
    M[i][i] -= 1
    M[j][j] -= 1
    M[i][j] += 1
    M[j][i] += 1
    return ex.charpoly(M) - ex.charpoly(L)


def _repeated_witness(system: System, U: np.ndarray, w: np.ndarray, g: list[int], pair: tuple[Label, Label]) -> dict[str, Any]:
    """A unit u in the eigenspace of the group g with u(i) = u(j): it exists when dim >= 2."""
    i, j = system.idx(pair)
    E = U[:, g]
    row = (E[i] - E[j])[None, :]
    _, _, Vh = np.linalg.svd(row, full_matrices=True)
    u = E @ Vh[-1]
    u = u / np.linalg.norm(u)
    u = np.where(np.abs(u) <= 1e-14, 0.0, u)
    return {
        "reason": "repeated eigenvalue: (iii) presupposes (ii); in an eigenspace of dimension >= 2 some unit "
        "eigenvector has u(i) = u(j), and an orthonormal eigenbasis U_q containing it violates (iii)",
        "eigenvalue": float(np.mean(w[g])),
        "multiplicity": len(g),
        "pair": list(pair),
        "eigenvector": system.vector_by_label(u, digits=12),
        "difference": float(u[i] - u[j]),
    }


def _eigvec_numeric(system: System, mode: str, ctx: CheckContext) -> tuple[Status, float, dict[str, Any]]:
    w, U = system.eigh(mode)
    n = system.n
    pairs = _pairs(system, mode)
    if not pairs:
        return Status.HOLDS, 1.0, {"note": "the mode changes no link: no pair to check"}
    scale = float(np.max(np.abs(w))) if n else 0.0
    scale = scale if scale > 0 else 1.0
    groups: list[list[int]] = [[0]]
    undecided_gap: list[int] = []
    for k in range(1, n):
        d = ctx.tol.decide(w[k] - w[k - 1], scale)
        if d is Decision.ZERO:
            groups[-1].append(k)
        else:
            if d is Decision.UNDECIDED:
                undecided_gap.append(k)
            groups.append([k])
    rep = [g for g in groups if len(g) >= 2]
    if rep:
        return Status.FAILS, 0.0, _repeated_witness(system, U, w, rep[0], pairs[0])
    idx = [tuple(system.idx(p)) for p in pairs]
    ii = np.array([a for a, _ in idx])
    jj = np.array([b for _, b in idx])
    D = np.abs(U[ii, :] - U[jj, :])  # pairs x N
    gaps = np.diff(w)
    left = np.concatenate([[np.inf], gaps])
    right = np.concatenate([gaps, [np.inf]])
    res = eigen_residuals(system, mode)
    gap = np.minimum(left, right) - 2.0 * float(np.max(res))
    with np.errstate(divide="ignore"):
        # Davis-Kahan: sin(angle(u_l, exact)) <= ||L u_l - w_l u_l|| / gap_l; an entry difference
        # moves by at most 2 sin(angle)
        err = np.where(gap > 0, 2.0 * res / np.where(gap > 0, gap, 1.0), np.inf) + 2.0 * math.sqrt(n) * _EPS
    cols = list(range(1, n))  # l != 1 (the simple eigenvalue 0 of a connected graph, or the smallest one)
    if not cols:
        return Status.HOLDS, 1.0, {"note": "a single agent"}
    sub = D[:, cols]
    flat = int(np.argmin(sub))
    pk, lk = divmod(flat, len(cols))
    l = cols[lk]
    margin = float(sub[pk, lk])
    status = Status.HOLDS
    witness: dict[str, Any] = {}
    first_undecided: tuple[int, int] | None = None
    for c_i, l_i in enumerate(cols):
        for p_i in range(len(pairs)):
            dec = _decide_err(float(D[p_i, l_i]), float(err[l_i]), ctx)
            if dec is Decision.ZERO:
                a, b = idx[p_i]
                return Status.FAILS, 0.0, {
                    "pair": list(pairs[p_i]),
                    "l": l_i + 1,
                    "eigenvalue": float(w[l_i]),
                    "entries": [float(U[a, l_i]), float(U[b, l_i])],
                    "difference": float(D[p_i, l_i]),
                    "error_bound": float(err[l_i]),
                }
            if dec is Decision.UNDECIDED and first_undecided is None:
                first_undecided = (p_i, l_i)
    if first_undecided is not None:
        status = Status.UNDECIDED
        p_i, l_i = first_undecided
        witness = {"pair": list(pairs[p_i]), "l": l_i + 1, "eigenvalue": float(w[l_i]),
                   "difference": float(D[p_i, l_i]), "error_bound": float(err[l_i])}
    elif undecided_gap:
        status = Status.UNDECIDED
        k = undecided_gap[0]
        witness = {"reason": "eigenvalues l and l+1 may coincide at this tolerance", "l": k, "eigenvalues": [float(w[k - 1]), float(w[k])]}
    else:
        a, b = idx[pk]
        witness = {"closest": {"pair": list(pairs[pk]), "l": l + 1, "eigenvalue": float(w[l]),
                               "entries": [float(U[a, l]), float(U[b, l])], "error_bound": float(err[l])}}
    witness["pairs_checked"] = len(pairs)
    return status, margin, witness


def _decide_err(value: float, error: float, ctx: CheckContext) -> Decision:
    if not math.isfinite(error):
        return Decision.UNDECIDED
    if value + error <= ctx.tol.rtol:
        return Decision.ZERO
    if value - error > ctx.tol.upper:
        return Decision.NONZERO
    return Decision.UNDECIDED


def _eigvec_exact(system: System, mode: str, numeric: tuple[Status, float, dict[str, Any]]) -> tuple[Status, float, dict[str, Any]]:
    pairs = _pairs(system, mode)
    _, margin, nwit = numeric
    if not pairs:
        return Status.HOLDS, 1.0, {"note": "the mode changes no link: no pair to check"}
    L = system.laplacian_exact(mode)
    p = ex.charpoly(L)
    if not ex.is_squarefree(p):
        g = ex.repeated_factor(p)
        w, U = system.eigh(mode)
        wit: dict[str, Any] = {
            "reason": "repeated eigenvalue: (iii) presupposes (ii); in an eigenspace of dimension >= 2 some unit "
            "eigenvector has u(i) = u(j), and an orthonormal eigenbasis U_q containing it violates (iii)",
            "repeated_factor": ex.poly_str(g),
            "pair": list(pairs[0]),
        }
        if "eigenvector" in nwit:
            wit["eigenvector"] = nwit["eigenvector"]
        return Status.FAILS, 0.0, wit
    coeffs = p.coeffs()
    if coeffs[0] != 0:  # pragma: no cover - a Laplacian always has the eigenvalue 0
        raise AssertionError("charpoly of a Laplacian must vanish at 0")
    p0 = type(p)(coeffs[1:])  # p(mu) / mu
    w, U = system.eigh(mode)
    for a, b in pairs:
        i, j = system.idx((a, b))
        q = eigenvector_difference_polynomial(L, i, j)
        g = p0.gcd(q)
        if g.degree() >= 1:
            fl = [float(Fraction(int(c.p), int(c.q))) for c in reversed(g.coeffs())]
            roots = np.roots(fl) if len(fl) > 1 else np.zeros(0)
            mu = float(np.real(roots[0])) if len(roots) else float("nan")
            l = int(np.argmin(np.abs(w - mu)))
            return Status.FAILS, 0.0, {
                "pair": [a, b],
                "l": l + 1,
                "eigenvalue": mu,
                "common_factor": ex.poly_str(g),
                "entries": [float(U[i, l]), float(U[j, l])],
            }
    return Status.HOLDS, margin, {"pairs_checked": len(pairs), "closest": nwit.get("closest")}


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

    Numeric: eigenvalues grouped at ``rtol * ||L_q||_2`` (as in ``switching.distinct-eigenvalues``);
    for a simple eigenvalue the differences ``|u_l(i) - u_l(j)|`` of the unit eigenvectors are
    compared with ``rtol`` (unit scale) after widening by the a-posteriori Davis-Kahan error
    ``2 ||L_q u_l - mu_l u_l|| / gap_l`` (``gap_l`` = distance to the nearest other eigenvalue,
    shrunk by twice the largest residual; :func:`~glocal_verify.analysis.modal.eigen_residuals`):
    zero if ``d + err <= rtol``, nonzero if ``d - err > rtol * band``, undecided otherwise; an
    undecided eigenvalue gap makes the verdict undecided.
    Exact: ``p`` = charpoly(L_q); repeated eigenvalue iff ``gcd(p, p') != 1`` (fails). Otherwise
    with ``q_ij`` from :func:`eigenvector_difference_polynomial`,
    ``q_ij(mu_l) = p'(mu_l) (u_l(i) - u_l(j))^2`` and ``p'(mu_l) != 0``, so (iii) fails for (i, j)
    iff ``gcd(p(mu) / mu, q_ij) != 1``.

    Margin
        ``min |u_l(i) - u_l(j)|`` over ``l != 1`` and the pairs (unit eigenvectors; floating
        point in both modes), 0 on failure.
    Witness
        On failure the pair (i, j), ``l`` (1-based, ascending eigenvalues), the eigenvalue and
        the two entries; exact: also the common factor. A repeated eigenvalue: the reason, the
        eigenvalue (or the repeated factor) and an eigenvector with equal entries on the pair.
        On success the closest (pair, l).
    """
    out = []
    for mode in system.safe_modes:
        num = _eigvec_numeric(system, mode, ctx)
        status, margin, witness = _eigvec_exact(system, mode, num) if ctx.exact else num
        out.append(result("switching.eigenvector-differences", ctx, status, scope={"mode": mode}, margin=margin, witness=witness))
    return out
