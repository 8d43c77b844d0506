"""Computed subspaces with both readings of their undecided decisions, and the widened zero test.

A :class:`Subspace` keeps a *lower* basis (directions certainly in the subspace) and an
*upper* basis (every undecided quantity read as zero) together with the estimated sine of the
angle to the exact subspace; :func:`decide_with_error` is the three-valued zero test of a
quantity known up to an absolute error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from glocal_verify.numerics.rounding import EPS, SVD_BACKWARD_CONSTANT, UNIT_ROUNDOFF
from glocal_verify.numerics.tolerance import Decision, Tolerance

__all__ = [
    "Subspace",
    "decide_with_error",
    "svd_rank_bound",
]



# --------------------------------------------------------------------------------------------
# decisions with an error estimate


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
    beta = SVD_BACKWARD_CONSTANT * max(M.shape) * EPS * float(sv[0]) * (1 + 2 * EPS) + UNIT_ROUNDOFF * float(np.linalg.norm(M, "fro"))
    return sv, beta


def decide_with_error(value: float, error: float, tol: Tolerance, scale: float = 1.0) -> Decision:
    """Three-valued zero test of a computed ``value`` known up to ``error`` (both absolute).

    ``ZERO`` iff ``|value| + error <= rtol * scale``, ``NONZERO`` iff
    ``|value| - error > rtol * band * scale``, ``UNDECIDED`` otherwise. With ``error = 0`` this is
    :meth:`Tolerance.decide <glocal_verify.numerics.tolerance.Tolerance.decide>`.

    Parameters
    ----------
    value : float
        The computed quantity.
    error : float
        Estimated absolute error of ``value`` (>= 0).
    tol : Tolerance
        Relative tolerance and band.
    scale : float
        The scale ``value`` is compared with.
    """
    v = abs(float(value))
    e = max(float(error), 0.0)
    if not math.isfinite(v) or not math.isfinite(e):
        return Decision.UNDECIDED
    if v + e <= tol.rtol * scale:
        return Decision.ZERO
    if v - e > tol.upper * scale:
        return Decision.NONZERO
    return Decision.UNDECIDED


# --------------------------------------------------------------------------------------------
# subspaces


@dataclass(frozen=True, slots=True)
class Subspace:
    """A numerically computed subspace of R^n with both readings of its undecided decisions.

    Attributes
    ----------
    basis : ndarray
        ``n x k`` orthonormal basis of the *lower* reading: only directions certainly in the
        subspace (every deciding quantity certainly zero).
    upper : ndarray
        ``n x k'`` orthonormal basis of the *upper* reading (every undecided quantity read as
        zero); ``k' >= k`` and ``span(basis)`` lies (numerically) inside ``span(upper)``.
    decided : bool
        ``k == k'``: the tolerance separates every case and ``basis`` is the subspace.
    margin : float
        Smallest certainly nonzero deciding quantity (unit scale; 1.0 when there is none): how
        far the subspace is from growing.
    error : float
        Estimated sine of the largest principal angle between ``basis`` and the exact subspace.
    rtol : float
        The relative tolerance used.
    evidence : mapping
        Method-specific details (eigen-groups, steps of a recursion ...).
    """

    basis: np.ndarray
    upper: np.ndarray
    decided: bool
    margin: float
    error: float
    rtol: float
    evidence: Mapping[str, Any] = field(default_factory=dict)

    @property
    def dim(self) -> int:
        """Dimension of the lower reading."""
        return int(self.basis.shape[1])

    @property
    def dim_upper(self) -> int:
        """Dimension of the upper reading."""
        return int(self.upper.shape[1])

    @property
    def ambient(self) -> int:
        """Dimension of the ambient space."""
        return int(self.basis.shape[0])

    def contains_decision(self, v: np.ndarray, tol: Tolerance) -> tuple[Decision, float]:
        """Is the vector ``v`` in the subspace? Returns the decision on ``dist(v, S) / ||v||`` and that distance.

        ``ZERO`` (inside) uses the lower reading, ``NONZERO`` (outside) the upper one, both
        widened by :attr:`error`.

        Parameters
        ----------
        v : ndarray
            A nonzero vector of the ambient space.
        tol : Tolerance
            Tolerance of the decision.
        """
        v = np.asarray(v, dtype=float)
        nv = float(np.linalg.norm(v))
        u = v / nv
        d_lo = _distance(u, self.basis)
        d_hi = _distance(u, self.upper)
        inside = decide_with_error(d_lo, self.error, tol)
        outside = decide_with_error(d_hi, self.error, tol)
        if inside is Decision.ZERO:
            return Decision.ZERO, d_lo
        if outside is Decision.NONZERO:
            return Decision.NONZERO, d_lo
        return Decision.UNDECIDED, d_lo


def _distance(u: np.ndarray, B: np.ndarray) -> float:
    if B.shape[1] == 0:
        return float(np.linalg.norm(u))
    return float(np.linalg.norm(u - B @ (B.T @ u)))
