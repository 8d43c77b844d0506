"""Theorem III.3 (``th:Attack_detectability_switching``) as stated, Remark III.3.1 and Section IV.

Checks of the statement rather than of a proof line:

- Condition (i) is written "= emptyset"; an intersection of subspaces always contains 0, so
  read literally (i) never holds (the reading is "= {0}", i.e. rank(S_M dL) = rank(dL)).
- Remark III.3.1 says the switching discrepancy is "bounded and vanishing if" eq.
  ``unsafe_set`` holds; Section IV says that of the two switches satisfying (i)-(iii) "only case 2
  meets (unsafe_set)" and that case 2's residual is unbounded. On an exact instance with an
  unstable ZDA, a switch that avoids the attacked agents keeps the ZDA stealthy (bounded), a
  switch that touches them makes the output grow like e^{lam_0 t}; both switches satisfy
  (i)-(iii). Whatever X_q means, the two texts cannot both hold.
- The sufficiency claim for ZDAs ("if the system is not at consensus, (i)-(iii) are
  sufficient for the detection of ZDA") fails twice, each time through a gap of Appendix D:

  * an *unbounded* ZDA (lam_0 = 1, any lam_0 in fact) moving two switched agents survives a
    switch with (i)-(iii) when the switching component mixes added and removed links, whose
    signed Laplacian has a kernel larger than span{1} (eqs. ``H_q_elements_kernel_1``,
    ``ZDA_ex_5``);
  * a ZDA at lam_0 = 0 (a constant bias, invisible when M_x = ∅ as privacy requires) whose
    agents in every D_c move together survives a switch with (i)-(iii): eq. ``ZDA_ex_4``
    (x~_i = 0 for monitored i) needs lam_0 != 0.

  Both survive for every attack-free state, so the exception "at consensus" does not cover them.
"""

from __future__ import annotations

import itertools

import sympy as sp
from sympy.logic.boolalg import And, Implies, Not

from . import _exact as X
from ._conditions import condition_i, condition_iii_pair, squarefree, switch_components
from ._instances import input_matrix, laplacian, output_matrix, state_matrix
from .core import StepList
from .prop_ii4 import zda_instance_every_lambda

__all__ = ["STEPS", "zero_bias_instance"]

STEPS = StepList("theorem_iii3")
REF = "Theorem III.3"

lam, alpha, gamma = sp.symbols("lambda alpha gamma")

TOUCH = (0, 2)  # add link (1, 3): agent 1 is moved by the ZDA
AVOID = (2, 4)  # add link (3, 5): agents the ZDA does not move


def _conditions_row(L1: sp.Matrix, Lq: sp.Matrix, M: list[int]) -> list[int]:
    """[not (i), not (ii), number of pairs in the components failing (iii)]."""
    dL = Lq - L1
    comps = switch_components(dL)
    bad_iii = sum(1 for c in comps for i, j in itertools.combinations(c, 2) if not condition_iii_pair(Lq, i, j))
    return [int(not condition_i(dL, M)), int(not squarefree(Lq)), bad_iii]


def _mode(add: tuple[int, int]) -> sp.Matrix:
    L1, *_ = zda_instance_every_lambda()
    return L1 + laplacian(5, {add: sp.Integer(1)})


@STEPS.add(
    "condition_i_empty_set_literal",
    equation="cond_suff_0",
    reference=REF + " (i)",
    paper_error="condition (i) is written Im(dL) ∩ ker([C_x; C_v]) = emptyset, which never holds (0 is in both subspaces); the intended reading is = {0}",
)
def _empty() -> sp.Matrix:
    """The zero vector lies in Im(dL) (as dL 0) and in ker S_M for every switch: residual
    [dL 0; S_M 0] = 0 (path of five agents, link (1,3) added, M_v = {3})."""
    L1, *_ = zda_instance_every_lambda()
    dL = _mode(TOUCH) - L1
    S = sp.Matrix([[0, 0, 1, 0, 0]])
    z = sp.zeros(5, 1)
    return sp.Matrix.vstack(dL * z, S * dL * z)


@STEPS.add("section_iv_like_switches_meet_i_iii", equation="cond_suff_0", reference=REF + " (i)-(iii), Section IV")
def _both_meet() -> sp.Matrix:
    """Path of five agents, M_v = {3}: adding (1,3) and adding (3,5) both satisfy (i), (ii) and
    (iii) exactly (rows [not (i), not (ii), #pairs failing (iii)] are zero), like Section IV's
    cases 1 and 2."""
    L1, *_ = zda_instance_every_lambda()
    return sp.Matrix([_conditions_row(L1, _mode(TOUCH), [2]), _conditions_row(L1, _mode(AVOID), [2])])


