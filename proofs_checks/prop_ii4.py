"""Proposition II.4 (``propo:stealthy_attacks``): covert attack and zero-dynamics attack.

Covert attack (eqs. ``ym_solution``-``covert_trajec_post``): with the attacker's model equal
to the true one (Assumption II.1 (i)), subtracting eq. ``us_solution`` from eq. ``ym_solution``
leaves eq. ``ym_solution_final``, y(t) = C e^{A_1 (t - t_a)} (x(t_a) - x~(t_a)).

ZDA (eqs. ``zda_cond``, ``zda_trajec``): a zeroing direction (x~_0, u_0) of
(A_1, B, C, 0) gives x(t) = x_bar(t) + x~_0 e^{lam_0 t} and y = C x_bar.

Symbolic steps use non-commutative blocks (any size); concrete steps use small exact
instances (rational eigenvalues, so exponentials are exact).
"""

from __future__ import annotations

import sympy as sp

from ._instances import input_matrix, laplacian, noncomm, output_matrix, path, state_matrix
from .core import StepList

__all__ = ["STEPS", "zda_instance_every_lambda"]

STEPS = StepList("prop_ii4")
REF = "Proposition II.4 and its proof"

t, tau = sp.symbols("t tau", real=True)
lam, alpha, gamma = sp.symbols("lambda alpha gamma")


@STEPS.add("covert_output_cancellation", equation="ym_solution, us_solution -> ym_solution_final", reference=REF)
def _covert_cancel() -> sp.Expr:
    """y - C Phi (x_a - x~_a) = 0 after substituting the attacker's model (C~, Phi~, J~) = (C, Phi, J).

    Phi = e^{A_1 (t - t_a)} and J = int_{t_a}^t e^{A_1 (t - tau)} B u_a(tau) dtau are opaque
    blocks; the cancellation is exact block algebra.
    """
    C, Phi, J, xa, xta, Ct, Phit, Jt = noncomm("C Phi J x_a xt_a Ct Phit Jt")
    us = Ct * Phit * xta + Ct * Jt  # eq. us_solution
    y = C * Phi * xa + C * J - us  # eq. ym_solution
    y = y.subs({Ct: C, Phit: Phi, Jt: J})  # Assumption II.1 (i)
    return y - C * Phi * (xa - xta)


def _p2():
    """Two agents, alpha = 1, gamma = 3: eigenvalues of A are 0, -3, -1, -2 (exact exponentials)."""
    Lm = laplacian(2, path(2))
    A = state_matrix(Lm, sp.Integer(1), sp.Integer(3))
    return Lm, A


@STEPS.add("covert_trajectory_solves_system", equation="covert_trajec, covert_trajec_post", reference=REF)
def _covert_traj() -> sp.Matrix:
    """x~(t) = int_0^t e^{A (t - tau)} B u_a(tau) dtau solves x~' = A x~ + B u_a, x~(0) = 0, so
    x = x_bar + x~ solves the attacked system with x(0) = x_bar(0) (two agents, F = {1},
    u_a(tau) = tau, exact integral)."""
    _, A = _p2()
    B = input_matrix([0], 2)
    ua = tau
    Phi = (A * (t - tau)).exp()
    xt = (Phi * B * ua).applyfunc(lambda e: sp.integrate(sp.expand(e), (tau, 0, t)))
    ode = xt.diff(t) - A * xt - B * ua.subs(tau, t)
    return sp.Matrix.vstack(ode, xt.subs(t, 0))


@STEPS.add("covert_unobservable_start", equation="ym_solution_final", reference=REF)
def _covert_unobs() -> sp.Matrix:
    """x~(t_0) in ker O_1 gives C e^{A_1 t} x~(t_0) = 0: two agents, M_v = {1}, x~(t_0) = [1, 1, 0, 0]."""
    _, A = _p2()
    C = output_matrix([], [0], 2)
    return C * (A * t).exp() * sp.Matrix([1, 1, 0, 0])


@STEPS.add(
    "covert_needs_reached_channels_in_F_s",
    equation="attack_model, ym_solution",
    reference=REF,
    expected="nonzero",
)
def _covert_channels() -> sp.Matrix:
    """u_s = C x~ must be injected on every monitored channel u_a reaches: two agents,
    F = {1}, M_v = {2}; the Markov parameters (C A^k B)_{k<4} are not all zero (C A^2 B = alpha),
    so the sensor of agent 2 must be in F_s (the proposition leaves this implicit)."""
    A = state_matrix(laplacian(2, path(2)), alpha, gamma)
    B = input_matrix([0], 2)
    C = output_matrix([], [1], 2)
    return sp.Matrix.vstack(*[C * A**k * B for k in range(4)])


