"""Appendix C: proof of Proposition III.2 (``prop:attack_detectability_local``), and the
rank bookkeeping around it.

The proof multiplies the pencil

.. math::

    P(\\lambda) = \\begin{bmatrix} \\lambda I - A & -B & E \\\\ C & 0 & 0 \\end{bmatrix}

on the left by M_1 = [[I - h C, lam h], [0, I], [h C, -lam h]] (eq. ``pencil_uio_pre``) and on
the right by M_2 = [[I, 0, 0], [0, I, 0], [G C A, G C B, I]] with G = (C E)^+ (eq.
``pencil_uio_post``), with h = E G, to reach
D = [[lam I - A_bar, -T B, 0], [C, 0, 0], [0, 0, E]] and eq. ``pencil_equivalance``,
rank P = rank P_bar + rank E.

What the steps establish:

- M_1 P M_2 = D holds for every lam exactly when h C E = E, i.e. under condition (ii)
  (rank(C E) = rank(E)); h C B != 0 does no harm. M_1 has a left inverse and M_2 an inverse
  for every lam, so eq. ``pencil_equivalance`` holds for all lam under (ii), and can fail
  without it.
- The printed block (3,2) of eq. ``pencil_uio_pre`` has the wrong sign (+h C B for -h C B);
  the printed post-multiplier is consistent with the correct sign (sign typo).
- Remark III.2.1's worst case B^i = [0; I] makes (iii) fail at every lam whenever the cluster
  has a boundary agent; one column per cut edge (the footnote of eq. ``E_definition``)
  contradicts "E full column rank"; the bound rank(C) <= 2k ignores the centre's own state;
  and (i) is not necessary for a UIO, contrary to Remark III.2.1's "equivalent to necessary
  and sufficient conditions".
"""

from __future__ import annotations

import random

import sympy as sp

from ._instances import laplacian, noncomm, selection, state_matrix
from .core import StepList

__all__ = ["STEPS", "pencil", "pbar", "multipliers"]

STEPS = StepList("appendix_c")
REF = "Appendix C (proof of Proposition III.2)"

lam, alpha, gamma = sp.symbols("lambda alpha gamma")
A, B, C, E, G = noncomm("A B C E G")
h = E * G
T = 1 - h * C
Abar = A - h * C * A
Hy = E * G * C * E - E  # the hypothesis h C E - E of eq. uio_conds_1 (zero under (ii))

P_nc = sp.Matrix([[lam - A, -B, E], [C, 0, 0]])
M1_nc = sp.Matrix([[1 - h * C, lam * h], [0, 1], [h * C, -lam * h]])
M2_nc = sp.Matrix([[1, 0, 0], [0, 1, 0], [G * C * A, G * C * B, 1]])
D_nc = sp.Matrix([[lam - Abar, -T * B, 0], [C, 0, 0], [0, 0, E]])


@STEPS.add("pre_multiplication", equation="pencil_uio_pre", reference=REF)
def _pre() -> sp.Matrix:
    """M_1 P equals the printed right-hand side of eq. ``pencil_uio_pre`` with block (3,2) read
    as -h C B, modulo h C E = E (blocks (1,3) and (3,3)). Block identity, any size."""
    rhs = sp.Matrix([[lam - Abar, -T * B, 0], [C, 0, 0], [-h * C * A, -h * C * B, E]])
    cert = sp.Matrix([[0, 0, -Hy], [0, 0, 0], [0, 0, Hy]])
    return M1_nc * P_nc - rhs - cert


def _single_agent_boundary_suspected():
    """One-agent cluster whose agent is both suspected and on the boundary, C = I_2."""
    Ai = state_matrix(sp.Matrix([[1]]), alpha, gamma)
    Ei = sp.Matrix([0, 1])
    Bi = sp.Matrix([0, 1])
    Cl = sp.eye(2)
    return Ai, Bi, Cl, Ei


