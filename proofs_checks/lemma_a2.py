"""Lemma A.2 (``lemma:app_component_measur``) and the eigenvector-difference identity.

Lemma A.2: under Theorem III.3 (i) (read as Im(dL) ∩ ker S_M = {0}, eq. ``cond_suff_0``)
every component D_c of the switching graph contains a monitored agent
(eq. ``app_component_measurements``). Proof idea (eq. ``app_contra``): after the permutation
of eq. ``graph_component_lap`` dL is block diagonal; if D_c ∩ M = ∅ the columns of the
block dL(D_c) are nonzero vectors of Im(dL) killed by S_M.

Identity (CONDITIONS.md, used for the exact test of (iii)): with
q_ij(mu) = (e_i - e_j)^T adj(mu I - L) (e_i - e_j) and a simple eigenvalue mu_l with unit
eigenvector u_l of a symmetric L,

.. math::

    q_{ij}(\\mu_l) = p'(\\mu_l)\\,(u_l(i) - u_l(j))^2 .

Proof: (mu I - L) adj(mu I - L) = p(mu) I puts the columns of adj(mu_l I - L) in the
eigenspace span{u_l}, so adj(mu_l I - L) = kappa u_l u_l^T (it is symmetric); Jacobi's formula
tr adj(mu I - L) = p'(mu) gives kappa = p'(mu_l).
"""

from __future__ import annotations

import itertools
import random

import flint
import sympy as sp

from . import _exact as X
from ._conditions import adjugate_poly_matrix, charpoly, condition_i, intersection_dim, q_ij, switch_components
from ._instances import laplacian, noncomm, path, random_edges
from .core import StepList

__all__ = ["STEPS"]

STEPS = StepList("lemma_a2")
REF = "Appendix A, Lemma A.2 and its proof"
REF_ID = "CONDITIONS.md, switching.eigenvector-differences"

mu = sp.Symbol("mu")
MU = flint.fmpq_poly([0, 1])


@STEPS.add("uncovered_component_violates_i", equation="app_contra, cond_suff_0_invariant", reference=REF)
def _block() -> sp.Matrix:
    """After the permutation, dL = blkdiag(L_c, L_r) and, if D_c ∩ M = ∅, S_M P^T = [0, S_r]:
    S_M dL [u; 0] = 0 for every u (block identity), while dL [u; 0] = [L_c u; 0] is nonzero for
    some u because L_c has nonzero off-diagonal entries; so Im(dL) ∩ ker S_M != {0}."""
    Lc, Lr, Sr, u = noncomm("L_c L_r S_r u")
    dLb = sp.Matrix([[Lc, 0], [0, Lr]])
    S = sp.Matrix([[0, Sr]])
    return S * dLb * sp.Matrix([u, 0])


def _signed_switches(seed: int = 99, count: int = 120) -> list[sp.Matrix]:
    """Random switching Laplacians dL (signed weights: added and removed links, weight changes)."""
    rng = random.Random(seed)
    R = [sp.Integer(1), sp.Integer(-1), sp.Rational(1, 2), sp.Rational(-1, 2), sp.Integer(2), sp.Rational(-3, 2)]
    out = []
    for _ in range(count):
        n = rng.choice([4, 5, 6])
        edges = random_edges(rng, n, rng.choice([0.2, 0.35, 0.5]), weights=R)
        if edges:
            out.append(laplacian(n, edges))
    return out


@STEPS.add("condition_i_implies_coverage", equation="cond_suff_0 -> app_component_measurements", reference=REF)
def _coverage() -> sp.Matrix:
    """Exhaustive over monitor sets: for 120 seeded random signed dL (N = 4..6) and every
    M ⊆ V, the residual counts the pairs (dL, M) where (i) holds and some D_c misses M: 0."""
    bad = 0
    holds = 0
    for dL in _signed_switches():
        n = dL.shape[0]
        comps = switch_components(dL)
        for r in range(n + 1):
            for M in itertools.combinations(range(n), r):
                if condition_i(dL, M):
                    holds += 1
                    if any(not set(c) & set(M) for c in comps):
                        bad += 1
    assert holds > 100, "too few instances satisfy (i) to test the lemma"
    return sp.Matrix([bad])


