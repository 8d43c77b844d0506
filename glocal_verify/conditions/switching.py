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

from glocal_verify.analysis.twins import distinct_eigenvalues_modular, eigenvector_differences_modular
from glocal_verify.conditions.registry import CheckContext, checker, result
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.results import ConditionResult, Status
from glocal_verify.spec.types import Label

__all__ = [
    "SVD_BACKWARD_CONSTANT",
    "algebraic_root_witness",
    "check_coverage",
    "check_distinct_eigenvalues",
    "check_eigenvector_differences",
    "check_image_kernel",
    "eigenvector_difference_polynomial",
    "image_kernel_component",
    "svd_rank_bound",
]

_EPS = float(np.finfo(float).eps)
_U = _EPS / 2.0
#: constant c of the SVD backward-error bound c * max(m, n) * eps * ||M||_2 used for ranks
SVD_BACKWARD_CONSTANT = 10.0


def _component_block(system: System, mode: str, comp: tuple[Label, ...]) -> tuple[list[int], np.ndarray]:
    idx = system.idx(comp)
    dL = system.delta_laplacian_sparse(mode)
    return idx, dL[idx, :][:, idx].toarray()


def svd_rank_bound(M: np.ndarray) -> tuple[np.ndarray, float]:
    """Singular values of ``M`` and a rigorous bound on their distance to those of the exact matrix.

    ``M`` holds correctly rounded copies of exact entries. The computed singular values are
    those of ``M + E`` with ``||E||_2 <= c max(m, n) eps ||M||_2`` (backward stability of the
    Golub-Kahan SVD, ``c = SVD_BACKWARD_CONSTANT = 10``), and the rounding of the input adds
    ``u ||M||_F``; by Weyl's theorem for singular values each computed ``s_k`` is within

    .. math:: \\beta = c \\max(m, n)\\, \\varepsilon\\, s_1 (1 + 2\\varepsilon) + u \\|M\\|_F

    of the k-th singular value of the exact matrix. A singular value ``s_k > beta`` is
    certainly nonzero; a smaller one proves nothing (it is never read as zero).

    Parameters
    ----------
    M : ndarray
        A real matrix (correctly rounded from exact data).

    Returns
    -------
    tuple
        ``(singular values (descending), beta)``.
    """
    if M.size == 0:
        return np.zeros(0), 0.0
    sv = np.linalg.svd(M, compute_uv=False)
    beta = SVD_BACKWARD_CONSTANT * max(M.shape) * _EPS * float(sv[0]) * (1 + 2 * _EPS) + _U * float(np.linalg.norm(M, "fro"))
    return sv, beta