def multipliers(Ai: sp.Matrix, Bi: sp.Matrix, Cl: sp.Matrix, Ei: sp.Matrix, l: sp.Expr = lam):
    """Exact M_1, M_2, h for an instance, with G = (C E)^+."""
    n, m, p, r = Ai.shape[0], Bi.shape[1], Cl.shape[0], Ei.shape[1]
    Gm = (Cl * Ei).pinv()
    hm = Ei * Gm
    M1 = sp.Matrix(
        sp.BlockMatrix(
            [[sp.eye(n) - hm * Cl, l * hm], [sp.zeros(p, n), sp.eye(p)], [hm * Cl, -l * hm]]
        )
    )
    M2 = sp.Matrix(
        sp.BlockMatrix(
            [
                [sp.eye(n), sp.zeros(n, m), sp.zeros(n, r)],
                [sp.zeros(m, n), sp.eye(m), sp.zeros(m, r)],
                [Gm * Cl * Ai, Gm * Cl * Bi, sp.eye(r)],
            ]
        )
    )
    return M1, M2, hm


def pencil(Ai: sp.Matrix, Bi: sp.Matrix, Cl: sp.Matrix, Ei: sp.Matrix, l: sp.Expr = lam) -> sp.Matrix:
    """P(l) of eq. ``pencil_uio``."""
    n, m, p, r = Ai.shape[0], Bi.shape[1], Cl.shape[0], Ei.shape[1]
    top = sp.Matrix.hstack(l * sp.eye(n) - Ai, -Bi, Ei)
    bottom = sp.Matrix.hstack(Cl, sp.zeros(p, m + r))
    return sp.Matrix.vstack(top, bottom)


def pbar(Ai: sp.Matrix, Bi: sp.Matrix, Cl: sp.Matrix, Ei: sp.Matrix, l: sp.Expr = lam) -> sp.Matrix:
    """P_bar(l) of eq. ``pencil_equivalance`` with h = E (C E)^+."""
    n, m, p = Ai.shape[0], Bi.shape[1], Cl.shape[0]
    hm = Ei * (Cl * Ei).pinv()
    Ab = Ai - hm * Cl * Ai
    Tm = sp.eye(n) - hm * Cl
    return sp.Matrix.vstack(sp.Matrix.hstack(l * sp.eye(n) - Ab, -Tm * Bi), sp.Matrix.hstack(Cl, sp.zeros(p, m)))


@STEPS.add(
    "pre_multiplication_printed_sign",
    equation="pencil_uio_pre",
    reference=REF,
    expected="nonzero",
    paper_error="block (3,2) of eq. pencil_uio_pre is printed as +h C B; the product gives -h C B (sign typo, harmless: eq. pencil_uio_post cancels -h C B)",
)
def _printed_sign() -> sp.Matrix:
    """Block (3,2) of M_1 P minus the printed +h C B is -2 h C B, nonzero as soon as a suspected
    agent is a measured boundary agent. Minimal instance: a one-agent cluster, agent suspected
    and on the boundary, C = I_2: residual [0; -2]."""
    Ai, Bi, Cl, Ei = _single_agent_boundary_suspected()
    M1, _M2, hm = multipliers(Ai, Bi, Cl, Ei)
    MP = M1 * pencil(Ai, Bi, Cl, Ei)
    n, m = Ai.shape[0], Bi.shape[1]
    block32 = MP[n + Cl.shape[0] :, n : n + m]
    return block32 - hm * Cl * Bi


@STEPS.add("post_multiplication_block_form", equation="pencil_uio_post", reference=REF)
def _post() -> sp.Matrix:
    """M_1 P M_2 = [[lam I - A_bar, -T B, 0], [C, 0, 0], [0, 0, E]] modulo h C E = E, with
    h = E G, G = (C E)^+ (block identity: the certificate is (E G C E - E) times
    [[-G C A, -G C B, -I], [0, 0, 0], [G C A, G C B, I]])."""
    cert = sp.Matrix(
        [
            [-Hy * G * C * A, -Hy * G * C * B, -Hy],
            [0, 0, 0],
            [Hy * G * C * A, Hy * G * C * B, Hy],
        ]
    )
    return M1_nc * P_nc * M2_nc - D_nc - cert


