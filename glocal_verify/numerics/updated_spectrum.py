"""A spectrum kept as the normal one times rank-one factors: ``U_q = U F_1 ... F_s``, never formed whole.

A safe mode that changes s links (s small) has ``L_q = L + sum_i rho_i b_i b_i^T``. Its
eigenvectors are ``U F_1 ... F_s`` with ``U`` the eigenvectors of L and ``F_i`` the factors of
:mod:`glocal_verify.numerics.rank_one`. The certified checks read rows of ``U_q`` (the monitors
and the switching components: ``|R| N^2`` per factor), a few of its columns, and the bounds of
:class:`~glocal_verify.numerics.spectrum.Spectrum`; none of them needs ``U_q`` whole, so the
N x N x N product and the ``syrk`` of its orthonormality check are not made. The bounds come
from the factors instead, in O(N^2) per factor:

Orthonormality
    ``Uh = U_prev F`` (exact product) has ``Uh^T Uh - I = F^T (U_prev^T U_prev - I) F +
    (F^T F - I)``, so ``eta <= eta_prev (1 + eta_F) + eta_F`` with ``eta_F`` the factor's
    certified bound (:attr:`RankOneFactor.orthogonality`; no ``F^T F`` is formed).
Residuals
    With ``M = M_prev + rho b b^T``, ``z = U_prev^T b`` (exact), ``R_prev = M_prev U_prev - U_prev
    diag(w)`` and the new values ``lambda``,

    .. math:: M U_{prev} F - U_{prev} F \\Lambda' = R_{prev} F + U_{prev} S
              + \\rho (b - U_{prev} z) z^T F,
              \\qquad S = \\operatorname{diag}(w) F - F \\Lambda' + \\rho z z^T F,

    so column k is at most ``sum_j |F_jk| ||r_j|| + sqrt(1 + eta_prev) ||s_k|| + |rho| sqrt(2)
    eta_prev |z^T f_k|`` (for square ``U_prev``, ``||I - U U^T||_2 = ||I - U^T U||_2 <=
    eta_prev``). S is computed column block by column block (O(N^2)) with its rounding, the
    rounding of the rotations and the error of the computed z bounded. The base's residuals
    are its computed ones plus their rounding ``gamma_{k+2} (||L||_F + |w_j|) ||u_j||``, and the
    last step adds ``||fl(L_q) - M_s||_2`` (exact, from the few changed entries).
Entries
    A row or column of ``U_q`` is computed, not exact: :attr:`UpdatedSpectrum.entry_error`
    bounds every entry's error (from ``gamma`` bounds of the products along the chain). The
    certified checks add it to their own error terms.

The update is kept only when its bounds are as good as those of ``eigh`` (module constant
``UPDATE_ACCEPT``); otherwise the caller decomposes ``L_q`` afresh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Sequence

import numpy as np
import scipy.sparse

from glocal_verify.numerics.rank_one import RankOneFactor, rank_one_factor
from glocal_verify.numerics.spectrum import EPS, Spectrum
from glocal_verify.numerics.spectrum import gamma_bound as gamma

__all__ = ["UpdatedSpectrum", "update_spectrum", "UPDATE_ACCEPT"]

#: an update is kept when its certified eigenvalue radius (:attr:`Spectrum.error_radius`, which
#: holds its residual and orthonormality bounds) is at most this many times the base spectrum's,
#: the radius ``eigh`` reaches on the changed matrix to within a few per cent
UPDATE_ACCEPT = 1.5
#: columns per block of the certificate's products (bounded temporaries); more when rotations
#: are many, since each rotation costs a call per block
_COLS = 256
_COLS_ROTATED = 1024
_U = EPS / 2.0
#: rows per block of |U| |y|
_ROWS = 512


@dataclass(frozen=True)
class _ChainBounds:
    residuals: np.ndarray
    eta: float
    entry_error: float


@dataclass(frozen=True, eq=False, repr=False)
class UpdatedSpectrum(Spectrum):
    """``L_q = (U F_1 ... F_s) diag(values) (U F_1 ... F_s)^T`` with the factors kept (module docstring).

    Built by :func:`update_spectrum`. :attr:`values`, :meth:`rows`, :meth:`columns`,
    :meth:`apply`, :meth:`project` and every certified bound work without forming the basis;
    :attr:`vectors` forms it (one GEMM per factor) for callers that need it whole.

    Parameters
    ----------
    matrix : scipy.sparse matrix or ndarray
        ``fl(L_q)``, as for :class:`Spectrum`.
    base : Spectrum
        The spectrum of the normal mode (explicit eigenvectors).
    factors : tuple of RankOneFactor
        One per changed link, in order.
    bounds : _ChainBounds
        The certified residual bounds, loss of orthonormality and entry error.
    """

    base: Spectrum
    factors: tuple[RankOneFactor, ...]
    bounds: _ChainBounds

    def __repr__(self) -> str:
        return f"UpdatedSpectrum(N={self.size}, factors={len(self.factors)}, eta={self.bounds.eta:.3g}, formed={self.formed})"

    @property
    def values(self) -> np.ndarray:
        """Eigenvalues, ascending (read-only), from the last factor."""
        return self.factors[-1].values

    @cached_property
    def _pairs(self) -> tuple[np.ndarray, np.ndarray]:
        U = np.asarray(self.base.vectors)
        for F in self.factors:
            U = F.right_multiply(U)
        U.setflags(write=False)
        return self.values, U

    @property
    def formed(self) -> bool:
        """Whether :attr:`vectors` has been formed (a test of the certified paths: they never need it)."""
        return "_pairs" in self.__dict__

    @cached_property
    def residuals(self) -> np.ndarray:
        """Certified upper bounds on ``||L_q u_i - w_i u_i||_2`` of the exact product basis (rounding included)."""
        return self.bounds.residuals

    @cached_property
    def orthogonality_error(self) -> float:
        """``eta``: certified bound on ``||U_q^T U_q - I||_F`` of the exact product basis (no ``syrk``)."""
        return self.bounds.eta

    @cached_property
    def _gram_loss(self) -> float:
        return self.bounds.eta

    @property
    def entry_error(self) -> float:
        """Bound on the error of every entry :meth:`rows`, :meth:`columns` and :attr:`vectors` return."""
        return self.bounds.entry_error

    def rows(self, idx: Sequence[int] | np.ndarray) -> np.ndarray:
        """Rows ``U_q[idx, :]`` (``|idx| x N``, a new array): ``U[idx, :] F_1 ... F_s``."""
        X = np.asarray(self.base.vectors)[np.asarray(idx, dtype=np.intp), :]
        for F in self.factors:
            X = F.right_multiply(X)
        return X

    def columns(self, idx: Sequence[int] | np.ndarray | slice) -> np.ndarray:
        """Columns ``U_q[:, idx]`` (``N x |idx|``, a new array): ``U (F_1 (... F_s[:, idx]))``."""
        idx = np.arange(self.size)[idx] if isinstance(idx, slice) else np.asarray(idx, dtype=np.intp)
        Y = self.factors[-1].columns(idx)
        for F in reversed(self.factors[:-1]):
            Y = F.apply(Y)
        return np.asarray(self.base.vectors) @ Y

    def apply(self, Y: np.ndarray) -> np.ndarray:
        """``U_q Y`` for ``Y`` of shape ``N x k``."""
        Z = np.asarray(Y, dtype=float)
        for F in reversed(self.factors):
            Z = F.apply(Z)
        return np.asarray(self.base.vectors) @ Z

    def project(self, X: np.ndarray) -> np.ndarray:
        """``U_q^T X`` for ``X`` of shape ``N x k``."""
        Z = np.asarray(self.base.vectors).T @ np.asarray(X, dtype=float)
        for F in self.factors:
            Z = F.apply_transpose(Z)
        return Z


def _base_residual_bounds(base: Spectrum) -> np.ndarray:
    """Rigorous ``||L u_j - w_j u_j||`` of the base: computed norm plus ``gamma_{k+2} (|| |L| ||_2 + |w_j|) ||u_j||`` (Higham, Thm 3.5)."""
    n = base.size
    k = base.row_nonzeros
    unorm = math.sqrt(1.0 + base.orthogonality_error)
    w = np.abs(base.values)
    return (np.asarray(base.residuals) * (1.0 + gamma(n + 2)) + gamma(k + 2) * (base.abs_norm + w) * unorm) * (1.0 + gamma(4))


def _step_residuals(F: RankOneFactor, w: np.ndarray, zhat: np.ndarray, zeta: float, rho: float, r_prev: np.ndarray, eta_prev: float, off: float) -> np.ndarray:
    """Certified residual bounds of ``U_prev F`` as eigenvectors of ``M_prev + rho b b^T`` (module docstring).

    ``zhat`` is the computed ``U_prev^T b``, ``||z - zhat||_2 <= zeta``; ``r_prev`` bounds the
    columns of ``R_prev``; ``off`` bounds ``||b - U_prev z||_2`` (:func:`_complement_norm`).
    """
    n = F.size
    lam = F.values
    omega = F.rotation_rounding
    znorm = float(np.linalg.norm(zhat)) * (1.0 + gamma(n + 2))
    zabs = np.abs(zhat)
    rnorm = float(np.linalg.norm(r_prev)) * (1.0 + gamma(n + 2))
    wspan = np.maximum(np.abs(w[0] - lam), np.abs(w[-1] - lam))  # max_j |w_j - lambda_k| (w ascending)
    arho = abs(rho)
    unorm = math.sqrt(1.0 + eta_prev)
    out = np.empty(n)
    step = _COLS_ROTATED if len(F.rot_c) > 64 else _COLS
    g_n = gamma(n + 3)
    for a in range(0, n, step):
        b = min(a + step, n)
        Fb = F.columns(np.arange(a, b))
        fn = np.linalg.norm(Fb, axis=0) * (1.0 + g_n)
        fn_true = fn * (1.0 + omega)
        dot = zhat @ Fb
        adot = (zabs @ np.abs(Fb)) * (1.0 + g_n)
        Sb = (w[:, None] - lam[None, a:b]) * Fb
        Sb += rho * zhat[:, None] * dot[None, :]
        sn = np.linalg.norm(Sb, axis=0) * (1.0 + g_n)
        del Sb
        err_round = gamma(3) * wspan[a:b] * fn + g_n * arho * znorm * adot + 2.0 * _U * sn
        err_f = (wspan[a:b] + arho * (znorm + zeta) ** 2) * omega * fn
        err_z = arho * (zeta * (np.abs(dot) + g_n * adot + znorm * omega * fn) + (znorm + zeta) * zeta * fn_true)
        s = sn + err_round + err_f + err_z
        c = np.abs(dot) + g_n * adot + znorm * omega * fn + zeta * fn_true
        t = np.minimum((np.abs(Fb).T @ r_prev) * (1.0 + g_n) + omega * fn * rnorm, fn_true * rnorm)
        out[a:b] = (t + unorm * s + arho * off * c) * (1.0 + gamma(8))
    return out


def _complement_norm(U: np.ndarray, i: int, j: int, eta: float) -> float:
    """Upper bound on ``||(I - U U^T) b||_2``, ``b = e_i - e_j``, computed a posteriori (O(N^2)).

    With ``y = fl(U[i] - U[j])`` (``|y - U^T b| <= u |y|``) and ``h = fl(b - fl(U y))``:
    ``||b - U U^T b|| <= ||h|| + gamma_{N+1} || |U| |y| + |b| || + sqrt(1 + eta) u ||y||``
    (Higham, Thm 3.5 for the product and the subtraction). It replaces the a-priori
    ``||I - U U^T||_2 ||b|| <= eta sqrt(2)``, whose ``eta`` is mostly the rounding allowance
    of the orthonormality check, and is never larger than it.
    """
    n = U.shape[0]
    y = U[i] - U[j]
    h = -(U @ y)
    h[i] += 1.0
    h[j] -= 1.0
    ay = np.abs(y)
    ab = np.empty(n)
    for a in range(0, n, _ROWS):  # |U| |y| in blocks of rows: no N x N temporary
        ab[a : a + _ROWS] = np.abs(U[a : a + _ROWS]) @ ay
    ab[i] += 1.0
    ab[j] += 1.0
    ynorm = float(np.linalg.norm(y))
    bound = (float(np.linalg.norm(h)) + gamma(n + 1) * float(np.linalg.norm(ab))) * (1.0 + gamma(n + 2)) + math.sqrt(1.0 + eta) * _U * ynorm * (1.0 + gamma(2))
    return min(bound, math.sqrt(2.0) * eta * (1.0 + gamma(2)))


def _mismatch_norm(matrix: scipy.sparse.csr_matrix | np.ndarray, base_matrix: scipy.sparse.csr_matrix | np.ndarray, changes: Sequence[tuple[int, int, float]]) -> float:
    """Upper bound on ``||fl(L_q) - (fl(L) + sum rho b b^T)||_2`` (its Frobenius norm, exact from the changed entries)."""
    idx = sorted({i for i, _, _ in changes} | {j for _, j, _ in changes})
    Mq = scipy.sparse.csr_matrix(matrix)
    M1 = scipy.sparse.csr_matrix(base_matrix)
    total = Fraction(0)
    for r in idx:
        for c in idx:
            d = Fraction(float(Mq[r, c])) - Fraction(float(M1[r, c]))
            for i, j, rho in changes:
                coef = (1 if r == i else -1 if r == j else 0) * (1 if c == i else -1 if c == j else 0)
                if coef:
                    d -= coef * Fraction(rho)
            total += d * d
    # the matrices differ from L + sum rho b b^T only at the changed pairs, whose rows and columns are `idx`
    return math.sqrt(float(total)) * (1.0 + 4.0 * EPS) if total else 0.0


def update_spectrum(matrix: np.ndarray | scipy.sparse.csr_matrix, base: Spectrum, changes: Sequence[tuple[int, int, float]]) -> UpdatedSpectrum | None:
    """The certified spectrum of ``matrix = base.matrix + sum rho (e_i - e_j)(e_i - e_j)^T`` as factors of ``base``.

    Parameters
    ----------
    matrix : ndarray or scipy.sparse matrix
        ``fl(L_q)``: the changed matrix, its entries rounded once from exact values.
    base : Spectrum
        The spectrum before the changes (explicit eigenvectors).
    changes : sequence of (int, int, float)
        ``(i, j, rho)`` per changed link.

    Returns
    -------
    UpdatedSpectrum or None
        None when a factor fails (:func:`~glocal_verify.numerics.rank_one.rank_one_factor`) or
        the certified bounds are not as good as ``eigh``'s (``UPDATE_ACCEPT``): the caller
        decomposes ``matrix`` afresh.
    """
    n = base.size
    if n == 0 or not changes:
        return None
    U = np.asarray(base.vectors)
    w = np.asarray(base.values)
    eta_base = base.orthogonality_error
    r = _base_residual_bounds(base)
    eta = eta_base
    mu0 = math.sqrt(1.0 + eta_base)
    # entry error along the chain: rows (error of a row as a 2-norm, `row_err`) and columns
    row_err, row_norm = 0.0, mu0
    entry_rows = 0.0
    factors: list[RankOneFactor] = []
    for i, j, rho in changes:
        rows = U[[i, j], :]
        for G in factors:
            rows = G.right_multiply(rows)
        zhat = rows[0] - rows[1]
        zeta = (2.0 * math.sqrt(n) * entry_rows + gamma(1) * float(np.linalg.norm(zhat))) * (1.0 + gamma(n + 4))
        made = rank_one_factor(w, zhat, rho)
        if made is None:
            return None
        F = made
        # ||(I - U_prev U_prev^T) b||: U_prev = U F_1 ... with ||I - F F^T||_2 <= eta_F for square F
        off = _complement_norm(U, i, j, eta_base)
        grow = mu0 * mu0
        for G in factors:
            off += grow * G.orthogonality * math.sqrt(2.0)
            grow *= G.norm**2
        off = min(off * (1.0 + gamma(4)), math.sqrt(2.0) * eta * (1.0 + gamma(2)))
        r = _step_residuals(F, w, zhat, zeta, rho, r, eta, off)
        # rows through F: rotations (omega, a 2-norm) and the block product (gamma_m, entrywise)
        tau = (F.rotation_rounding + gamma(F.live_size + 2) * (1.0 + F.rotation_rounding) * (1.0 + F.rotation_defect)) * (1.0 + F.column_error)
        entry_rows = row_err * F.norm + tau * row_norm
        row_err = row_err * F.norm + math.sqrt(n) * tau * row_norm
        row_norm = row_norm * F.norm + row_err
        eta = eta * (1.0 + F.orthogonality) + F.orthogonality
        factors.append(F)
        w = np.asarray(F.values)
    # columns: F_s e_c is exact but for the rotations; each further factor is a product of
    # V (gamma_m per entry, sqrt(N) of them in a 2-norm) and rotations; then U times the result
    col_err = factors[-1].rotation_rounding * (1.0 + factors[-1].column_error)
    col_norm = factors[-1].norm
    for F in reversed(factors[:-1]):
        step = math.sqrt(n) * gamma(F.live_size + 2) * math.sqrt(1.0 + F.cauchy_gram) * (1.0 + F.rotation_rounding) + F.rotation_rounding * F.norm
        col_err = col_err * F.norm + step * (col_norm + col_err)
        col_norm *= F.norm
    entry_cols = gamma(n + 2) * mu0 * (col_norm + col_err) + mu0 * col_err
    mismatch = _mismatch_norm(matrix, base.matrix, changes)
    r = r + mismatch * math.sqrt(1.0 + eta) * (1.0 + gamma(2))
    r.setflags(write=False)
    bounds = _ChainBounds(residuals=r, eta=eta * (1.0 + gamma(4)), entry_error=max(entry_rows, entry_cols) * (1.0 + gamma(8)))
    sp = UpdatedSpectrum(matrix, base, tuple(factors), bounds)
    if not sp.error_radius <= UPDATE_ACCEPT * base.error_radius:
        return None
    return sp