def image_kernel_component(
    system: System, mode: str, comp: tuple[Label, ...], ctx: CheckContext
) -> dict[str, Any]:
    """Theorem III.3 (i) restricted to one switching component D_c: rank(S_M dL_c) = rank(dL_c).

    Structure first (exact, from the spec's rational link differences): dL_c is the
    Laplacian of the connected graph of switching links of D_c with signed weights, so
    ``rank(dL_c) <= |D_c| - 1`` and ``rank(S_M dL_c) <= min(|M ∩ D_c|, |D_c| - 1)``. When all
    link differences of D_c have one sign, dL_c is +- the Laplacian of a connected graph with
    positive weights: ``rank(dL_c) = |D_c| - 1`` and any ``|D_c| - 1`` of its rows are
    independent, so the condition holds on D_c iff ``|M ∩ D_c| >= |D_c| - 1`` (combinatorial,
    no rounding). With mixed signs the numeric decision uses certified singular values
    (:func:`svd_rank_bound`): holds if ``S_M dL_c`` has ``|D_c| - 1`` singular values above
    its bound beta; fails if dL_c has more singular values above beta than
    ``min(|M ∩ D_c|, |D_c| - 1)``; undecided otherwise (escalation decides exactly).
    Exact: rank(dL_c[M, :]) = rank(dL_c) over Q.

    Returns a dict with ``status``, ``sigma_min`` (the robustness margin: the smallest
    fraction of a unit vector of Im(dL_c) seen by the monitors, ``sigma_min(S_M Q_c)``),
    ``rank``, ``monitored``, ``error_bound``/``note`` when undecided and, on failure,
    ``vector`` (a y in Im(dL_q) with S_M y = 0).
    """
    monitored = set(system.monitored)
    mon = [a for a in comp if a in monitored]
    nc = len(comp)
    inside = set(comp)
    signs = {d > 0 for a, b, d in system.switching_links(mode) if a in inside and b in inside}
    same_sign = len(signs) == 1
    idx, block = _component_block(system, mode, comp)
    rows = [comp.index(a) for a in mon]
    # robustness margin: Q_c orthonormal basis of Im(dL_c) (1-perp when one sign)
    sv_b, beta_b = svd_rank_bound(block)
    Ub, _, _ = np.linalg.svd(block)
    r_img = nc - 1 if same_sign else max(1, int(np.sum(sv_b > beta_b)))
    Q = Ub[:, :r_img]
    SQ = Q[rows, :]
    s_full = np.zeros(Q.shape[1])
    Vh = np.eye(Q.shape[1])
    if SQ.shape[0]:
        _, s, Vh = np.linalg.svd(SQ, full_matrices=True)
        s_full[: len(s)] = s
    k = int(np.argmin(s_full)) if len(s_full) else 0
    sigma = float(s_full[k]) if len(s_full) else 1.0
    info: dict[str, Any] = {"nodes": list(comp), "rank": r_img, "monitored": mon, "sigma_min": sigma}
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
    ub_s = min(len(mon), nc - 1)
    if same_sign:
        info["status"] = Status.HOLDS if len(mon) >= nc - 1 else Status.FAILS
        info["decided_by"] = "structure: one-signed link changes, rank(dL_c) = |D_c| - 1 and any |D_c| - 1 rows independent"
        info["error_bound"] = 0.0
    else:
        sv_s, beta_s = svd_rank_bound(block[rows, :]) if rows else (np.zeros(0), 0.0)
        r_s_lo = int(np.sum(sv_s > beta_s))
        r_d_lo = max(1, int(np.sum(sv_b > beta_b)))
        if r_s_lo >= nc - 1:
            info["status"] = Status.HOLDS
            info["error_bound"] = beta_s
        elif r_d_lo > ub_s:
            info["status"] = Status.FAILS
            info["error_bound"] = beta_b
        else:
            info["status"] = Status.UNDECIDED
            smallest = float(sv_s[nc - 2]) if len(sv_s) >= nc - 1 and nc >= 2 else 0.0
            info["error_bound"] = max(beta_s, beta_b)
            info["note"] = (
                f"component {list(comp)}: rank(S_M dL_c) >= {r_s_lo} and rank(dL_c) >= {r_d_lo} are certified; "
                f"singular value {smallest:.3g} of S_M dL_c is below its rounding bound {beta_s:.3g} "
                f"(and the bound {beta_b:.3g} of dL_c proves no more), so the ranks cannot be compared"
            )
    if info["status"] is Status.FAILS and SQ.shape[0] < Q.shape[1]:
        vec = Q @ Vh[-1] if SQ.shape[0] else Q[:, 0]
    elif info["status"] is Status.FAILS:
        vec = Q @ Vh[k]
    else:
        vec = None
    if vec is not None:
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

    Certainty
        Structural where possible (one-signed link changes: a count of monitors), otherwise
        certified singular values with the SVD backward-error bound
        ``beta = 10 max(m, n) eps ||M||_2 + u ||M||_F`` (:func:`svd_rank_bound`); a singular
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
        bad = [i for i in infos if i["status"] is status and status is not Status.HOLDS]
        if bad:
            b = bad[0]
            witness["failing_component" if status is Status.FAILS else "undecided_component"] = b["nodes"]
            witness["monitors_needed"] = b["rank"]
            if "vector" in b:
                witness["vector"] = b["vector"]
        if not comps:
            witness["note"] = "the mode changes no link: Im(dL_q) = {0}"
        bound = max((float(i.get("error_bound", 0.0)) for i in infos), default=0.0) if not ctx.exact else None
        note = bad[0].get("note", "") if (bad and status is Status.UNDECIDED) else ""
        out.append(
            result(
                "switching.image-kernel", ctx, status, scope={"mode": mode}, margin=margin, witness=witness,
                error_bound=bound, note=note,
            )
        )
    return out