@STEPS.add("pre_multiplier_full_column_rank", equation="pencil_uio_pre", reference=REF)
def _left_inverse() -> sp.Matrix:
    """[[I, 0, I], [0, I, 0]] M_1 = I for every lam: the pre-multiplier has full column rank
    (the paper's claim is right)."""
    Linv = sp.Matrix([[1, 0, 1], [0, 1, 0]])
    return Linv * M1_nc - sp.eye(2)


@STEPS.add("post_multiplier_invertible", equation="pencil_uio_post", reference=REF)
def _inverse() -> sp.Matrix:
    """M_2 has the inverse [[I, 0, 0], [0, I, 0], [-G C A, -G C B, I]] (both products are I)."""
    M2inv = sp.Matrix([[1, 0, 0], [0, 1, 0], [-G * C * A, -G * C * B, 1]])
    return sp.Matrix.vstack(M2_nc * M2inv - sp.eye(3), M2inv * M2_nc - sp.eye(3))


@STEPS.add("explicit_small_blocks", equation="pencil_uio_pre, pencil_uio_post, pencil_equivalance", reference=REF)
def _explicit() -> sp.Matrix:
    """n = 2, one input, one unknown input, one output, every entry a symbol: with
    h = E (C E)^{-1} (C E a nonzero scalar), M_1 P M_2 - D cancels to 0 identically."""
    a = sp.Matrix(2, 2, lambda i, j: sp.Symbol(f"a_{i + 1}{j + 1}"))
    b = sp.Matrix(2, 1, lambda i, j: sp.Symbol(f"b_{i + 1}"))
    e = sp.Matrix(2, 1, lambda i, j: sp.Symbol(f"e_{i + 1}"))
    c = sp.Matrix(1, 2, lambda i, j: sp.Symbol(f"c_{j + 1}"))
    M1, M2, hm = multipliers(a, b, c, e)
    Ab = a - hm * c * a
    Tm = sp.eye(2) - hm * c
    D = sp.Matrix(
        sp.BlockMatrix(
            [
                [lam * sp.eye(2) - Ab, -Tm * b, sp.zeros(2, 1)],
                [c, sp.zeros(1, 1), sp.zeros(1, 1)],
                [sp.zeros(2, 2), sp.zeros(2, 1), e],
            ]
        )
    )
    return M1 * pencil(a, b, c, e) * M2 - D


def _random_instances() -> list[tuple[str, sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]]:
    """Seeded random rational instances satisfying (ii), and cluster instances of graphs."""
    rng = random.Random(314)
    R = lambda: sp.Rational(rng.randint(-4, 4), rng.randint(1, 3))  # noqa: E731
    out = []
    for k in range(6):
        n, m, r = rng.randint(3, 5), rng.randint(1, 2), rng.randint(1, 2)
        p = rng.randint(r, n)
        while True:
            Ai = sp.Matrix(n, n, lambda i, j: R())
            Bi = sp.Matrix(n, m, lambda i, j: R())
            Ei = sp.Matrix(n, r, lambda i, j: R())
            Cl = sp.Matrix(p, n, lambda i, j: R())
            if (Cl * Ei).rank() == Ei.rank():
                break
        out.append((f"random #{k} (n={n}, m={m}, r={r}, p={p})", Ai, Bi, Cl, Ei))
    # rank-deficient E (two cut edges at one agent, one column each) with (ii)
    Ai = state_matrix(sp.Matrix([[3, -1], [-1, 1]]), sp.Integer(1), sp.Integer(2))
    Ei = sp.Matrix([[0, 0], [0, 0], [1, 1], [0, 0]])
    out.append(("cluster {1,2}, two cut edges at agent 1 (E rank 1)", Ai, sp.Matrix([0, 0, 0, 1]), sp.Matrix([[1, 0, 0, 0], [0, 0, 1, 0]]), Ei))
    # the uio_error cluster
    from .uio_error import cluster_instance

    Ai, Bi, Cl, Ei, _ = cluster_instance()
    out.append(("cluster of a random 8-agent graph", Ai, Bi, Cl, Ei))
    return out


