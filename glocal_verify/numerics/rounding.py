"""Bounds on floating-point rounding error shared by the certified computations.

The machine epsilon ``EPS`` and unit roundoff ``UNIT_ROUNDOFF = eps / 2`` of IEEE doubles,
Higham's ``gamma_k = k u / (1 - k u)`` (the relative error of a sum or product chain of k
rounded operations), the rigorous rounding bound of a matrix product ``A^T B`` (Higham,
Accuracy and Stability of Numerical Algorithms, Thm 3.5), and the backward error of an SVD
(:data:`SVD_BACKWARD_CONSTANT`, :func:`svd_error`). Every certified computation of the
package reads these constants here; no module keeps a copy.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["EPS", "SVD_BACKWARD_CONSTANT", "UNIT_ROUNDOFF", "gamma_bound", "product_rounding", "svd_error"]

#: unit roundoff doubled: the spacing of doubles at 1 (2^-52)
EPS = float(np.finfo(float).eps)
#: unit roundoff u = eps / 2: a correctly rounded operation has relative error at most u
UNIT_ROUNDOFF = EPS / 2.0
#: the stated constant c of the SVD backward error used by every rank certificate: the
#: singular values LAPACK computes for M are the exact singular values of M + Delta with
#: ||Delta||_2 <= c * max(m, n) * eps * ||M|| (Demmel-Kahan / Golub-Van Loan 8.6; LAPACK's
#: p(m, n) eps ||M||_2 with a modest p, taken generously)
SVD_BACKWARD_CONSTANT = 10.0


def gamma_bound(k: float) -> float:
    """gamma_k = k u / (1 - k u), u = eps / 2 (Higham's bound for a sum of k rounded terms).

    Parameters
    ----------
    k : int or float
        Number of floating-point operations in the longest chain (infinite bound when k u >= 1/2).
    """
    u = UNIT_ROUNDOFF
    return k * u / (1.0 - k * u) if k * u < 0.5 else math.inf


def product_rounding(A: np.ndarray, B: np.ndarray, shifted: bool = False) -> float:
    """A rigorous bound on ``||fl(A^T B) - A^T B||_F`` (plus one subtraction if ``shifted``).

    Entrywise ``|fl(A^T B) - A^T B| <= gamma_n |A|^T |B|`` for inner dimension n (Higham,
    Accuracy and Stability of Numerical Algorithms, Thm 3.5; ``gamma_{n+1}`` when a constant
    such as I is subtracted afterwards), and ``|| |A|^T |B| ||_F <= || |A| ||_2 ||B||_F``
    with ``|| |A| ||_2 <= sqrt(|| A ||_1 || A ||_inf)``. O(size of A and B).

    Parameters
    ----------
    A, B : ndarray
        n x k and n x l.
    shifted : bool
        Whether the product is followed by one more rounded operation per entry.
    """
    A, B = np.asarray(A), np.asarray(B)
    n = A.shape[0]
    if A.size == 0 or B.size == 0:
        return 0.0
    absA = np.abs(A)
    norm_abs = math.sqrt(float(absA.sum(axis=0).max()) * float(absA.sum(axis=1).max()))
    # (1 + 2 gamma_n): the sums of n nonnegative terms and the 2-norm are computed in floating point too
    return gamma_bound(n + (1 if shifted else 0)) * norm_abs * float(np.linalg.norm(B)) * (1.0 + 2.0 * gamma_bound(max(n, B.size)))


def svd_error(M: np.ndarray) -> float:
    """Bound on the backward error of LAPACK's SVD of ``M``:
    ``SVD_BACKWARD_CONSTANT * max(m, n) * eps * ||M||_F`` (:data:`SVD_BACKWARD_CONSTANT`).

    Parameters
    ----------
    M : ndarray
    """
    M = np.asarray(M)
    if M.size == 0:
        return 0.0
    return SVD_BACKWARD_CONSTANT * max(M.shape) * EPS * float(np.linalg.norm(M)) * (1.0 + M.size * EPS)