def _rational_orthogonal_basis(basis: list[list[Fraction]]) -> list[list[Fraction]]:
    """Gram-Schmidt over Q (no normalisation): pairwise orthogonal rational vectors, same span."""
    out: list[list[Fraction]] = []
    for b in basis:
        v = list(b)
        for o in out:
            c = sum((x * y for x, y in zip(v, o)), Fraction(0)) / sum((y * y for y in o), Fraction(0))
            v = [x - c * y for x, y in zip(v, o)]
        if any(x != 0 for x in v):
            out.append(v)
    return out


def _unit_floats(v: list[Fraction]) -> np.ndarray:
    a = np.array([float(x) for x in v])
    return a / np.linalg.norm(a)


def _rational_repeated_eigenspaces(system: System, mode: str, g: ex.flint.fmpq_poly) -> list[tuple[Fraction, list[list[Fraction]]]]:
    """Rational roots of the repeated factor g with an exact orthogonal basis of their eigenspace."""
    L = system.laplacian_exact(mode)
    out = []
    num = g.numer() if hasattr(g, "numer") else g
    for fac, _m in num.factor()[1]:
        if fac.degree() != 1:
            continue
        c = fac.coeffs()
        mu = Fraction(-int(c[0]), int(c[1]))
        M = [[L[i][j] - (mu if i == j else 0) for j in range(system.n)] for i in range(system.n)]
        out.append((mu, _rational_orthogonal_basis(ex.nullspace(M))))
    return out


def _disconnection_witness(system: System, mode: str) -> dict[str, Any]:
    comps = system.components(mode)
    vecs = []
    for c in comps[:2]:
        v = [Fraction(int(lab in c)) for lab in system.labels]
        vecs.append(system.vector_by_label(v))
    return {
        "eigenvalue": 0.0,
        "eigenvalue_exact": Fraction(0),
        "multiplicity": len(comps),
        "reason": f"the {mode} graph has {len(comps)} components: the indicators of its components span ker L_q",
        "rational_eigenvectors": vecs,
        "eigenvectors": [system.vector_by_label(_unit_floats([Fraction(int(lab in c)) for lab in system.labels])) for c in comps[:2]],
    }


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
    Before it is undecided, :func:`~glocal_verify.analysis.twins.distinct_eigenvalues_modular`
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
    out = []
    for mode in system.safe_modes:
        sp = system.spectrum(mode)
        w = sp.values
        gaps = np.diff(w)
        k = int(np.argmin(gaps)) if len(gaps) else 0
        margin = float(gaps[k]) if len(gaps) else float("inf")
        rho = sp.error_radius
        closest = {"closest_pair": [k + 1, k + 2], "eigenvalues": [float(w[k]), float(w[k + 1])]} if len(gaps) else {}
        witness: dict[str, Any] = {}
        bound: float | None = None
        note = ""
        if ctx.exact:
            p = ex.charpoly(system.laplacian_exact(mode))
            if ex.is_squarefree(p):
                status = Status.HOLDS
                witness = dict(closest)
            else:
                status = Status.FAILS
                margin = 0.0
                g = ex.repeated_factor(p)
                witness = {"repeated_factor": ex.poly_str(g), "charpoly_degree": int(p.degree())}
                spaces = _rational_repeated_eigenspaces(system, mode, g)
                if spaces:
                    witness["rational_eigenspaces"] = [
                        {"eigenvalue": mu, "basis": [system.vector_by_label(b) for b in basis]} for mu, basis in spaces
                    ]
                    mu, basis = spaces[0]
                    witness["eigenvalue"] = float(mu)
                    witness["eigenvalue_exact"] = mu
                    witness["multiplicity"] = len(basis)
                    witness["eigenvectors"] = [system.vector_by_label(_unit_floats(b)) for b in basis[:2]]
        else:
            bound = 2.0 * rho
            if len(system.components(mode)) > 1:
                status = Status.FAILS
                margin = 0.0
                witness = _disconnection_witness(system, mode)
            elif all(len(c) == 1 for c in sp.clusters):
                status = Status.HOLDS
                witness = dict(closest, certified_radius=rho)
            elif (decided := distinct_eigenvalues_modular(system, mode)) is not None:
                status, witness = decided
                if status is Status.FAILS:
                    margin = 0.0
                else:
                    witness = dict(closest, **witness)
            else:
                status = Status.UNDECIDED
                c = next(c for c in sp.clusters if len(c) > 1)
                j = c[0]
                witness = {
                    "closest_pair": [j + 1, j + 2],
                    "eigenvalues": [float(w[j]), float(w[j + 1])],
                    "gap": float(w[j + 1] - w[j]),
                    "certified_radius": rho,
                }
                note = (
                    f"eigenvalues {j + 1} and {j + 2} differ by {float(w[j + 1] - w[j]):.3g}, not more than twice the "
                    f"certified rounding radius 2 rho = {bound:.3g} (Weyl): they may coincide"
                )
        if len(gaps) and sp.scale > 0 and "relative_gap" not in witness and status is not Status.FAILS:
            witness["relative_gap"] = margin / sp.scale
        out.append(
            result(
                "switching.distinct-eigenvalues", ctx, status, scope={"mode": mode}, margin=margin, witness=witness,
                error_bound=bound, note=note,
            )
        )
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


