"""The generic orthogonal staircase: the unobservable subspace of any pair (A, C).

A backward-stable reference for small systems and for testing the modal path; it never forms
the observability matrix.
"""

from __future__ import annotations

import math

import numpy as np

from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance

__all__ = [
    "unobservable_subspace_dense",
]

# --------------------------------------------------------------------------------------------
# generic dense staircase


def _staircase(A: np.ndarray, C: np.ndarray, tol: Tolerance, upper: bool) -> tuple[np.ndarray, bool, float, int, float]:
    """One reading of the staircase; returns (basis, decided, margin, steps, error estimate)."""
    n = A.shape[0]
    scale_a = float(np.linalg.norm(A, 2)) if A.size else 0.0
    decided = True
    margin = 1.0
    err = n * EPS
    if C.shape[0]:
        _, s, Vh = np.linalg.svd(C, full_matrices=True)
        sc = float(s[0]) if len(s) else 0.0
        sp = np.zeros(n)
        sp[: len(s)] = s / sc if sc > 0 else s
        dec = [decide_with_error(x, n * EPS, tol) if sc > 0 else Decision.ZERO for x in sp]
        r_lo = sum(1 for d in dec if d is Decision.NONZERO)
        r_hi = sum(1 for d in dec if d is not Decision.ZERO)
        decided &= r_lo == r_hi
        r = r_lo if upper else r_hi
        if r:
            gap = float(sp[r - 1] - (sp[r] if r < n else 0.0))
            err = n * EPS / gap if gap > 0 else math.inf
        V = Vh.T[:, r:]
    else:
        V = np.eye(n)
    steps = 0
    if scale_a == 0.0:
        return V, decided, margin, steps, err
    while V.shape[1] > 0:
        steps += 1
        Y = A @ V
        R = Y - V @ (V.T @ Y)
        k = V.shape[1]
        _, s, Vh = np.linalg.svd(R, full_matrices=False)  # R is n x k with n >= k: Vh is k x k
        sp = np.zeros(k)
        sp[: len(s)] = s / scale_a
        dec = [tol.decide(x, 1.0) for x in sp]
        r_lo = sum(1 for d in dec if d is Decision.NONZERO)
        r_hi = sum(1 for d in dec if d is not Decision.ZERO)
        decided &= r_lo == r_hi
        if r_lo:
            margin = min(margin, float(sp[r_lo - 1]))
        r = r_lo if upper else r_hi
        if r == 0:
            break
        # this step's rounding moves the kernel by about n eps / gap (Wedin), gap between kept
        # and dropped singular values; recorded as information, not used in the decisions
        gap = float(sp[r - 1] - (sp[r] if r < k else 0.0))
        err = err + (n * EPS / gap if gap > 0 else math.inf)
        Z = Vh.T[:, r:]
        V, _ = np.linalg.qr(V @ Z)
        V = V[:, : Z.shape[1]]
    return V, decided, margin, steps, err


def unobservable_subspace_dense(A: np.ndarray, C: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> Subspace:
    """Unobservable subspace of a generic pair (A, C) by an orthogonal staircase (reference method).

    The largest A-invariant subspace inside ``ker C`` is the limit of

    .. math:: \\mathcal V_0 = \\ker C, \\qquad
              \\mathcal V_{j+1} = \\{ v \\in \\mathcal V_j : A v \\in \\mathcal V_j \\},

    computed with orthonormal bases: for ``V_j`` orthonormal, ``V_{j+1} = V_j Z`` where ``Z``
    spans the kernel of ``(I - V_j V_j^T) A V_j`` (an SVD per step; at most n steps). This is the
    dual of the controllability staircase; it never forms ``(C, CA, ..., CA^{n-1})``. Meant for
    small systems (O(n^3) per step) and as a generic reference for the modal method.

    The staircase is backward stable, but the unobservable subspace of a generic pair is
    ill-conditioned: with few outputs it needs many steps, each of which can amplify the error
    by ``||A|| / s`` (``s`` the singular value it peels off). A 30-agent graph with one velocity
    monitor and a 16-fold Laplacian eigenvalue loses its true 35-dimensional subspace this way
    (the same ill-conditioning that ruins the observability matrix); a rigorous compounded
    error bound would declare almost every staircase undecided, so none is applied: the
    result is the exact unobservable subspace of a nearby pair, not a certified one. Use it as
    a reference on small, well-conditioned systems; the modal method, which only needs the
    well-conditioned ``eigh`` of L, is the one the checkers use.

    Parameters
    ----------
    A : ndarray
        ``n x n`` state matrix.
    C : ndarray
        ``p x n`` output matrix.
    tol : Tolerance
        ``ker C``: singular values of C compared with ``rtol * ||C||_2``; each step: singular
        values of ``(I - V V^T) A V`` compared with ``rtol * ||A||_2``. Undecided singular
        values give the two readings of :class:`Subspace`. ``error`` sums the per-step
        estimates ``n eps / gap`` (Wedin; first order, information only). Undecided
        singular values give the two readings of :class:`Subspace`; a small gap makes later
        decisions undecided rather than wrong.
    """
    A = np.asarray(A, dtype=float)
    C = np.asarray(C, dtype=float).reshape(-1, A.shape[0])
    lo, dec_lo, margin, steps, err = _staircase(A, C, tol, upper=False)
    hi, dec_hi, _, _, _ = _staircase(A, C, tol, upper=True)
    return Subspace(
        basis=lo,
        upper=hi,
        decided=dec_lo and dec_hi and lo.shape[1] == hi.shape[1],
        margin=margin,
        error=err,
        rtol=tol.rtol,
        evidence={"method": "staircase", "steps": steps},
    )
