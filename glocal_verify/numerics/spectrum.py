"""The eigendecomposition of one real symmetric matrix with its a-posteriori error bounds.

A :class:`Spectrum` is what every global question of the toolkit starts from: the modal
structure reduces observability, privacy and zero-dynamics questions on the 2N-dimensional
closed loop to N-sized questions on the eigenpairs of a Laplacian ``L_q``. It is frozen; its
parts are computed on first use and then kept (``functools.cached_property``).

Bounds
------
For a computed eigenpair ``(w_i, u_i)`` the residual ``r_i = ||L u_i - w_i u_i||_2`` bounds the
distance from ``w_i`` to the spectrum of the exact ``L`` (Weyl / Bauer-Fike for symmetric
matrices), and, for a group of eigenvalues separated from the rest by ``delta``, the
Davis-Kahan sin-theta theorem bounds the angle between the computed and the exact invariant
subspace by ``||R_g||_2 / delta``. The residuals are computed with the matrix applied in
sparse form, O(nnz * N).

Certified quantities (:attr:`Spectrum.error_radius`, :attr:`Spectrum.clusters`,
:meth:`Spectrum.subspace_sine`) are rigorous: they add the rounding of the residual itself,
the loss of orthonormality of the computed eigenvectors and the rounding of the input
(``input_error``, for a matrix whose entries were each rounded once from exact values) to the
a-posteriori residual bounds, with the constants stated in each docstring. They are bounds on
floating-point error, not tolerances: no ``rtol`` enters them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Sequence

import numpy as np
import scipy.linalg
import scipy.linalg.blas
import scipy.sparse

from glocal_verify.numerics.rounding import EPS, gamma_bound, product_rounding
from glocal_verify.numerics.tolerance import (
    DEFAULT_TOLERANCE,
    EigenGroup,
    Tolerance,
    group_eigenvalues,
)

__all__ = ["Spectrum"]

#: columns per block of the a-posteriori products (bounded temporaries)
_BLOCK = 256


@dataclass(frozen=True, eq=False)
class Spectrum:
    """``L = U diag(w) U^T`` (ascending ``w``) of a real symmetric matrix, computed lazily.

    Parameters
    ----------
    matrix : ndarray or scipy.sparse matrix
        The symmetric matrix (kept read-only). A sparse matrix stays sparse (kept as CSR):
        only the decomposition makes a dense scratch copy, which it overwrites, so a large
        Laplacian is held once as its eigenvectors, not twice.

    Examples
    --------
    >>> import numpy as np
    >>> s = Spectrum(np.array([[1.0, -1.0], [-1.0, 1.0]]))
    >>> [round(float(x), 12) for x in s.values]
    [0.0, 2.0]
    """

    matrix: np.ndarray | scipy.sparse.csr_matrix

    def __post_init__(self) -> None:
        if scipy.sparse.issparse(self.matrix):
            S = scipy.sparse.csr_matrix(self.matrix, dtype=float)
            if S.data.flags.writeable:
                S = S.copy()  # a caller's writable matrix is copied once; read-only ones (System's) are shared
                S.sort_indices()
                for arr in (S.data, S.indices, S.indptr):
                    arr.setflags(write=False)
            object.__setattr__(self, "matrix", S)
            return
        M = np.asarray(self.matrix, dtype=float)
        if M.flags.writeable:
            M = M.copy()  # a caller's writable array is copied once; read-only ones (System's) are shared
            M.setflags(write=False)
        object.__setattr__(self, "matrix", M)

    @cached_property
    def _sparse(self) -> scipy.sparse.csr_matrix:
        """The matrix in CSR form (the residuals apply it in O(nnz) per vector)."""
        M = self.matrix
        return M if scipy.sparse.issparse(M) else scipy.sparse.csr_matrix(M)

    @cached_property
    def frobenius(self) -> float:
        """An upper bound on ``||L||_F`` of :attr:`matrix`: the computed norm of its stored entries times ``1 + 2 gamma_{nnz+2}`` (its rounding)."""
        data = self._sparse.data
        return float(np.linalg.norm(data)) * (1.0 + 2.0 * gamma_bound(data.size + 2))

    @cached_property
    def abs_norm(self) -> float:
        """An upper bound on ``|| |L| ||_2``: the smaller of :attr:`frobenius` and the largest absolute row sum (``|L|`` is symmetric, so its 2-norm is at most its infinity norm), rounding included."""
        S = self._sparse
        if S.shape[0] == 0:
            return 0.0
        rows = np.bincount(np.repeat(np.arange(S.shape[0]), np.diff(S.indptr)), weights=np.abs(S.data), minlength=S.shape[0])
        return min(self.frobenius, float(np.max(rows)) * (1.0 + 2.0 * gamma_bound(self.row_nonzeros + 2)))

    @cached_property
    def row_nonzeros(self) -> int:
        """``k``: the largest number of nonzero entries of a row of :attr:`matrix` (0 when empty)."""
        S = self._sparse
        if S.shape[0] == 0:
            return 0
        return int(np.max(np.diff(scipy.sparse.csr_matrix(S != 0).indptr)))

    @cached_property
    def _pairs(self) -> tuple[np.ndarray, np.ndarray]:
        # LAPACK's divide and conquer (syevd, as numpy.linalg.eigh) on a scratch copy it may
        # overwrite: 5-8 % faster than numpy's at N = 4000 on one thread
        M = self.matrix
        scratch = M.toarray() if isinstance(M, scipy.sparse.csr_matrix) else np.array(M)
        w, U = scipy.linalg.eigh(scratch, driver="evd", overwrite_a=True, check_finite=False)
        w.setflags(write=False)
        U.setflags(write=False)
        return w, U

    @property
    def values(self) -> np.ndarray:
        """Eigenvalues, ascending (read-only)."""
        return self._pairs[0]

    @property
    def vectors(self) -> np.ndarray:
        """Orthonormal eigenvectors as columns, in the order of :attr:`values` (read-only)."""
        return self._pairs[1]

    @property
    def size(self) -> int:
        """Order N of the matrix."""
        return int(self.matrix.shape[0])

    @property
    def entry_error(self) -> float:
        """Bound on the error of each entry :meth:`rows`, :meth:`columns` and :attr:`vectors` return.

        0 here: they are the computed eigenvectors themselves, which every bound of this class
        is about. A spectrum kept in factored form
        (:class:`~glocal_verify.numerics.updated_spectrum.UpdatedSpectrum`) computes its rows
        and columns, and a certified decision that reads them adds this error to its own.
        """
        return 0.0

    @property
    def explicit(self) -> bool:
        """Whether the eigenvectors are held as an array (columns are views); False for a factored spectrum."""
        return True

    @property
    def entry_estimate(self) -> float:
        """An estimate (not a bound) of the error of a computed entry, for the tolerance readings: 0 here.

        A factored spectrum's rows are computed with ``O(sqrt(m) u)`` typical rounding per
        product, far below the worst case :attr:`entry_error` bounds.
        """
        return 0.0

    def rows(self, idx: Sequence[int] | np.ndarray) -> np.ndarray:
        """Rows ``U[idx, :]`` of the eigenvector matrix (``|idx| x N``, a new array)."""
        return np.asarray(self.vectors)[np.asarray(idx, dtype=np.intp), :]

    def columns(self, idx: Sequence[int] | np.ndarray | slice) -> np.ndarray:
        """Columns ``U[:, idx]`` (a read-only view for a slice, a new array otherwise)."""
        return self.vectors[:, idx] if isinstance(idx, slice) else np.asarray(self.vectors)[:, np.asarray(idx, dtype=np.intp)]

    def apply(self, Y: np.ndarray) -> np.ndarray:
        """``U Y`` for ``Y`` of shape ``N x k``, real or complex (entries within :attr:`entry_error` times ``||Y||_1`` of exact products)."""
        Y = np.asarray(Y)
        if np.iscomplexobj(Y):
            return self._apply_real(np.ascontiguousarray(Y.real)) + 1j * self._apply_real(np.ascontiguousarray(Y.imag))
        return self._apply_real(Y.astype(float, copy=False))

    def project(self, X: np.ndarray) -> np.ndarray:
        """``U^T X`` for ``X`` of shape ``N x k``, real or complex."""
        X = np.asarray(X)
        if np.iscomplexobj(X):
            return self._project_real(np.ascontiguousarray(X.real)) + 1j * self._project_real(np.ascontiguousarray(X.imag))
        return self._project_real(X.astype(float, copy=False))

    def abs_apply(self, y: np.ndarray) -> np.ndarray:
        """``|U| |y|`` for a vector y (the rounding bound of ``U y``), in blocks of rows: no N x N temporary."""
        U = np.asarray(self.vectors)
        ay = np.abs(np.asarray(y, dtype=float))
        out = np.empty(U.shape[0])
        for a in range(0, U.shape[0], 512):
            out[a : a + 512] = np.abs(U[a : a + 512]) @ ay
        return out

    def _apply_real(self, Y: np.ndarray) -> np.ndarray:
        return np.asarray(self.vectors) @ Y

    def _project_real(self, X: np.ndarray) -> np.ndarray:
        return np.asarray(self.vectors).T @ X

    @cached_property
    def scale(self) -> float:
        """``||L||_2 = max |w_i|`` (1.0 for the zero matrix, so relative tests stay defined)."""
        s = float(np.max(np.abs(self.values))) if self.size else 0.0
        return s if s > 0.0 else 1.0

    @cached_property
    def residuals(self) -> np.ndarray:
        """Residual norms ``||L u_i - w_i u_i||_2`` of the computed eigenpairs (read-only)."""
        L = self._sparse
        U, w = self.vectors, self.values
        r = np.empty(self.size)
        for a in range(0, self.size, _BLOCK):  # column blocks: O(N b) temporaries
            b = min(a + _BLOCK, self.size)
            r[a:b] = np.linalg.norm(L @ U[:, a:b] - U[:, a:b] * w[None, a:b], axis=0)
        r.setflags(write=False)
        return r

    @property
    def residual_estimates(self) -> np.ndarray:
        """Estimates of ``||L u_i - w_i u_i||_2`` for the tolerance readings (not certified): the computed norms here.

        The certified bounds add the rounding of these norms themselves; the readings at a
        tolerance (:func:`~glocal_verify.analysis.unobservable.modal.modal_decomposition`) take them as they
        are. A spectrum kept in factored form, whose :attr:`residuals` are rigorous bounds,
        gives the same recurrence without its rounding allowances instead.
        """
        return self.residuals

    @cached_property
    def residual_frobenius(self) -> float:
        """``||R||_F`` of the residual matrix ``L U - U diag(w)``: the norm of :attr:`residuals` here.

        A spectrum kept in factored form bounds it directly, more sharply than its per-column
        bounds together.
        """
        return float(np.linalg.norm(self.residuals))

    @cached_property
    def input_error(self) -> float:
        """Bound on ``||fl(L) - L||_2`` for the exact matrix L whose entries were rounded once.

        ``u ||fl(L)||_F / (1 - u)`` with ``u = 2^-53``: valid when every entry of
        :attr:`matrix` is the correctly rounded value of an exact entry (as
        :meth:`System.laplacian_sparse <glocal_verify.model.System.laplacian_sparse>` builds it); 0 for a
        matrix whose entries are all small integers would also be valid but is not assumed.
        """
        u = EPS / 2.0
        return u * self.frobenius / (1.0 - u) if self.size else 0.0

    @cached_property
    def orthogonality_error(self) -> float:
        """``eta``: a rigorous bound on ``||U^T U - I||_F``, the loss of orthonormality of :attr:`vectors`.

        .. math:: \\eta = (1 + \\gamma_{N^2}) \\|fl(U^T U) - I\\|_F
                  + \\gamma_{N+1} \\sqrt{\\| |U| \\|_1 \\| |U| \\|_\\infty}\\, \\|U\\|_F,
                  \\qquad \\gamma_k = \\frac{k u}{1 - k u},

        the second term bounding the rounding of the product (entrywise ``|fl(U^T U) - U^T U|
        <= gamma_N |U|^T |U|`` (Higham, Thm 3.5), the diagonal shift adding one rounding, and
        ``|| |U|^T |U| ||_F <= || |U| ||_2 ||U||_F`` with ``|| |U| ||_2 <= sqrt(||U||_1 ||U||_inf)``),
        the factor ``1 + gamma_{N^2}`` the rounding of the sum of squares. ``U^T U`` is one
        symmetric rank-N update (BLAS ``syrk``, half the flops of a general product, one N x N
        array).
        """
        n = self.size
        if n == 0:
            return 0.0
        return (1.0 + gamma_bound(float(n) * n)) * self._gram_loss + product_rounding(self.vectors, self.vectors, shifted=True)

    @cached_property
    def _gram_loss(self) -> float:
        """The computed ``||fl(U^T U) - I||_F`` (no rounding allowance; see :attr:`orthogonality_error`)."""
        n = self.size
        if n == 0:
            return 0.0
        G = scipy.linalg.blas.dsyrk(1.0, self.vectors, trans=1)  # upper triangle of U^T U; the lower one is zero
        d = np.arange(n)
        G[d, d] -= 1.0
        diag2 = float(np.dot(G[d, d], G[d, d]))
        total = 2.0 * float(np.vdot(G, G)) - diag2  # the strict upper triangle counts twice
        return math.sqrt(max(total, 0.0))

    @cached_property
    def error_radius(self) -> float:
        """Certified ``rho``: the i-th smallest eigenvalue of the exact L lies in ``[w_i - rho, w_i + rho]``.

        Weyl's theorem applied to ``L = U diag(w) U^T + F`` with the computed (nearly
        orthonormal) ``U``. With ``R = fl(L U - U diag(w))``, ``eta`` the :attr:`orthogonality_error`
        (bound on the loss of orthonormality, its own rounding included) and ``k`` the largest
        number of nonzeros of a row of L,

        .. math:: \\rho = \\frac{\\|R\\|_F + (k + 2)\\,\\varepsilon\\,\\sqrt N\\,(\\|L\\|_F + \\max|w_i|)}{1 - \\eta}
                  + 2 \\eta \\max|w_i| + \\text{input\\_error},

        where the second term of the numerator bounds the rounding of the residual
        (Higham, Thm 3.5, constant ``k + 2`` for a sparse product with ``k`` terms and a
        subtraction, ``sqrt N`` from ``|| |L| |U| ||_F <= ||L||_F ||U||_F``), ``1 / (1 - eta)``
        accounts for a non-orthonormal ``U`` (polar factor) and ``2 eta max|w|`` for
        ``U diag(w) U^T`` versus its orthonormal polar part. Infinite if ``eta >= 1/2``.
        """
        n = self.size
        if n == 0:
            return 0.0
        eta = self.orthogonality_error
        if eta >= 0.5:
            return math.inf
        k = self.row_nonzeros
        wmax = float(np.max(np.abs(self.values)))
        rnorm = self.residual_frobenius
        rround = (k + 2) * EPS * math.sqrt(n) * (self.frobenius + wmax)
        return (rnorm + rround) * (1.0 + 2.0 * eta) + 2.0 * eta * wmax + self.input_error

    @cached_property
    def clusters(self) -> tuple[tuple[int, ...], ...]:
        """Maximal runs of consecutive eigenvalues that the certified radius cannot separate.

        ``i`` and ``i + 1`` are in one cluster iff ``w_{i+1} - w_i <= 2 rho``
        (:attr:`error_radius`). By Weyl's index pairing the exact eigenvalues with the indices
        of a cluster lie in ``[w_first - rho, w_last + rho]`` and no other exact eigenvalue does:
        a singleton cluster is a certified simple eigenvalue.
        """
        n = self.size
        if n == 0:
            return ()
        rho = self.error_radius
        out: list[list[int]] = [[0]]
        for i in range(1, n):
            if not (self.values[i] - self.values[i - 1] > 2.0 * rho):
                out[-1].append(i)
            else:
                out.append([i])
        return tuple(tuple(c) for c in out)

    def separation(self, cluster: Sequence[int]) -> float:
        """Certified lower bound on the distance from the Ritz values of ``cluster`` to the other exact eigenvalues.

        ``min(w_first - w_{first-1}, w_{last+1} - w_last) - rho`` (``inf`` without neighbours).

        Parameters
        ----------
        cluster : sequence of int
            Consecutive indices (one of :attr:`clusters`).
        """
        a, b = cluster[0], cluster[-1]
        left = self.values[a] - self.values[a - 1] if a > 0 else math.inf
        right = self.values[b + 1] - self.values[b] if b + 1 < self.size else math.inf
        return float(min(left, right)) - self.error_radius

    def subspace_sine(self, cluster: Sequence[int]) -> float:
        """Certified bound on ``||sin Theta||_2`` between ``span(U[:, cluster])`` and the exact spectral subspace.

        Davis-Kahan sin-theta theorem (residual form, Hermitian case):
        ``||sin Theta|| <= ||L U_g - U_g W_g||_F / delta`` with ``delta`` from
        :meth:`separation`; the residual is widened by its rounding and by the input error
        exactly as in :attr:`error_radius` (per cluster). ``inf`` when ``delta <= 0``; capped at 1.

        Parameters
        ----------
        cluster : sequence of int
            Consecutive indices (one of :attr:`clusters`).
        """
        delta = self.separation(cluster)
        if not delta > 0:
            return math.inf
        n = self.size
        g = list(cluster)
        k = self.row_nonzeros
        wmax = float(np.max(np.abs(self.values[g])))
        r = float(np.linalg.norm(self.residuals[g]))
        r += (k + 2) * EPS * math.sqrt(n) * (self.frobenius + wmax) + self.input_error
        r *= 1.0 + 4.0 * n * EPS
        return min(1.0, r / delta)

    def groups(self, tol: Tolerance = DEFAULT_TOLERANCE) -> list[EigenGroup]:
        """Groups of numerically equal eigenvalues at ``rtol * ||L||_2``.

        Parameters
        ----------
        tol : Tolerance
            Gaps at most ``rtol * scale`` join, gaps above ``rtol * band * scale`` split, gaps in
            between mark both neighbouring groups uncertain.
        """
        return group_eigenvalues(self.values, self.scale, tol)