def _identity_and_ranks(Ai: sp.Matrix, Bi: sp.Matrix, Cl: sp.Matrix, Ei: sp.Matrix) -> list[sp.Matrix]:
    """[M_1 P M_2 - D (polynomial in lam), rank P - rank P_bar - rank E at sample lam]."""
    n, m, p, r = Ai.shape[0], Bi.shape[1], Cl.shape[0], Ei.shape[1]
    M1, M2, hm = multipliers(Ai, Bi, Cl, Ei)
    Ab = Ai - hm * Cl * Ai
    Tm = sp.eye(n) - hm * Cl
    D = sp.Matrix(
        sp.BlockMatrix(
            [
                [lam * sp.eye(n) - Ab, -Tm * Bi, sp.zeros(n, r)],
                [Cl, sp.zeros(p, m), sp.zeros(p, r)],
                [sp.zeros(n, n), sp.zeros(n, m), Ei],
            ]
        )
    )
    ident = (M1 * pencil(Ai, Bi, Cl, Ei) * M2 - D).applyfunc(sp.expand)
    from . import _exact as X

    ranks = []
    for l0 in (sp.Integer(0), sp.Integer(1), sp.Integer(-1), sp.Rational(1, 2), sp.Integer(-2), sp.Integer(3)):
        ranks.append(X.rank(pencil(Ai, Bi, Cl, Ei, l0)) - X.rank(pbar(Ai, Bi, Cl, Ei, l0)) - X.rank(Ei))
    return [ident, sp.Matrix(ranks)]


@STEPS.add("pencil_equivalance_random_instances", equation="pencil_equivalance", reference=REF)
def _random() -> list[sp.Matrix]:
    """Eight exact instances satisfying (ii) (six random rational, one with E of rank 1 from two
    cut edges at one agent, one graph cluster): M_1 P(lam) M_2 = D(lam) as polynomial matrices,
    and rank P - rank P_bar - rank E = 0 at lam in {0, 1, -1, 1/2, -2, 3}."""
    out: list[sp.Matrix] = []
    for _name, Ai, Bi, Cl, Ei in _random_instances():
        out.extend(_identity_and_ranks(Ai, Bi, Cl, Ei))
    return out


@STEPS.add("pencil_equivalance_with_hCB_nonzero", equation="pencil_equivalance", reference=REF)
def _hcb() -> list[sp.Matrix]:
    """h C B != 0 does not break eq. ``pencil_equivalance``: cluster {1, 2} (edge weight 1, agent 2
    with one cut edge), agent 2 suspected and on the boundary, C = I_4, alpha = 1, gamma = 2."""
    Ai = state_matrix(sp.Matrix([[1, -1], [-1, 2]]), sp.Integer(1), sp.Integer(2))
    Ei = sp.Matrix([0, 0, 0, 1])
    Bi = sp.Matrix([0, 0, 0, 1])
    Cl = sp.eye(4)
    hm = Ei * (Cl * Ei).pinv()
    assert hm * Cl * Bi != sp.zeros(4, 1)
    return _identity_and_ranks(Ai, Bi, Cl, Ei)


@STEPS.add("pencil_equivalance_needs_condition_ii", equation="pencil_equivalance", reference=REF, expected="nonzero")
def _needs_ii() -> sp.Expr:
    """Without (ii) the equation can fail: cluster {1, 2} (edge weight 1, agent 2 with one cut
    edge of weight 1), alpha = gamma = 1, E = e_{v2}, no suspected agent, C = e_{v1}^T
    (C E = 0, h = 0). At lam = 0: rank P - rank P_bar - rank E = 4 - 4 - 1 = -1 (lam = 0 is an
    invariant zero of (A, E, C))."""
    from . import _exact as X

    Ai = state_matrix(sp.Matrix([[1, -1], [-1, 2]]), sp.Integer(1), sp.Integer(1))
    Ei = sp.Matrix([0, 0, 0, 1])
    Bi = sp.zeros(4, 0)
    Cl = sp.Matrix([[0, 0, 1, 0]])
    l0 = sp.Integer(0)
    return sp.Integer(X.rank(pencil(Ai, Bi, Cl, Ei, l0)) - X.rank(pbar(Ai, Bi, Cl, Ei, l0)) - X.rank(Ei))


