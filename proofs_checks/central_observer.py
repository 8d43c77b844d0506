"""The centralized observer (eq. ``obs_cent``) and its error dynamics.

Claims checked:

- eq. ``obs_cent_error``: e' = (A_1 - H C) e + (A_sigma - A_1) x + H u_s + B u_a and
  r_0 = C e - u_s = C e_bar (with u_s = C x~, which covers the covert attack and, with
  u_s = 0 and C x~ = 0, the ZDA);
- eq. ``obs_cent_error_normal``: e_bar' = (A_1 - H C) e_bar + (A_sigma - A_1) x_bar when the
  measurement is y = C x_bar;
- eq. ``obs_cent_INV_zero`` reduces to eq. ``zda_cond`` because C x~_0 = 0.

Paper error: the gain design asks A_sigma - H C Hurwitz in all modes. Under the privacy
condition of Lemma III.1 ([1; 0] in ker C and A_q [1; 0] = 0), (A_q - H C) [1; 0] = 0 for every
H: 0 is an eigenvalue for every gain, and the requirement is infeasible. What can be designed is
the observable part (step ``observable_part_assignable``).
"""

from __future__ import annotations

import sympy as sp

from ._instances import laplacian, noncomm, output_matrix, path, state_matrix
from .core import StepList
from .lemma_iii1 import generic_laplacian

__all__ = ["STEPS"]

STEPS = StepList("central_observer")
REF = "Section III-D, centralized observer"

lam = sp.Symbol("lambda")
alpha, gamma = sp.symbols("alpha gamma", positive=True)
A1, Aq, H, C, B, x, xh, xb, xt, us, ua = noncomm("A_1 A_q H C B x xhat xbar xt u_s u_a")


@STEPS.add("error_dynamics", equation="obs_cent_error", reference=REF)
def _error() -> sp.Matrix:
    """e' - [(A_1 - H C) e + (A_sigma - A_1) x + H u_s + B u_a] = 0 and r_0 - (C e - u_s) = 0 for
    x' = A_sigma x + B u_a, y = C x - u_s, x_hat' = A_1 x_hat + H (y - C x_hat) (block identity)."""
    y = C * x - us
    xdot = Aq * x + B * ua
    xhdot = A1 * xh + H * (y - C * xh)
    e = x - xh
    r0 = y - C * xh
    return sp.Matrix([xdot - xhdot - ((A1 - H * C) * e + (Aq - A1) * x + H * us + B * ua), r0 - (C * e - us)])


@STEPS.add("residual_equals_C_ebar", equation="est_error_normal, est_error, obs_cent_error", reference=REF)
def _residual() -> sp.Expr:
    """With e = e_bar + x~ (eq. ``est_error``): C e - u_s - C e_bar = -(u_s - C x~), zero by the
    attack model u_s = C~ x~ = C x~ (block identity with certificate)."""
    eb = noncomm("ebar")[0]
    e = eb + xt
    return (C * e - us) - C * eb + (us - C * xt)


@STEPS.add("attack_free_error_dynamics", equation="obs_cent_error_normal", reference=REF)
def _normal() -> sp.Expr:
    """e_bar = x_bar - x_hat with x_bar' = A_sigma x_bar and y = C x_bar:
    e_bar' - [(A_1 - H C) e_bar + (A_sigma - A_1) x_bar] = 0 (block identity)."""
    y = C * xb
    xhdot = A1 * xh + H * (y - C * xh)
    eb = xb - xh
    return Aq * xb - xhdot - ((A1 - H * C) * eb + (Aq - A1) * xb)


@STEPS.add("observer_zda_pencil_reduces", equation="obs_cent_INV_zero -> zda_cond", reference=REF)
def _pencil() -> sp.Matrix:
    """[[lam I - (A_1 - H C), -B], [C, 0]] [x~; u] - [[lam I - A_1, -B], [C, 0]] [x~; u] = [H (C x~); 0]:
    the two pencils share their zero directions because C x~ = 0 (certificate H times row 2)."""
    u0 = noncomm("u_0")[0]
    v = sp.Matrix([xt, u0])
    Pobs = sp.Matrix([[lam - (A1 - H * C), -B], [C, 0]])
    Pzda = sp.Matrix([[lam - A1, -B], [C, 0]])
    cert = sp.Matrix([H * (C * xt), 0])
    return Pobs * v - Pzda * v - cert


@STEPS.add(
    "hurwitz_requirement_infeasible",
    equation="obs_cent",
    reference=REF + ", 'A_sigma - H C (Hurwitz) stable in all modes'",
    paper_error="under Lemma III.1's privacy condition ([1; 0] in ker C), (A_q - H C)[1; 0] = 0 for every gain H: 0 is an eigenvalue in every mode, so no H makes A_sigma - H C Hurwitz",
)
def _hurwitz() -> list[sp.Expr | sp.Matrix]:
    """(A_q - H C) w_r for a generic 3 x 3 Laplacian, a symbolic 6 x 2 gain H and C = [0, C_v]
    with symbolic 2 x 3 C_v; and det(A_q - H C) for two agents, M_v = {1}, symbolic 4 x 1 H.
    Both vanish identically (minimal counterexample: two agents, one edge, M_v = {1})."""
    n = 3
    L = generic_laplacian(n)
    A = state_matrix(L, alpha, gamma)
    Cv = sp.Matrix(2, n, lambda i, j: sp.Symbol(f"c_{i + 1}{j + 1}"))
    Cm = sp.Matrix.hstack(sp.zeros(2, n), Cv)
    Hm = sp.Matrix(2 * n, 2, lambda i, j: sp.Symbol(f"h_{i + 1}{j + 1}"))
    wr = sp.Matrix([1] * n + [0] * n)
    A2 = state_matrix(laplacian(2, path(2)), alpha, gamma)
    C2 = output_matrix([], [0], 2)
    H2 = sp.Matrix(4, 1, lambda i, j: sp.Symbol(f"g_{i + 1}"))
    return [(A - Hm * Cm) * wr, sp.expand((A2 - H2 * C2).det())]


@STEPS.add("observable_part_assignable", equation="obs_cent", reference=REF)
def _assignable() -> sp.Matrix:
    """What can be designed instead: two agents, M_v = {2}: det(lam I - (A_1 - H C)) = lam q(lam)
    for every H (residual 1: the value at lam = 0), and the coefficients of q are affine in H with
    a Jacobian of rank 3 = 2N - dim N(A_1, C) (residual 2: 3 - rank), so every monic cubic q,
    Hurwitz ones included, is reached by some H."""
    A = state_matrix(laplacian(2, path(2)), sp.Integer(1), sp.Integer(1))
    Cm = output_matrix([], [1], 2)
    g = sp.symbols("g_1:5")
    Hm = sp.Matrix(4, 1, list(g))
    cp = sp.expand((lam * sp.eye(4) - (A - Hm * Cm)).det())
    q = sp.Poly(sp.cancel(cp / lam), lam)
    coeffs = q.all_coeffs()[1:]  # monic cubic: lower three coefficients
    J = sp.Matrix([[sp.diff(c, gi) for gi in g] for c in coeffs])
    hess = [sp.diff(c, gi, gj) for c in coeffs for gi in g for gj in g]
    return sp.Matrix([cp.subs(lam, 0), 3 - J.rank()] + hess)