@STEPS.add("avoiding_switch_keeps_zda", equation="unsafe_set, obs_cent_INV_zero_3", reference="Remark III.3.1")
def _avoid() -> sp.Matrix:
    """ZDA of ``prop_ii4.zda_for_every_lambda_when_not_left_invertible`` (x~_0 = [e_1; lam e_1],
    F = {1, 2}, M_v = {3}). After adding (3,5): dA_q x~_0 = 0 and (x~_0, u_0) is still a
    zeroing direction of (A_q, B, C), identically in lam, alpha, gamma: the discrepancy is
    bounded and vanishing, the attack stays stealthy."""
    L1, A1, B, C, x0, u0 = zda_instance_every_lambda()
    Aq = state_matrix(_mode(AVOID), alpha, gamma)
    pencil = sp.Matrix.vstack(sp.Matrix.hstack(lam * sp.eye(10) - Aq, -B), sp.Matrix.hstack(C, sp.zeros(1, 2)))
    return sp.Matrix.vstack((Aq - A1) * x0, pencil * sp.Matrix.vstack(x0, u0))


def _touch_growth() -> sp.Matrix:
    """C (lam I - A_q)^{-1} B u_0 at lam = 1, alpha = gamma = 1 after adding (1,3)."""
    _L1, _A1, B, C, x0, u0 = zda_instance_every_lambda()
    subs = {lam: 1, alpha: 1, gamma: 1}
    Aq = state_matrix(_mode(TOUCH), sp.Integer(1), sp.Integer(1))
    M = sp.eye(10) - Aq
    assert M.det() != 0
    return C * M.inv() * B * u0.subs(subs)


@STEPS.add("touching_switch_unbounded_residual", equation="unsafe_set, obs_cent_error", reference="Remark III.3.1", expected="nonzero")
def _touch() -> sp.Matrix:
    """After adding (1,3), the unstable ZDA (lam_0 = 1, alpha = gamma = 1) forces the particular
    response x_p(t) = (I - A_q)^{-1} B u_0 e^t; its output coefficient C x_p(0) is nonzero while
    the homogeneous part stays bounded (A_q: simple eigenvalue 0, the others in the open left
    half-plane): the
    output, hence the residual, grows like e^t."""
    return _touch_growth()


@STEPS.add(
    "remark_iii31_vs_section_iv",
    equation="unsafe_set",
    reference="Remark III.3.1 vs Section IV",
    paper_error="Remark III.3.1 says meeting (unsafe_set) makes the switching discrepancy bounded and vanishing; Section IV says case 2 meets (unsafe_set) and its residual is unbounded: no definition of X_q makes both true (exact computation: the switch touching the ZDA is the unbounded one)",
)
def _contradiction() -> sp.Integer:
    """Residual: the number of truth values of 'the unbounded switch meets (unsafe_set)'
    consistent with both texts, given that the touching switch's residual is unbounded
    (``touching_switch_unbounded_residual``): 0. The exact computation supports the Remark's
    mechanism under the reading X_q ∩ Z = ∅ <=> the switch avoids the attacked agents."""
    bounded = all(e == 0 for e in _touch_growth())
    meets = sp.Symbol("meets")
    remark = Implies(meets, bounded)
    section_iv = And(meets, Not(bounded))
    return sp.Integer(sum(1 for m in (True, False) if bool((remark & section_iv).subs(meets, m))))


def zero_bias_instance():
    """Star with hub 2: edges (1,2) w 1, (2,3) w 2, (2,4) w 1, (2,5) w 2; F = {1, 2, 3};
    M_x = ∅, M_v = {1, 4}; the switch adds (1,3) and (4,5); xi = [1/2, 0, 1/2, 0, 0],
    u_0 = alpha [1/2, -3/2, 1], lam_0 = 0."""
    R = sp.Rational
    L1 = laplacian(5, {(0, 1): R(1), (1, 2): R(2), (1, 3): R(1), (1, 4): R(2)})
    Lq = L1 + laplacian(5, {(0, 2): R(1), (3, 4): R(1)})
    F, Mv = [0, 1, 2], [0, 3]
    xi = sp.Matrix([R(1, 2), 0, R(1, 2), 0, 0])
    u0 = alpha * sp.Matrix([R(1, 2), R(-3, 2), 1])
    return L1, Lq, F, Mv, xi, u0


def signed_switch_zda():
    """The switch of ``appendix_d.signed_triangle_switch`` (D_1 = {1, 2, 3}, signed weights
    +1, +1, -1/2, M_v = {2}, M_x = ∅) with F = {1, 3, 4} and the ZDA x~_0 = [xi; lam xi],
    xi = [1, 0, -1, 0] (in ker dL, xi_2 = 0), u_0 = ((lam^2 + gamma lam) I + alpha L_1) xi on F."""
    from .appendix_d import signed_triangle_switch

    L1, Lq, Mv = signed_triangle_switch()
    F = [0, 2, 3]
    xi = sp.Matrix([1, 0, -1, 0])
    full = ((lam**2 + gamma * lam) * sp.eye(4) + alpha * L1) * xi
    assert full[1] == 0
    u0 = full.extract(F, [0])
    return L1, Lq, F, Mv, xi, u0