@STEPS.add("output_injection_equivalence", equation="obs_decent_INV_zero_1 -> obs_decent_INV_zero_2", reference=REF)
def _injection() -> sp.Matrix:
    """[[lam I - F, -T B], [C, 0]] = [[I, K_bar], [0, I]] [[lam I - A_bar, -T B], [C, 0]] with
    F = A_bar - K_bar C: the two pencils have the same kernel (block identity)."""
    Kb = noncomm("Kbar")[0]
    F = Abar - Kb * C
    left = sp.Matrix([[lam - F, -T * B], [C, 0]])
    right = sp.Matrix([[1, Kb], [0, 1]]) * sp.Matrix([[lam - Abar, -T * B], [C, 0]])
    return left - right


def _two_agent_path_cluster_one():
    """Path 1-2 split into clusters {1} and {2}; cluster {1} with worst-case B = [0; 1]."""
    Ai = state_matrix(sp.Matrix([[1]]), alpha, gamma)  # L[P,P] keeps the cut-edge degree
    Ei = sp.Matrix([0, 1])
    Bi = sp.Matrix([0, 1])
    Cl = sp.eye(2)
    return Ai, Bi, Cl, Ei


@STEPS.add(
    "worst_case_B_breaks_iii",
    equation="pencil_uio",
    reference="Remark III.2.1",
    paper_error="with the worst-case B^i = [0; I] of Remark III.2.1, (iii) fails at every lam in every cluster that has a boundary agent (columns -B e_b and E are opposite)",
)
def _worst_case() -> sp.Matrix:
    """P(lam) v = 0 identically in lam, alpha, gamma for v = [0; 0; 1; 1] (the -B column of the
    boundary agent plus the E column). Minimal instance: path 1-2, clusters {1} and {2},
    cluster {1} with B = [0; 1] (all agents suspected), E = [0; 1], C = I_2."""
    Ai, Bi, Cl, Ei = _two_agent_path_cluster_one()
    v = sp.Matrix([0, 0, 1, 1])
    return pencil(Ai, Bi, Cl, Ei) * v


@STEPS.add("degenerate_pencil_is_structural", equation="pencil_uio", reference="Appendix C, footnote on degenerate systems")
def _degenerate() -> sp.Matrix:
    """(i) and (ii) hold yet P(lam) loses rank at every lam: cluster {1, 2} with edge 1-2, agent 2
    with one cut edge, suspected and on the boundary; centre 2 has degree 2 >= 1 + 1; C = I_4.
    P v = 0 for v = [0; 0; 0; 0; 1; 1]. The paper's footnote puts 'degenerate systems' out of
    scope; this shows the degeneracy is structural whenever a suspected agent is a boundary agent."""
    Ai = state_matrix(sp.Matrix([[1, -1], [-1, 2]]), alpha, gamma)
    Ei = sp.Matrix([0, 0, 0, 1])
    Bi = sp.Matrix([0, 0, 0, 1])
    Cl = sp.eye(4)
    v = sp.Matrix([0, 0, 0, 0, 1, 1])
    return pencil(Ai, Bi, Cl, Ei) * v