def _pairs(system: System, mode: str) -> list[tuple[Label, Label]]:
    out = []
    for comp in system.switching_components(mode):
        for a in range(len(comp)):
            for b in range(a + 1, len(comp)):
                out.append((comp[a], comp[b]))
    return out


def eigenvector_difference_polynomial(L: list[list[Fraction]], i: int, j: int) -> ex.flint.fmpq_poly:
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


_REPEATED_REASON = (
    "repeated eigenvalue: (iii) presupposes (ii); in an eigenspace of dimension >= 2 some unit "
    "eigenvector has u(i) = u(j), and an orthonormal eigenbasis U_q containing it violates (iii)"
)


def _equal_pair_vector(E: np.ndarray, i: int, j: int) -> np.ndarray:
    """A unit vector of span(E) (orthonormal columns, >= 2) with u(i) = u(j) (float)."""
    row = (E[i] - E[j])[None, :]
    _, _, Vh = np.linalg.svd(row, full_matrices=True)
    u = E @ Vh[-1]
    u = u / np.linalg.norm(u)
    return np.asarray(np.where(np.abs(u) <= 1e-14, 0.0, u))


def _exact_equal_pair_vector(basis: list[list[Fraction]], i: int, j: int) -> list[Fraction] | None:
    """A nonzero rational vector of span(basis) (>= 2 vectors) with v(i) = v(j)."""
    if len(basis) < 2:
        return None
    row = [[b[i] - b[j] for b in basis]]
    for c in ex.nullspace(row, ncols=len(basis)):
        v = [sum((cc * b[t] for cc, b in zip(c, basis)), Fraction(0)) for t in range(len(basis[0]))]
        if any(x != 0 for x in v):
            return v
    return None


def _disconnected_pair_witness(system: System, mode: str, pair: tuple[Label, Label]) -> dict[str, Any]:
    """Exact witness of a repeated eigenvalue 0 (disconnected graph): a kernel vector equal on the pair."""
    comps = system.components(mode)
    ci = next(c for c in comps if pair[0] in c)
    if pair[1] in ci:
        v = [Fraction(int(lab in ci)) for lab in system.labels]
    else:
        v = [Fraction(1)] * system.n
    return {
        "reason": _REPEATED_REASON + f" (here 0, the graph has {len(comps)} components)",
        "eigenvalue": 0.0,
        "eigenvalue_exact": Fraction(0),
        "multiplicity": len(comps),
        "pair": list(pair),
        "eigenvector": system.vector_by_label(_unit_floats(v), digits=15),
        "eigenvector_exact": system.vector_by_label(v),
        "difference": 0.0,
    }


