"""Appendix D: proof of Theorem III.3 (``th:Attack_detectability_switching``).

Block structure (eq. ``cl_sys``): A_1 = [[0, I], [-alpha L_1, -gamma I]],
dA_q = A_q - A_1 = [[0, 0], [-alpha dL, 0]], C = blkdiag(C_x, C_v). The rows of
H(dA_q) X (eq. ``H_q``, a block Toeplitz matrix) are

    row 1: C dA x = [0; -alpha C_v dL x]
    row 2: C A_1 dA x + C dA x' = [-alpha C_x dL x; alpha gamma C_v dL x - alpha C_v dL v]

so rows 1-2 vanishing give eqs. ``H_q_elements_d0``-``H_q_elements_d1``
(C_v dL x = 0, C_x dL x = 0, C_v dL v = 0), hence eq. ``H_q_elements_stack``
[C_x; C_v] dL x = 0, and with (i) dL x = 0: (i) alone does give this conclusion, from the
Toeplitz rows. The *printed* eq. ``H_q_elements`` (A_1^d in every term) is not the row of
eq. ``H_q`` and does not give the d1 line.

Then the proof concludes x_i = x_j on each D_c (eq. ``H_q_elements_kernel_1``) from "the
kernel of a connected Laplacian is span{1}": dL mixes added (+) and removed (-) links, and the
signed Laplacian of a connected component can have a larger kernel.

Finally (eqs. ``H_q_elements_new1``-``H_q_elements_new2``, Mao et al. Th. 2): for
d = e_i - e_j, d^T x_bar^{(m)} = 0 for all m is equivalent to d^T L_q^m x_bar = 0 and
d^T L_q^m v_bar = 0 for all m; under (ii)-(iii) the Krylov space of d is 1^perp and x_bar is at
consensus. The step is sound; it needs neither (ii) nor (iii) for every pair when D_c has
several pairs, so the theorem's "only if" is not supported by this proof.
"""

from __future__ import annotations

import itertools
import random

import sympy as sp

from . import _exact as X
from ._conditions import condition_i, squarefree, switch_components
from ._instances import complete, laplacian, noncomm, path, random_edges, selection, state_matrix
from .core import StepList

__all__ = ["STEPS", "position_krylov_kernel"]

STEPS = StepList("appendix_d")
REF = "Appendix D (proof of Theorem III.3)"

alpha, gamma = sp.symbols("alpha gamma")
L1, dL, Cx, Cv, x, v, a = noncomm("L_1 dL C_x C_v x v a")

A1_nc = sp.Matrix([[0, 1], [-alpha * L1, -gamma]])
dA_nc = sp.Matrix([[0, 0], [-alpha * dL, 0]])
C_nc = sp.Matrix([[Cx, 0], [0, Cv]])
X_nc = sp.Matrix([x, v])
Xd_nc = sp.Matrix([v, a])  # x' = [v; v'], v' = a free


def _rows():
    row1 = C_nc * dA_nc * X_nc
    row2 = C_nc * A1_nc * dA_nc * X_nc + C_nc * dA_nc * Xd_nc
    return row1, row2


@STEPS.add("toeplitz_row_1_gives_d0", equation="H_q, H_q_elements_d0", reference=REF)
def _d0() -> sp.Matrix:
    """Row 1 of H(dA_q) X is [0; -alpha C_v dL x]: C_v dL x = -(1/alpha) (row 1)_v, and the
    position part of row 1 is identically 0 (block identity)."""
    row1, _ = _rows()
    return sp.Matrix([row1[0], Cv * dL * x + row1[1] / alpha])


@STEPS.add("toeplitz_row_2_gives_d1", equation="H_q, H_q_elements_d1", reference=REF)
def _d1() -> sp.Matrix:
    """Row 2 = C A_1 dA x + C dA x': C_x dL x = -(1/alpha) (row 2)_x and
    C_v dL v = -(1/alpha) (row 2)_v - (gamma/alpha) (row 1)_v (block identity)."""
    row1, row2 = _rows()
    return sp.Matrix([Cx * dL * x + row2[0] / alpha, Cv * dL * v + row2[1] / alpha + gamma * row1[1] / alpha])