@STEPS.add("signed_switch_meets_i_iii", equation="cond_suff_0", reference=REF + " (i)-(iii)")
def _signed_conditions() -> sp.Matrix:
    """The signed switch of ``unbounded_zda_survives_signed_switch`` satisfies (i), (ii), (iii),
    and both graphs are connected (residual [not (i), not (ii), #pairs failing (iii),
    3 - rank L_1, 3 - rank L_q])."""
    L1, Lq, _F, Mv, _xi, _u0 = signed_switch_zda()
    return sp.Matrix(_conditions_row(L1, Lq, Mv) + [3 - X.rank(L1), 3 - X.rank(Lq)])


@STEPS.add(
    "unbounded_zda_survives_signed_switch",
    equation="zda_cond, H_q_elements_kernel_1, ZDA_ex_5",
    reference=REF + " (sufficiency for ZDA); Appendix D",
    paper_error="an unbounded ZDA (any lam_0, e.g. 1) moving agents 1 and 3 of D_1 survives a switch meeting (i)-(iii) because the component mixes added and removed links (signed kernel larger than span{1}): (i)-(iii) are not sufficient for ZDA detection",
)
def _signed_survives() -> sp.Matrix:
    """Residual [(lam I - A_1) x~_0 - B u_0; (lam I - A_q) x~_0 - B u_0; C x~_0] = 0 identically
    in lam, alpha, gamma (four agents, F = {1, 3, 4}, M_v = {2}): the ZDA is a zeroing direction in
    both modes, so for lam = 1 the states grow like e^t while the output keeps its attack-free
    value, whatever the attack-free state."""
    L1, Lq, F, Mv, xi, u0 = signed_switch_zda()
    A1 = state_matrix(L1, alpha, gamma)
    Aq = state_matrix(Lq, alpha, gamma)
    B = input_matrix(F, 4)
    C = output_matrix([], Mv, 4)
    x0 = sp.Matrix.vstack(xi, lam * xi)
    return sp.Matrix.vstack(lam * x0 - A1 * x0 - B * u0, lam * x0 - Aq * x0 - B * u0, C * x0)


@STEPS.add("zero_bias_instance_meets_i_iii", equation="cond_suff_0", reference=REF + " (i)-(iii)")
def _zb_conditions() -> sp.Matrix:
    """The switch of ``zda_at_zero_survives_switch`` satisfies (i), (ii) and (iii) exactly, and
    both graphs are connected (residual [not (i), not (ii), #pairs failing (iii), 4 - rank L_1,
    4 - rank L_q])."""
    L1, Lq, _F, Mv, _xi, _u0 = zero_bias_instance()
    return sp.Matrix(_conditions_row(L1, Lq, Mv) + [4 - X.rank(L1), 4 - X.rank(Lq)])


@STEPS.add("zero_bias_moves_switched_agents", equation="ZDA_ex_4, zda_simp", reference="Appendix D", expected="nonzero")
def _zb_moves() -> sp.Expr:
    """The ZDA moves the switched agents: x~_1 - x~_4 = 1/2 != 0 (agents 1, 3 of D_1 by 1/2,
    agents 4, 5 of D_2 by 0), so no unobservable shift c 1 puts both components at rest and
    eq. ``zda_simp`` (x~ = 0 on every D_c) fails; eq. ``ZDA_ex_4`` fails for monitored agent 1."""
    *_, xi, _u0 = zero_bias_instance()
    return xi[0] - xi[3]


@STEPS.add(
    "zda_at_zero_survives_switch",
    equation="zda_cond, ZDA_ex_4",
    reference=REF + " (sufficiency for ZDA); Appendix D eq. ZDA_ex_4",
    paper_error="a ZDA at lam_0 = 0 (constant bias; M_x = ∅) moving the agents of each D_c together stays a zeroing direction of (A_q, B, C) after a switch meeting (i)-(iii), for any attack-free state: (i)-(iii) are not sufficient; eq. ZDA_ex_4 assumes lam_0 != 0",
)
def _zb_survives() -> sp.Matrix:
    """Residual [(0 I - A_1) x~_0 - B u_0; (0 I - A_q) x~_0 - B u_0; C x~_0] = 0 identically in
    alpha, gamma, with x~_0 = [xi; 0] (instance of ``zero_bias_instance``): the ZDA is stealthy
    before and after the switch."""
    L1, Lq, F, Mv, xi, u0 = zero_bias_instance()
    A1 = state_matrix(L1, alpha, gamma)
    Aq = state_matrix(Lq, alpha, gamma)
    B = input_matrix(F, 5)
    C = output_matrix([], Mv, 5)
    x0 = sp.Matrix.vstack(xi, sp.zeros(5, 1))
    return sp.Matrix.vstack(-A1 * x0 - B * u0, -Aq * x0 - B * u0, C * x0)