@STEPS.add(
    "rank_C_at_most_2k",
    equation="measurments",
    reference=REF + ", 'k <= rank(C) <= 2k'",
    expected="nonzero",
    paper_error="rank(C_{i_i}) <= 2k fails when the centre measures its own state as well as its k neighbours' (the local observer default): rank can be 2(k+1)",
)
def _rank_c() -> sp.Expr:
    """Residual max(0, rank C - 2k) for the centre of a two-agent cluster (k = 1 neighbour)
    measuring positions and velocities of itself and its neighbour: rank C = 4 > 2 = 2k."""
    from . import _exact as X

    k = 1
    Cl = sp.eye(4)
    return sp.Integer(max(0, X.rank(Cl) - 2 * k))


@STEPS.add(
    "E_full_column_rank_with_cut_edge_columns",
    equation="E_definition",
    reference="Section III-D, footnote of eq. E_definition",
    expected="nonzero",
    paper_error="with one column of E^i per cut edge (the footnote), an agent with two cut edges gives two parallel columns: E^i is not of full column rank as eq. E_definition asserts",
)
def _e_rank() -> sp.Expr:
    """Residual (#columns - rank E) = 1 for a one-agent cluster {1} with cut edges to agents 2
    and 3 (weights a_12, a_13): E = [0, 0; -alpha a_12, -alpha a_13]."""
    a12, a13 = sp.symbols("a_12 a_13", positive=True)
    Ei = sp.Matrix([[0, 0], [-alpha * a12, -alpha * a13]])
    return sp.Integer(Ei.shape[1] - Ei.rank())


def _remark_instance():
    """Cluster {1, 2} with edge 1-2 (weight 1), agent 2 with cut edges to agents 3 and 4
    (weights 1), no suspected agent, centre 1 (degree 1) measuring itself and agent 2 (C = I_4)."""
    Li = sp.Matrix([[1, -1], [-1, 3]])
    Ai = state_matrix(Li, sp.Integer(1), sp.Integer(1))
    Ei = sp.Matrix([0, 0, 0, 1])  # one column per boundary agent (rank(E) = 1)
    Cl = sp.eye(4)
    return Ai, Cl, Ei


@STEPS.add("remark_iii21_instance_has_uio", equation="uio_conds_1-uio_conds_3, pencil_uio", reference="Remark III.2.1")
def _remark_uio() -> list[sp.Matrix]:
    """The instance of ``remark_iii21_condition_i_not_necessary`` has a UIO and satisfies (ii)
    and (iii): (h C - I) E = 0 for h = E (C E)^+, K_bar = A_bar + I gives F = -I (Hurwitz), and
    the 5 x 5 minor of P(lam) on the rows (v_2, y) has determinant 1 for every lam."""
    Ai, Cl, Ei = _remark_instance()
    hm = Ei * (Cl * Ei).pinv()
    Ab = Ai - hm * Cl * Ai
    Kbar = Ab + sp.eye(4)
    F = Ab - Kbar * Cl
    P = pencil(Ai, sp.zeros(4, 0), Cl, Ei)
    minor = P.extract([3, 4, 5, 6, 7], [0, 1, 2, 3, 4])
    return [(hm * Cl - sp.eye(4)) * Ei, F + sp.eye(4), sp.Matrix([sp.expand(minor.det()) - 1])]


@STEPS.add(
    "remark_iii21_condition_i_not_necessary",
    equation="pencil_uio",
    reference="Remark III.2.1, Proposition III.2 (i)",
    expected="nonzero",
    paper_error="(i)-(iii) are not 'equivalent to necessary and sufficient conditions' for the UIO: a UIO exists and (ii)-(iii) hold while (i), counting cut edges as stated, fails",
)
def _remark_i() -> sp.Expr:
    """Residual (cut edges + |F ∩ P_i|) - deg(centre) = 2 + 0 - 1 = 1 > 0: (i) as stated (with
    the count of cut edges) fails for the cluster of ``remark_iii21_instance_has_uio`` (agent 2
    has two cut edges). With rank(E^i) = 1 in place of the edge count it would hold: the
    paper's count is conservative, and (i) is not necessary for a UIO."""
    cut_edges, suspected, deg_centre = 2, 0, 1
    return sp.Integer(max(0, cut_edges + suspected - deg_centre))
