"""Lemma III.1 (``lemma:Inv_unobs_subspace``) and its proof in Appendix B.

Claim: span{[1; 0]} is an A_sigma-invariant unobservable subspace of the switched system
(eq. ``cl_sys``) when it lies in ker C. The proof (eq. ``PBH_test``) is a PBH test at
lambda = 0 with w_r = [1; 0] and C = diag{0, C_v}:

.. math::

    \\begin{bmatrix} 0 \\cdot I - A_q \\\\ C \\end{bmatrix} w_r = 0 .

The steps use a *generic* Laplacian: symbolic off-diagonal entries, diagonal fixed by
L 1 = 0 and no symmetry imposed, so they also cover the balanced directed case the lemma
mentions. Connectivity is never used: L 1 = 0 holds for every Laplacian.
"""

from __future__ import annotations

import sympy as sp

from ._instances import state_matrix
from .core import StepList

__all__ = ["STEPS", "generic_laplacian"]

STEPS = StepList("lemma_iii1")
REF = "Appendix B (proof of Lemma III.1)"

alpha, gamma = sp.symbols("alpha gamma", positive=True)


def generic_laplacian(n: int, prefix: str = "a", symmetric: bool = False) -> sp.Matrix:
    """An n x n matrix with symbolic off-diagonal entries and zero row sums (L 1 = 0)."""
    L = sp.zeros(n, n)
    for i in range(n):
        for j in range(n):
            if i != j:
                a, b = (min(i, j), max(i, j)) if symmetric else (i, j)
                L[i, j] = -sp.Symbol(f"{prefix}_{a + 1}{b + 1}")
        L[i, i] = -sum(L[i, j] for j in range(n) if j != i)
    return L


def _wr(n: int) -> sp.Matrix:
    return sp.Matrix([1] * n + [0] * n)


@STEPS.add("eigenpair_at_zero", equation="PBH_test", reference=REF)
def _eigenpair() -> sp.Matrix:
    """(0 I - A_q) w_r = 0 for a generic 4 x 4 Laplacian (L 1 = 0, not necessarily symmetric)."""
    L = generic_laplacian(4)
    A = state_matrix(L, alpha, gamma)
    return (0 * sp.eye(8) - A) * _wr(4)


@STEPS.add("output_kernel", equation="PBH_test", reference=REF)
def _output_kernel() -> sp.Matrix:
    """C w_r = 0 for C = diag{0, C_v} with a generic symbolic 3 x 4 block C_v."""
    Cv = sp.Matrix(3, 4, lambda i, j: sp.Symbol(f"c_{i + 1}{j + 1}"))
    C = sp.Matrix.hstack(sp.zeros(3, 4), Cv)
    return C * _wr(4)


@STEPS.add("unobservable_in_every_mode", equation="obsv_nullspace_matrix", reference=REF)
def _observability_rows() -> sp.Matrix:
    """O_k w_r = col(C w_r, C A_k w_r, ..., C A_k^{2N-1} w_r) = 0 for two generic modes (N = 3).

    A_k w_r = 0 gives A_k^m w_r = 0 (m >= 1) and exp(A_k tau) w_r = w_r, so w_r lies in every
    factor of eqs. ``obsv_nullspace_1``-``obsv_nullspace_2``: span{w_r} is in the switched
    unobservable subspace for any mode sequence and dwell times.
    """
    n = 3
    Cv = sp.Matrix(2, n, lambda i, j: sp.Symbol(f"c_{i + 1}{j + 1}"))
    C = sp.Matrix.hstack(sp.zeros(2, n), Cv)
    rows = []
    for prefix in ("a", "b"):
        A = state_matrix(generic_laplacian(n, prefix), alpha, gamma)
        v = _wr(n)
        for _ in range(2 * n):
            rows.append(C * v)
            v = A * v
        rows.append(v)  # A^{2N} w_r, also zero
    return sp.Matrix.vstack(*rows)


@STEPS.add("flow_fixes_consensus_direction", equation="obsv_O", reference=REF)
def _flow() -> sp.Matrix:
    """exp(A_q tau) w_r - w_r = 0, computed exactly for two agents with alpha = 1, gamma = 3.

    The eigenvalues of A_q are the roots of lam^2 + 3 lam + mu, mu in {0, 2}: 0, -3, -1, -2,
    so the exponential is exact and the residual simplifies to zero for every tau.
    """
    tau = sp.Symbol("tau", positive=True)
    L = sp.Matrix([[1, -1], [-1, 1]])
    A = state_matrix(L, sp.Integer(1), sp.Integer(3))
    return (A * tau).exp() * _wr(2) - _wr(2)


@STEPS.add("consensus_value_not_reconstructable", equation="PBH_test", reference="Problem 1 (i), Lemma III.1", expected="nonzero")
def _consensus_value() -> sp.Expr:
    """f^T w_r = 1 != 0 for f = [1/N 1; 0]: the consensus value x* is not orthogonal to the
    unobservable subspace, hence not reconstructable from y (N = 5)."""
    n = 5
    f = sp.Matrix([sp.Rational(1, n)] * n + [0] * n)
    return (f.T * _wr(n))[0, 0]