@STEPS.add("intersection_dimension_formula", equation="cond_suff_0", reference=REF)
def _dimension() -> sp.Matrix:
    """dim(Im dL ∩ ker S_M) = rank dL - rank(S_M dL) on the same instances with M the first
    agent, the first two, ... (so (i) is exactly rank(S_M dL) = rank(dL))."""
    diffs = []
    for dL in _signed_switches():
        n = dL.shape[0]
        for r in range(n + 1):
            M = list(range(r))
            S = sp.Matrix(r, n, lambda a, b: 1 if a == b else 0)
            diffs.append(intersection_dim(dL, M) - (X.rank(dL) - (X.rank(S * dL) if r else 0)))
    return sp.Matrix(diffs)


@STEPS.add("coverage_does_not_imply_i", equation="cond_suff_0", reference=REF, expected="nonzero")
def _converse() -> sp.Expr:
    """The converse fails: a switch adding the path 1-2-3 (one component, rank 2) with only
    agent 1 monitored is covered, yet dim(Im dL ∩ ker S_M) = 1 (a component of rank
    |D_c| - 1 needs |D_c| - 1 monitors)."""
    dL = laplacian(3, path(3))
    assert switch_components(dL) == [[0, 1, 2]]
    return sp.Integer(intersection_dim(dL, [0]))


@STEPS.add(
    "former_dichotomy",
    equation="former, H_q_elements_kernel",
    reference=REF + "; Appendix D",
    paper_error="eq. former ('dL x not in Im(dL) iff dL x = 0') is false: dL x is always in Im(dL), and 0 = dL 0 is in Im(dL), so the left side never holds while the right side does for x in ker dL",
)
def _former() -> sp.Matrix:
    """For x in ker dL the right side holds, but 0 = dL x = dL 0 lies in Im(dL): residual
    [dL x; dL 0] = 0 exhibits it (dL: one added link between agents 1 and 2, x = [1, 1])."""
    dL = laplacian(2, path(2))
    x = sp.Matrix([1, 1])
    return sp.Matrix.vstack(dL * x, dL * sp.zeros(2, 1))


# -- eigenvector-difference identity ------------------------------------------------------
def _generic_symmetric(n: int) -> sp.Matrix:
    return sp.Matrix(n, n, lambda i, j: sp.Symbol(f"l_{min(i, j) + 1}{max(i, j) + 1}"))


@STEPS.add("jacobi_trace_formula", equation="switching.eigenvector-differences", reference=REF_ID)
def _jacobi() -> sp.Expr:
    """tr adj(mu I - L) = d/dmu det(mu I - L) for a generic symmetric 4 x 4 L (fixes kappa = p'(mu_l))."""
    M = mu * sp.eye(4) - _generic_symmetric(4)
    return M.adjugate().trace() - sp.diff(M.det(), mu)


@STEPS.add("adjugate_columns_in_eigenspace", equation="switching.eigenvector-differences", reference=REF_ID)
def _adj_kernel() -> sp.Matrix:
    """(mu I - L) adj(mu I - L) = p(mu) I for a generic symmetric 4 x 4 L: at a root mu_l the
    columns of the adjugate lie in ker(mu_l I - L) = span{u_l} (simple eigenvalue)."""
    M = mu * sp.eye(4) - _generic_symmetric(4)
    return M * M.adjugate() - M.det() * sp.eye(4)