def _eigvec_numeric(system: System, mode: str, ctx: CheckContext) -> tuple[Status, float, dict[str, Any], float | None, str]:
    """Certified numeric decision of (iii): (status, margin, witness, error bound, note)."""
    sp = system.spectrum(mode)
    w = sp.values
    n = system.n
    pairs = _pairs(system, mode)
    if not pairs:
        return Status.HOLDS, 1.0, {"note": "the mode changes no link: no pair to check"}, 0.0, ""
    if n < 2:
        return Status.HOLDS, 1.0, {"note": "a single agent"}, 0.0, ""
    idx = [tuple(system.idx(p)) for p in pairs]
    ii = np.array([a for a, _ in idx])
    jj = np.array([b for _, b in idx])
    R = sp.rows(np.concatenate([ii, jj]))  # the rows the pairs read (|M| N^2 per factor of a factored spectrum)
    D = np.abs(R[: len(ii)] - R[len(ii) :])  # pairs x N
    cols = list(range(1, n))  # l != 1
    sub = D[:, cols]
    flat = int(np.argmin(sub))
    pk, lk = divmod(flat, len(cols))
    margin = float(sub[pk, lk])
    if len(system.components(mode)) > 1:
        return Status.FAILS, 0.0, _disconnected_pair_witness(system, mode, pairs[0]), 0.0, ""
    multi = [c for c in sp.clusters if len(c) > 1]
    if multi:
        c = multi[0]
        wit = {
            "reason": "eigenvalues l and l+1 may coincide: their gap is within the certified rounding radius",
            "l": c[0] + 1,
            "eigenvalues": [float(w[c[0]]), float(w[c[0] + 1])],
            "pairs_checked": len(pairs),
        }
        note = (
            f"eigenvalues {c[0] + 1} and {c[0] + 2} differ by {float(w[c[0] + 1] - w[c[0]]):.3g} <= 2 rho = "
            f"{2 * sp.error_radius:.3g}: (ii) is not certified, so the eigenvectors are not determined"
        )
        return Status.UNDECIDED, margin, wit, 2 * sp.error_radius, note
    eta = sp.orthogonality_error
    err = np.full(n, math.inf)
    for l in cols:
        # Davis-Kahan: the exact unit eigenvector u_l (sign-aligned) has ||u_hat - u_l|| <= sqrt(2) sin + eta,
        # so the difference of two entries moves by at most sqrt(2) times that
        err[l] = 2.0 * sp.subspace_sine((l,)) + 2.0 * eta + 4.0 * _EPS + 2.0 * sp.entry_error
    worst: tuple[float, int, int] | None = None
    for l in cols:
        for p_i in range(len(pairs)):
            d = float(D[p_i, l])
            if not d > err[l]:
                slack = d - err[l]
                if worst is None or slack < worst[0]:
                    worst = (slack, p_i, l)
    if worst is not None:
        _, p_i, l = worst
        wit = {
            "pair": list(pairs[p_i]),
            "l": l + 1,
            "eigenvalue": float(w[l]),
            "entries": [float(R[p_i, l]), float(R[len(ii) + p_i, l])],
            "difference": float(D[p_i, l]),
            "error_bound": float(err[l]),
            "pairs_checked": len(pairs),
        }
        note = (
            f"|u_{l + 1}({pairs[p_i][0]}) - u_{l + 1}({pairs[p_i][1]})| = {float(D[p_i, l]):.3g} is not above its "
            f"Davis-Kahan bound {float(err[l]):.3g}: a difference that is merely small proves no equality"
        )
        return Status.UNDECIDED, margin, wit, float(err[l]), note
    l = cols[lk]
    wit = {
        "closest": {"pair": list(pairs[pk]), "l": l + 1, "eigenvalue": float(w[l]),
                    "entries": [float(R[pk, l]), float(R[len(ii) + pk, l])], "error_bound": float(err[l])},
        "pairs_checked": len(pairs),
    }
    return Status.HOLDS, margin, wit, float(np.max(err[1:])), ""


def _dyadic(x: Any) -> Fraction:
    """An exact binary rational from an arb midpoint or radius."""
    m, e = x.man_exp()
    m, e = int(m), int(e)
    return Fraction(m * 2**e) if e >= 0 else Fraction(m, 2 ** (-e))


def _eval_q(poly: ex.flint.fmpz_poly, x: Fraction) -> Fraction:
    acc = Fraction(0)
    for c in reversed(poly.coeffs()):
        acc = acc * x + int(c)
    return acc


