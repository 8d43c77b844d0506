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
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse

from glocal_verify.numerics.tolerance import (
    DEFAULT_TOLERANCE,
    EigenGroup,
    Tolerance,
    group_eigenvalues,
)

__all__ = ["Spectrum"]


@dataclass(frozen=True, eq=False)
class Spectrum:
    """``L = U diag(w) U^T`` (ascending ``w``) of a real symmetric matrix, computed lazily.

    Parameters
    ----------
    matrix : ndarray
        The symmetric matrix (kept read-only).

    Examples
    --------
    >>> import numpy as np
    >>> s = Spectrum(np.array([[1.0, -1.0], [-1.0, 1.0]]))
    >>> [round(float(x), 12) for x in s.values]
    [0.0, 2.0]
    """

    matrix: np.ndarray

    def __post_init__(self) -> None:
        M = np.array(self.matrix, dtype=float)
        M.setflags(write=False)
        object.__setattr__(self, "matrix", M)

    @cached_property
    def _pairs(self) -> tuple[np.ndarray, np.ndarray]:
        w, U = np.linalg.eigh(self.matrix)
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

    @cached_property
    def scale(self) -> float:
        """``||L||_2 = max |w_i|`` (1.0 for the zero matrix, so relative tests stay defined)."""
        s = float(np.max(np.abs(self.values))) if self.size else 0.0
        return s if s > 0.0 else 1.0

    @cached_property
    def residuals(self) -> np.ndarray:
        """Residual norms ``||L u_i - w_i u_i||_2`` of the computed eigenpairs (read-only)."""
        L = scipy.sparse.csr_matrix(self.matrix)
        R = L @ self.vectors - self.vectors * self.values[None, :]
        r = np.linalg.norm(R, axis=0)
        r.setflags(write=False)
        return r

    def groups(self, tol: Tolerance = DEFAULT_TOLERANCE) -> list[EigenGroup]:
        """Groups of numerically equal eigenvalues at ``rtol * ||L||_2``.

        Parameters
        ----------
        tol : Tolerance
            Gaps at most ``rtol * scale`` join, gaps above ``rtol * band * scale`` split, gaps in
            between mark both neighbouring groups uncertain.
        """
        return group_eigenvalues(self.values, self.scale, tol)