@STEPS.add("identity_spectral_3x3", equation="switching.eigenvector-differences", reference=REF_ID)
def _spectral() -> list[sp.Basic]:
    """L = U diag(m_1, m_2, m_3) U^T with a rational orthogonal U (Cayley transform of a
    rational skew matrix) and symbolic eigenvalues: adj(m_1 I - L) - p'(m_1) u_1 u_1^T = 0 and
    q_13(m_1) - p'(m_1) (u_1(1) - u_1(3))^2 = 0."""
    m1, m2, m3 = sp.symbols("m_1 m_2 m_3")
    S = sp.Matrix([[0, -sp.Rational(1, 2), -1], [sp.Rational(1, 2), 0, -sp.Rational(1, 3)], [1, sp.Rational(1, 3), 0]])
    U = (sp.eye(3) - S) * (sp.eye(3) + S).inv()
    assert U * U.T == sp.eye(3)
    L = U * sp.diag(m1, m2, m3) * U.T
    p = (mu - m1) * (mu - m2) * (mu - m3)
    dp = sp.diff(p, mu).subs(mu, m1)
    u1 = U[:, 0]
    adj = (m1 * sp.eye(3) - L).adjugate()
    d = sp.Matrix([1, 0, -1])
    q13 = (d.T * adj * d)[0, 0]
    return [adj - dp * u1 * u1.T, q13 - dp * (u1[0] - u1[2]) ** 2]


def _connected_squarefree(seed: int = 4242, count: int = 14) -> list[sp.Matrix]:
    rng = random.Random(seed)
    out: list[sp.Matrix] = []
    while len(out) < count:
        n = rng.randint(4, 7)
        L = laplacian(n, random_edges(rng, n, 0.55))
        if X.rank(L) != n - 1:
            continue
        p = charpoly(L)
        if p.gcd(p.derivative()).degree() > 0:
            continue
        out.append(L)
    return out


@STEPS.add("identity_random_graphs_exact", equation="switching.eigenvector-differences", reference=REF_ID)
def _identity_random() -> sp.Matrix:
    """On 14 seeded random connected graphs (N = 4..7, rational weights, simple spectrum), for
    every irreducible factor f of p and every pair i < j, with a = adj(mu I - L) e_k (k chosen so
    that a_k != 0 mod f): (mu I - L) a = 0 mod f and q_ij a^T a - p' (a_i - a_j)^2 = 0 mod f,
    i.e. the identity holds at every eigenvalue (all residuals are polynomials reduced mod f)."""
    out: list[sp.Expr] = []
    for L in _connected_squarefree():
        n = L.shape[0]
        p = charpoly(L)
        dp = p.derivative()
        adj = adjugate_poly_matrix(L)
        Lq = X.qmat(L)
        _, facs = p.factor()
        for f, _m in facs:
            k = next(c for c in range(n) if adj[c][c] % f != 0)
            a = [adj[r][k] for r in range(n)]
            for r in range(n):  # (mu I - L) a
                v = MU * a[r] - sum((a[c] * Lq[r, c] for c in range(n)), flint.fmpq_poly([0]))
                out.append(X.qpoly_to_sympy(v % f, mu))
            ata = sum((x * x for x in a), flint.fmpq_poly([0]))
            for i, j in itertools.combinations(range(n), 2):
                q = adj[i][i] + adj[j][j] - adj[i][j] - adj[j][i]
                assert q == q_ij(L, i, j) if (i, j) == (0, 1) else True
                out.append(X.qpoly_to_sympy((q * ata - dp * (a[i] - a[j]) ** 2) % f, mu))
    return sp.Matrix(out)


@STEPS.add("gcd_criterion_path3", equation="switching.eigenvector-differences", reference=REF_ID)
def _path3() -> sp.Matrix:
    """Path 1-2-3 (eigenvalues 0, 1, 3; u_3 = [1, -2, 1]): gcd(p/mu, q_13) = mu - 3 (pair (1, 3)
    fails (iii) at mu = 3, where u_3(1) = u_3(3)), gcd(p/mu, q_12) = 1. Residual: the coefficients
    of gcd_13 - (mu - 3), the degree of gcd_12, and (L - 3 I) u_3."""
    L = laplacian(3, path(3))
    p = charpoly(L) // MU
    g13 = p.gcd(q_ij(L, 0, 2))
    g12 = p.gcd(q_ij(L, 0, 1))
    r13 = X.qpoly_to_sympy(g13 * (1 / g13.leading_coefficient()), mu) - (mu - 3)
    return sp.Matrix([sp.expand(r13), g12.degree()] + list((L - 3 * sp.eye(3)) * sp.Matrix([1, -2, 1])))