def algebraic_root_witness(factor: ex.flint.fmpq_poly, p0: ex.flint.fmpq_poly) -> dict[str, Any]:
    """A real root of ``factor`` (a factor of ``p0``) as an algebraic number with a certified enclosure.

    The root is isolated with python-flint's ``complex_roots`` (arb ball arithmetic: each
    returned ball provably contains exactly one root), on the irreducible factor of
    ``factor`` that holds it. The enclosure ``[lo, hi]`` is then re-checked in exact rational
    arithmetic: the minimal polynomial changes sign on it. The index of the root among the
    ascending roots of ``p0`` comes from the isolated real roots of ``p0`` (all simple).

    Parameters
    ----------
    factor : fmpq_poly
        Degree >= 1, dividing ``p0``, with only real roots (a factor of a charpoly of a
        symmetric matrix).
    p0 : fmpq_poly
        Squarefree polynomial whose ascending real roots are indexed.

    Returns
    -------
    dict
        ``minimal_polynomial`` (str) with its integer ``coefficients`` (ascending powers),
        ``rational`` (the Fraction, degree 1 only),
        ``enclosure`` ([lo, hi] Fractions, ``lo < root < hi``, a point for a rational root),
        ``approx`` (float) and ``index`` (0-based position among the roots of ``p0``).
    """
    num = factor.numer()
    irreducible = sorted((f for f, _ in num.factor()[1] if f.degree() >= 1), key=lambda f: f.degree())
    f = irreducible[0]
    if f.degree() == 1:
        c = f.coeffs()
        r = Fraction(-int(c[0]), int(c[1]))
        lo = hi = r
        approx = float(r)
    else:
        prec = 64
        while True:
            with_prec = ex.flint.ctx.prec
            ex.flint.ctx.prec = prec
            try:
                roots: list[Any] = [z for z, _ in f.complex_roots()]  # type: ignore[misc, has-type]
            finally:
                ex.flint.ctx.prec = with_prec
            real = [z for z in roots if z.imag.contains(0)]
            z = min(real, key=lambda t: float(t.real.mid()))
            mid, rad = _dyadic(z.real.mid()), _dyadic(z.real.rad())
            lo, hi = mid - rad - Fraction(1, 2**prec), mid + rad + Fraction(1, 2**prec)
            if _eval_q(f, lo) * _eval_q(f, hi) < 0:
                break
            prec *= 2  # pragma: no cover - arb's enclosure was too tight for a sign change
        approx = float(mid)
        r = None
    # index among the roots of p0 (squarefree, all real): arb isolates them in disjoint balls; the
    # ball meeting [lo, hi] is the root's, and the balls below it are the smaller eigenvalues
    below = -1
    prec = 64
    while below < 0:
        saved = ex.flint.ctx.prec
        ex.flint.ctx.prec = prec
        try:
            balls: list[Any] = [zz for zz, _m in p0.numer().complex_roots()]  # type: ignore[misc, has-type]
        finally:
            ex.flint.ctx.prec = saved
        ivs = sorted((_dyadic(z.real.mid()) - _dyadic(z.real.rad()), _dyadic(z.real.mid()) + _dyadic(z.real.rad())) for z in balls)
        meet = [k for k, (a, b) in enumerate(ivs) if a <= hi and lo <= b]
        if len(meet) == 1 and all(ivs[k][1] < ivs[k + 1][0] for k in range(len(ivs) - 1)):
            below = meet[0]
        else:  # pragma: no cover - balls not yet separated at this precision
            prec *= 2
    out: dict[str, Any] = {
        "minimal_polynomial": ex.poly_str(f),
        "coefficients": [int(c) for c in f.coeffs()],
        "enclosure": [lo, hi],
        "approx": approx,
        "index": below,
    }
    if r is not None:
        out["rational"] = r
    return out