@STEPS.add(
    "H_q_elements_as_printed",
    equation="H_q_elements",
    reference=REF,
    expected="nonzero",
    paper_error="eq. H_q_elements has A_1^d in every term; the block rows of eq. H_q give sum_{l=0}^{d} C A_1^l dA x^(d-l) (exponent l); with the printed exponent the d = 1 equation does not give eq. H_q_elements_d1",
)
def _printed() -> sp.Matrix:
    """Printed d = 1 term C A_1 dA (x + x') minus the Toeplitz row 2 (C A_1 dA x + C dA x'):
    two agents, L_1 = dL = L(path 1-2), alpha = gamma = 1, C = e_{v1}^T, x = [1, 0],
    v = [1, 0], v' = [0, 0]: residual 2."""
    L = laplacian(2, path(2))
    A1 = state_matrix(L, sp.Integer(1), sp.Integer(1))
    dA = sp.Matrix(sp.BlockMatrix([[sp.zeros(2, 2), sp.zeros(2, 2)], [-L, sp.zeros(2, 2)]]))
    C = sp.Matrix([[0, 0, 1, 0]])
    Xv = sp.Matrix([1, 0, 1, 0])
    Xd = sp.Matrix([1, 0, 0, 0])
    printed = C * A1 * dA * (Xv + Xd)
    toeplitz = C * A1 * dA * Xv + C * dA * Xd
    return printed - toeplitz


@STEPS.add("d0_d1_with_condition_i_give_dL_x_zero", equation="H_q_elements_stack, H_q_elements_kernel", reference=REF)
def _stack() -> sp.Matrix:
    """[C_x; C_v] dL x = 0 and (i) give dL x = 0: on seeded random signed dL (N = 4..6) and
    every monitor set M with (i), nullity(S_M dL) - nullity(dL) = 0."""
    rng = random.Random(7)
    R = [sp.Integer(1), sp.Integer(-1), sp.Rational(1, 2), sp.Integer(-2)]
    diffs = []
    for _ in range(60):
        n = rng.choice([4, 5, 6])
        D = laplacian(n, random_edges(rng, n, 0.4, weights=R))
        for r in range(n + 1):
            for M in itertools.combinations(range(n), r):
                if condition_i(D, M):
                    S = selection(list(M), n)
                    k1 = n - (X.rank(S * D) if r else 0)
                    diffs.append(k1 - (n - X.rank(D)))
    assert len(diffs) > 100
    return sp.Matrix(diffs)


def signed_triangle_switch():
    """Four agents. Normal mode: (1,3) weight 1/2, (2,4) weight 2, (3,4) weight 1. Safe mode:
    add (1,2) and (2,3) (weight 1), remove (1,3). dL has the single component D_1 = {1, 2, 3}
    with signed weights +1, +1, -1/2 (1*1 + 1*(-1/2) + (-1/2)*1 = 0: rank 1); M_v = {2}."""
    R = sp.Rational
    E1 = {(0, 2): R(1, 2), (1, 3): R(2), (2, 3): R(1)}
    Eq = {(0, 1): R(1), (1, 2): R(1), (1, 3): R(2), (2, 3): R(1)}
    return laplacian(4, E1), laplacian(4, Eq), [1]


@STEPS.add(
    "component_kernel_is_span_ones",
    equation="H_q_elements_kernel_1",
    reference=REF,
    paper_error="eq. H_q_elements_kernel_1 (dL x = 0 gives x_i = x_j on each D_c) assumes the kernel of each component block is span{1}; with added and removed links in one component the signed Laplacian can have a larger kernel",
)
def _signed() -> sp.Matrix:
    """Normal mode (1,3) w 1/2, (2,4) w 2, (3,4) w 1; safe mode adds (1,2), (2,3), removes (1,3);
    both graphs connected, M_v = {2}, (i) holds (residual entry 1: dim(Im dL ∩ ker S_M) = 0),
    D_1 = {1, 2, 3}, yet dL [1, 0, -1, 0]^T = 0 (entries 2-5) with x_1 != x_3."""
    from ._conditions import intersection_dim

    L1m, Lqm, M = signed_triangle_switch()
    D = Lqm - L1m
    assert switch_components(D) == [[0, 1, 2]] and X.rank(L1m) == 3 and X.rank(Lqm) == 3
    return sp.Matrix([intersection_dim(D, M)] + list(D * sp.Matrix([1, 0, -1, 0])))


# -- the step borrowed from Mao et al. -------------------------------------------------
@STEPS.add("mao_step_position_derivatives", equation="H_q_elements_kernel__ -> H_q_elements_new1, H_q_elements_new2", reference=REF)
def _mao_cert() -> sp.Matrix:
    """With p_m = d^T (A_q^m [x; v])_pos: d^T x = p_0, d^T v = p_1,
    d^T L x = -(p_2 + gamma p_1)/alpha, d^T L v = (alpha gamma d^T L x + gamma^2 p_1 - p_3)/alpha
    (block identity; the pattern continues, see ``mao_step_kernel_exact``)."""
    L, d = noncomm("L_q d")
    A = sp.Matrix([[0, 1], [-alpha * L, -gamma]])
    Xs = sp.Matrix([x, v])
    p = []
    Y = Xs
    for _ in range(4):
        p.append(d * Y[0])
        Y = A * Y
    dLx = -(p[2] + gamma * p[1]) / alpha
    dLv = (alpha * gamma * dLx + gamma**2 * p[1] - p[3]) / alpha
    return sp.Matrix([d * x - p[0], d * v - p[1], d * L * x - dLx, d * L * v - dLv])