@STEPS.add("zda_direction_parametrisation", equation="zda_cond", reference=REF)
def _zda_param() -> sp.Matrix:
    """x~_0 = [xi; lam xi] with (s I + alpha L) xi = S_F^T u_0, s = lam^2 + gamma lam, solves the
    first block row of eq. ``zda_cond``; C x~_0 = [S_x xi; lam S_v xi] (block identity).

    Residual: [(lam I - A) x~_0 - B u_0 - [0; h]; C x~_0 - [S_x xi; lam S_v xi]] with
    h = (s I + alpha L) xi - S_F^T u_0 the hypothesis.
    """
    L, SFt, Sx, Sv, xi, u0 = noncomm("L S_F^T S_x S_v xi u_0")
    A = sp.Matrix([[0, 1], [-alpha * L, -gamma]])
    B = sp.Matrix([0, SFt])
    C = sp.Matrix([[Sx, 0], [0, Sv]])
    x0 = sp.Matrix([xi, lam * xi])
    h = (lam**2 + gamma * lam) * xi + alpha * L * xi - SFt * u0
    first = lam * x0 - A * x0 - B * u0 - sp.Matrix([0, h])
    second = C * x0 - sp.Matrix([Sx * xi, lam * Sv * xi])
    return sp.Matrix.vstack(first, second)


@STEPS.add("zda_output_identity", equation="zda_trajec", reference=REF)
def _zda_identity() -> sp.Matrix:
    """x = x_bar + x~_0 e^{lam t} solves x' = A x + B u_0 e^{lam t} and y = C x_bar, modulo
    (lam I - A) x~_0 = B u_0, C x~_0 = 0, x_bar' = A x_bar (block identity, any size)."""
    A, B, C, x0, u0, xb = noncomm("A B C xt_0 u_0 xbar")
    e = sp.exp(lam * t)
    x = xb + e * x0
    xdot = A * xb + sp.diff(e, t) * x0  # x_bar' = A x_bar
    hyp_state = lam * x0 - A * x0 - B * u0
    hyp_out = C * x0
    r_state = xdot - (A * x + B * u0 * e) - e * hyp_state
    r_out = C * x - C * xb - e * hyp_out
    return sp.Matrix([r_state, r_out])


@STEPS.add("zda_concrete_instance", equation="zda_cond, zda_trajec", reference=REF)
def _zda_concrete() -> sp.Matrix:
    """Path 1-2-3, F = {2}, M_v = {1}, alpha = 2, gamma = 3: lam_0 = -1, x~_0 = [e_3; -e_3],
    u_0 = -2 is a zeroing direction; x~_0 e^{lam_0 t} solves the attacked dynamics with zero output."""
    A = state_matrix(laplacian(3, path(3)), sp.Integer(2), sp.Integer(3))
    B = input_matrix([1], 3)
    C = output_matrix([], [0], 3)
    l0 = sp.Integer(-1)
    x0 = sp.Matrix([0, 0, 1, 0, 0, l0])
    u0 = sp.Matrix([-2])
    pencil = sp.Matrix.vstack(sp.Matrix.hstack(l0 * sp.eye(6) - A, -B), sp.Matrix.hstack(C, sp.zeros(1, 1)))
    traj = x0 * sp.exp(l0 * t)
    ode = traj.diff(t) - A * traj - B * u0 * sp.exp(l0 * t)
    return sp.Matrix.vstack(pencil * sp.Matrix.vstack(x0, u0), ode, C * traj)


def zda_instance_every_lambda():
    """Path 1-..-5, F = {1, 2}, M_v = {3}, M_x = {}: x~_0 = [e_1; lam e_1],
    u_0 = [lam^2 + gamma lam + alpha, -alpha] is a zeroing direction for every lam."""
    n = 5
    Lm = laplacian(n, path(n))
    A = state_matrix(Lm, alpha, gamma)
    B = input_matrix([0, 1], n)
    C = output_matrix([], [2], n)
    e1 = sp.Matrix([1, 0, 0, 0, 0])
    x0 = sp.Matrix.vstack(e1, lam * e1)
    u0 = sp.Matrix([lam**2 + gamma * lam + alpha, -alpha])
    return Lm, A, B, C, x0, u0


@STEPS.add("zda_for_every_lambda_when_not_left_invertible", equation="zda_cond", reference=REF)
def _zda_every() -> sp.Matrix:
    """Path of 5 agents, F = {1, 2}, M_v = {3}: (x~_0, u_0) = ([e_1; lam e_1],
    [lam^2 + gamma lam + alpha; -alpha]) satisfies eq. ``zda_cond`` identically in lam, alpha,
    gamma, so unstable ZDAs (lam > 0, unbounded states) exist: the pencil is not left-invertible."""
    _, A, B, C, x0, u0 = zda_instance_every_lambda()
    n2 = A.shape[0]
    pencil = sp.Matrix.vstack(
        sp.Matrix.hstack(lam * sp.eye(n2) - A, -B), sp.Matrix.hstack(C, sp.zeros(C.shape[0], B.shape[1]))
    )
    return pencil * sp.Matrix.vstack(x0, u0)