def _eigvec_exact(system: System, mode: str, numeric: tuple[Status, float, dict[str, Any], float | None, str]) -> tuple[Status, float, dict[str, Any]]:
    pairs = _pairs(system, mode)
    _, margin, nwit, _, _ = numeric
    if not pairs:
        return Status.HOLDS, 1.0, {"note": "the mode changes no link: no pair to check"}
    fast = eigenvector_differences_modular(system, mode)
    if fast is not None:
        st, fwit = fast
        if st is Status.HOLDS:
            fwit = {**fwit, "closest": nwit.get("closest")}
        return st, (margin if st is Status.HOLDS else 0.0), fwit
    L = system.laplacian_exact(mode)
    p = ex.charpoly(L)
    if not ex.is_squarefree(p):
        g = ex.repeated_factor(p)
        wit: dict[str, Any] = {"reason": _REPEATED_REASON, "repeated_factor": ex.poly_str(g), "pair": list(pairs[0])}
        i, j = system.idx(pairs[0])
        for mu, basis in _rational_repeated_eigenspaces(system, mode, g):
            v = _exact_equal_pair_vector(basis, i, j)
            if v is not None:
                wit.update(
                    eigenvalue=float(mu), eigenvalue_exact=mu, multiplicity=len(basis),
                    eigenvector=system.vector_by_label(_unit_floats(v), digits=15),
                    eigenvector_exact=system.vector_by_label(v),
                )
                return Status.FAILS, 0.0, wit
        # irrational repeated eigenvalue: the eigenvector is computed in floating point (approximate)
        sp = system.spectrum(mode)
        groups = [c for c in sp.clusters if len(c) > 1] or [
            (k, k + 1) for k in [int(np.argmin(np.diff(sp.values)))]
        ]
        c = list(groups[0])
        u = _equal_pair_vector(sp.columns(c), i, j)
        wit.update(
            eigenvalue=float(np.mean(sp.values[c])), multiplicity=len(c),
            eigenvector=system.vector_by_label(u, digits=12), eigenvector_note="floating point, approximate",
        )
        return Status.FAILS, 0.0, wit
    coeffs = p.coeffs()
    if coeffs[0] != 0:  # pragma: no cover - a Laplacian always has the eigenvalue 0
        raise AssertionError("charpoly of a Laplacian must vanish at 0")
    p0 = type(p)(coeffs[1:])  # p(mu) / mu
    sp = system.spectrum(mode)
    for a, b in pairs:
        i, j = system.idx((a, b))
        q = eigenvector_difference_polynomial(L, i, j)
        g = p0.gcd(q)
        if g.degree() >= 1:
            root = algebraic_root_witness(g, p0)
            l = int(root["index"]) + 1  # 0-based among the eigenvalues: the eigenvalue 0 comes first
            return Status.FAILS, 0.0, {
                "pair": [a, b],
                "l": l + 1,
                "eigenvalue": root["approx"],
                "eigenvalue_exact": {k: v for k, v in root.items() if k not in ("approx", "index")},
                "common_factor": ex.poly_str(g),
                "entries": [float(x) for x in sp.rows([i, j])[:, l]],
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
    with ``q_ij`` from :func:`eigenvector_difference_polynomial`,
    ``q_ij(mu_l) = p'(mu_l) (u_l(i) - u_l(j))^2`` and ``p'(mu_l) != 0``, so (iii) fails for (i, j)
    iff ``gcd(p(mu) / mu, q_ij) != 1``.

    Before the exact path, and when the numeric bound cannot decide, :func:`_eigvec_modular`
    decides exactly by an exact twin mode (fails) or by the two gcds modulo a prime (holds).

    Margin
        ``min |u_l(i) - u_l(j)|`` over ``l != 1`` and the pairs (unit eigenvectors; floating
        point in both modes), 0 on failure.
    Witness
        On failure the pair (i, j), ``l`` (1-based, ascending eigenvalues), the eigenvalue and
        the two entries; exact: also the common factor and ``eigenvalue_exact``, the
        eigenvalue as a rational or as an algebraic number (its minimal polynomial and a
        rational enclosure ``[lo, hi]`` on which it changes sign, isolated by arb ball
        arithmetic: :func:`algebraic_root_witness`). A repeated eigenvalue: the reason, the
        eigenvalue (or the repeated factor) and an eigenvector with equal entries on the pair.
        On success the closest (pair, l).
    """
    out = []
    for mode in system.safe_modes:
        num = _eigvec_numeric(system, mode, ctx)
        if ctx.exact:
            status, margin, witness = _eigvec_exact(system, mode, num)
            bound, note = None, ""
        else:
            status, margin, witness, bound, note = num
            if status is Status.UNDECIDED:
                fast = eigenvector_differences_modular(system, mode)
                if fast is not None:
                    status, witness = fast
                    margin = margin if status is Status.HOLDS else 0.0
                    note = f"{note}; decided exactly: {witness.get('reason') or witness.get('certificate')}"
        out.append(
            result(
                "switching.eigenvector-differences", ctx, status, scope={"mode": mode}, margin=margin,
                witness=witness, error_bound=bound, note=note,
            )
        )
    return out