def position_krylov_kernel(L: sp.Matrix, pairs: list[tuple[int, int]]) -> tuple[int, int]:
    """(dim K, dim ker O_d) with K = ∩_pairs ker [d^T L^k]_{k<N} and O_d the observability matrix
    of ([d^T 0] for all pairs, A_q) (alpha = 1, gamma = 2)."""
    n = L.shape[0]
    rows = []
    for i, j in pairs:
        d = sp.zeros(1, n)
        d[i], d[j] = 1, -1
        for k in range(n):
            rows.append(d * L**k)
    K = n - X.rank(sp.Matrix.vstack(*rows))
    A = state_matrix(L, sp.Integer(1), sp.Integer(2))
    orows = []
    for i, j in pairs:
        c = sp.zeros(1, 2 * n)
        c[i], c[j] = 1, -1
        for _ in range(2 * n):
            orows.append(c)
            c = c * A
    return K, 2 * n - X.rank(sp.Matrix.vstack(*orows))


@STEPS.add("mao_step_kernel_exact", equation="H_q_elements_new1, H_q_elements_new2", reference=REF)
def _mao_exact() -> sp.Matrix:
    """For all m at once: on seeded random connected graphs and a pair d = e_1 - e_2,
    dim ker O_d = 2 dim K (x_bar and v_bar range independently over K, eqs. ``H_q_elements_new1``-
    ``H_q_elements_new2``)."""
    rng = random.Random(3)
    out = []
    for _ in range(6):
        n = rng.randint(3, 6)
        L = laplacian(n, random_edges(rng, n, 0.6))
        K, O = position_krylov_kernel(L, [(0, 1)])
        out.append(O - 2 * K)
    return sp.Matrix(out)


@STEPS.add("mao_step_consensus_under_ii_iii", equation="H_q_elements_new1 -> equib_1, equib_2", reference=REF)
def _mao_consensus() -> sp.Matrix:
    """Under (ii) and (iii) for the pair (e_1 - e_2): K = span{1}, the attack-free state is at
    consensus (seeded random connected graphs with simple spectrum; residual dim K - 1)."""
    from ._conditions import condition_iii_pair

    rng = random.Random(5)
    out: list[int] = []
    while len(out) < 6:
        n = rng.randint(3, 6)
        L = laplacian(n, random_edges(rng, n, 0.6))
        if X.rank(L) != n - 1 or not squarefree(L) or not condition_iii_pair(L, 0, 1):
            continue
        K, _ = position_krylov_kernel(L, [(0, 1)])
        out.append(K - 1)
    return sp.Matrix(out)


@STEPS.add("mao_step_fails_without_iii", equation="H_q_elements_new1 -> equib_1", reference=REF, expected="nonzero")
def _mao_no_iii() -> sp.Expr:
    """Without (iii) the step fails, as the theorem requires: path 1-2-3 and the pair (1, 3)
    (u_3 = [1, -2, 1]): dim K - 1 = 1, x_bar = u_3 is not at consensus."""
    K, _ = position_krylov_kernel(laplacian(3, path(3)), [(0, 2)])
    return sp.Integer(K - 1)


@STEPS.add(
    "mao_step_without_distinct_eigenvalues",
    equation="H_q_elements_new1 -> equib_1",
    reference=REF + "; Theorem III.3 ('only if')",
    paper_error="the step that uses (ii)-(iii) (Mao et al. Th. 2) reaches consensus without (ii) when D_c has several pairs, so the proof does not support the theorem's 'only if (i)-(iii)'",
)
def _mao_k4() -> sp.Matrix:
    """Switch from the path 1-2-3-4 to K_4 (add (1,3), (1,4), (2,4)): D_1 = {1, 2, 3, 4} and L_q
    has the triple eigenvalue 4, so (ii) fails (asserted); yet the pairs of D_1 jointly give
    K = span{1}. Residual [dim K - 1, dim ker O - 2 dim K] = 0."""
    L1m = laplacian(4, path(4))
    Lq = laplacian(4, complete(4))
    comps = switch_components(Lq - L1m)
    assert comps == [[0, 1, 2, 3]] and not squarefree(Lq)
    pairs = list(itertools.combinations(comps[0], 2))
    K, O = position_krylov_kernel(Lq, pairs)
    return sp.Matrix([K - 1, O - 2 * K])
