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
``update_accept`` (:mod:`glocal_verify.config`): its eigenvalue radius within 1.5 times the larger of the base's and the one an
``eigh`` of the whole matrix carries); otherwise the caller decomposes ``L_q`` afresh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from typing import Sequence

import numpy as np
import scipy.sparse

from glocal_verify import config
from glocal_verify.numerics.rank_one import RankOneFactor, rank_one_factor
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.rounding import UNIT_ROUNDOFF as _U
from glocal_verify.numerics.rounding import gamma_bound as gamma
from glocal_verify.numerics.spectrum import Spectrum

__all__ = ["UpdatedSpectrum", "update_spectrum"]

#: columns per block of the certificate's products (bounded temporaries); more when rotations
#: are many, since each rotation costs a call per block
_COLS = 256
_COLS_ROTATED = 1024


@dataclass(frozen=True)
class _ChainBounds:
    """The certified state at the end of a chain of factors (a longer chain continues from it).

    ``residuals`` bound the columns of ``M U_q - U_q diag(values)`` for the matrix ``M`` of the
    spectrum and ``frobenius`` its Frobenius norm (sharper than the columns' bounds together);
    ``estimates`` are the same recurrence on the computed residual norms, without rounding
    allowances and with the propagated residuals combined in 2-norm (for tolerance readings);
    ``eta`` the loss of orthonormality; ``row_err`` / ``row_norm`` the 2-norm of a
    computed row's error and of the row, ``entry_rows`` the error of a computed row entry,
    ``entry_error`` that of any computed entry (rows, columns, the formed basis).
    """

    residuals: np.ndarray
    frobenius: float
    estimates: np.ndarray
    eta: float
    row_err: float
    row_norm: float
    entry_rows: float
    entry_error: float


@dataclass(frozen=True, eq=False, repr=False)
class UpdatedSpectrum(Spectrum):
    """``L_q = (U F_1 ... F_s) diag(values) (U F_1 ... F_s)^T`` with the factors kept (module docstring).

    Built by :func:`update_spectrum`. :attr:`values`, :meth:`rows`, :meth:`columns`,
    :meth:`apply`, :meth:`project` and every certified bound work without forming the basis;
    :attr:`vectors` forms it (one GEMM per factor) for callers that need it whole. Computed
    rows are kept (on this object), so the checks that read the same monitors share them.

    Parameters
    ----------
    matrix : scipy.sparse matrix or ndarray
        ``fl(L_q)``, as for :class:`Spectrum`.
    base : Spectrum
        The spectrum the factors start from (explicit eigenvectors, or a block-diagonal
        :class:`~glocal_verify.numerics.block_spectrum.BlockSpectrum`).
    factors : tuple of RankOneFactor
        One per changed link, in order.
    bounds : _ChainBounds
        The certified residual bounds, loss of orthonormality and entry errors.
    parent : UpdatedSpectrum, optional
        The spectrum whose chain this one continues (its factors are the first ones here): rows
        and products go through it, so the rows it has computed are not computed again.
    """

    base: Spectrum
    factors: tuple[RankOneFactor, ...]
    bounds: _ChainBounds
    parent: UpdatedSpectrum | None = None
    _row_cache: dict[int, np.ndarray] = field(default_factory=dict, compare=False)
    _col_cache: dict[int, np.ndarray] = field(default_factory=dict, compare=False)

    @property
    def _inner(self) -> tuple[Spectrum, tuple[RankOneFactor, ...]]:
        """(the spectrum the own factors act on, the own factors): the parent's rows and products are shared."""
        if self.parent is None:
            return self.base, self.factors
        return self.parent, self.factors[len(self.parent.factors) :]

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

    @property
    def residual_estimates(self) -> np.ndarray:
        """Estimates of the residual norms for the tolerance readings (not certified; :class:`_ChainBounds`)."""
        return self.bounds.estimates

    @cached_property
    def residual_frobenius(self) -> float:
        """Certified bound on ``||L_q U_q - U_q diag(values)||_F``."""
        return min(self.bounds.frobenius, float(np.linalg.norm(self.bounds.residuals)))

    @cached_property
    def orthogonality_error(self) -> float:
        """``eta``: certified bound on ``||U_q^T U_q - I||_F`` of the exact product basis (no ``syrk``)."""
        return self.bounds.eta

    @property
    def entry_error(self) -> float:
        """Bound on the error of every entry :meth:`rows`, :meth:`columns` and :attr:`vectors` return."""
        return self.bounds.entry_error

    @property
    def explicit(self) -> bool:
        """False: the basis is the product of the factors (formed only for :attr:`vectors`)."""
        return False

    @property
    def entry_estimate(self) -> float:
        """``sqrt(N) u`` per factor: the typical (not the worst-case) rounding of a computed entry, for tolerance readings."""
        return len(self.factors) * math.sqrt(self.size) * _U

    def rows(self, idx: Sequence[int] | np.ndarray) -> np.ndarray:
        """Rows ``U_q[idx, :]`` (``|idx| x N``, a new array): ``U[idx, :] F_1 ... F_s``, each row computed once."""
        idx = [int(i) for i in np.asarray(idx, dtype=np.intp).ravel()]
        missing = [i for i in dict.fromkeys(idx) if i not in self._row_cache]
        if missing:
            inner, own = self._inner
            X = inner.rows(missing)
            for F in own:
                X = F.right_multiply(X)
            for i, row in zip(missing, X):
                row.setflags(write=False)
                self._row_cache[i] = row
        if not idx:
            return np.zeros((0, self.size))
        return np.array([self._row_cache[i] for i in idx])

    def columns(self, idx: Sequence[int] | np.ndarray | slice) -> np.ndarray:
        """Columns ``U_q[:, idx]`` (``N x |idx|``, a new array): ``U (F_1 (... F_s[:, idx]))``, each computed once.

        A column the own factors leave a unit vector ``e_t`` (a deflated eigenvector: the
        change does not touch it) is the inner spectrum's column t, which the parent keeps.
        """
        idx = np.arange(self.size)[idx] if isinstance(idx, slice) else np.asarray(idx, dtype=np.intp)
        want = [int(i) for i in dict.fromkeys(idx.tolist()) if int(i) not in self._col_cache]
        if want:
            inner, own = self._inner
            Y = own[-1].columns(np.asarray(want, dtype=np.intp))
            for F in reversed(own[:-1]):
                Y = F.apply(Y)
            top = np.argmax(np.abs(Y), axis=0) if Y.size else np.zeros(0, dtype=np.intp)
            unit = (np.count_nonzero(Y, axis=0) == 1) & (Y[top, np.arange(Y.shape[1])] == 1.0)
            got = np.empty((self.size, len(want)))
            if np.any(unit):
                got[:, unit] = inner.columns(top[unit])
            if not np.all(unit):
                got[:, ~unit] = inner.apply(Y[:, ~unit])
            fresh = {i: got[:, k] for k, i in enumerate(want)}
            if len(want) <= config.get("keep_columns_max"):  # a request for most of the basis is not kept (read vectors instead)
                for i, col in fresh.items():
                    col = col.copy()
                    col.setflags(write=False)
                    self._col_cache[i] = col
        else:
            fresh = {}
        if not len(idx):
            return np.zeros((self.size, 0))
        return np.column_stack([fresh[int(i)] if int(i) in fresh else self._col_cache[int(i)] for i in idx])

    def abs_apply(self, y: np.ndarray) -> np.ndarray:
        """Not available for a factored basis (its absolute values are not at hand)."""
        raise NotImplementedError("|U_q| |y| of a factored spectrum: bound it through its factors instead")

    def _apply_real(self, Y: np.ndarray) -> np.ndarray:
        inner, own = self._inner
        Z = Y
        for F in reversed(own):
            Z = F.apply(Z)
        return inner.apply(Z)

    def _project_real(self, X: np.ndarray) -> np.ndarray:
        inner, own = self._inner
        Z = inner.project(X)
        for F in own:
            Z = F.apply_transpose(Z)
        return Z


def _base_residual_bounds(base: Spectrum) -> np.ndarray:
    """Rigorous ``||L u_j - w_j u_j||`` of the base: computed norm plus ``gamma_{k+2} (|| |L| ||_2 + |w_j|) ||u_j||`` (Higham, Thm 3.5)."""
    n = base.size
    k = base.row_nonzeros
    unorm = math.sqrt(1.0 + base.orthogonality_error)
    w = np.abs(base.values)
    return (np.asarray(base.residuals) * (1.0 + gamma(n + 2)) + gamma(k + 2) * (base.abs_norm + w) * unorm) * (1.0 + gamma(4))


def _step_residuals(
    F: RankOneFactor,
    w: np.ndarray,
    zhat: np.ndarray,
    zeta: float,
    rho: float,
    r_prev: np.ndarray,
    frob_prev: float,
    est_prev: np.ndarray,
    eta_prev: float,
    off: float,
    off_est: float,
) -> tuple[np.ndarray, float, np.ndarray]:
    """Certified residual bounds of ``U_prev F`` as eigenvectors of ``M_prev + rho b b^T`` (module docstring): per column, and in Frobenius norm.

    ``zhat`` is the computed ``U_prev^T b``, ``||z - zhat||_2 <= zeta``; ``r_prev`` bounds the
    columns of ``R_prev`` and ``frob_prev`` its Frobenius norm; ``off`` bounds
    ``||b - U_prev z||_2`` (:func:`_complement_norm`). The Frobenius bound takes each term as
    a matrix (``||R_prev F||_F <= ||R_prev||_F ||F||_2``, ``||rho (z z^T - zhat zhat^T) F||_F <=
    |rho| ||F||_2 zeta (2 ||zhat|| + zeta)``), where adding the columns' bounds would count an
    error of z once per column. The third result are the estimates, not bounds: the three
    terms taken as independent errors, ``sqrt(sum_j F_jk^2 est_j^2 + ||s_hat_k||^2 +
    (|rho| off_est zhat^T f_k)^2)`` with ``est_prev`` the previous estimates.
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
    est = np.empty(n)
    est_sq = np.asarray(est_prev) ** 2
    s_sq = 0.0  # squares of the computed S and of its rounding, over the columns
    e_sq = 0.0
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
        s_sq += float(np.sum(sn * sn))
        e_sq += float(np.sum((err_round + err_f) ** 2))
        c = np.abs(dot) + g_n * adot + znorm * omega * fn + zeta * fn_true
        t = np.minimum((np.abs(Fb).T @ r_prev) * (1.0 + g_n) + omega * fn * rnorm, fn_true * rnorm)
        out[a:b] = (t + unorm * s + arho * off * c) * (1.0 + gamma(8))
        est[a:b] = np.sqrt((Fb * Fb).T @ est_sq + sn * sn + (arho * off_est * dot) ** 2)
    mu = F.norm
    s_frob = math.sqrt(s_sq) * (1.0 + gamma(n + 2)) + math.sqrt(e_sq) * (1.0 + gamma(n + 2)) + arho * mu * zeta * (2.0 * znorm + zeta)
    frob = (frob_prev * mu + unorm * s_frob + arho * off * mu * (znorm + zeta)) * (1.0 + gamma(8))
    return out, frob, est


def _complement_norm(base: Spectrum, i: int, j: int, y: np.ndarray) -> tuple[float, float]:
    """Upper bound on ``||(I - U U^T) b||_2``, ``b = e_i - e_j``, for the basis U of ``base``, computed a posteriori (O(N^2)), and the computed norm.

    With ``y = fl(U[i] - U[j])`` (given: the caller has it; ``|y - U^T b| <= u |y|``) and ``h = fl(b - fl(U y))``:
    ``||b - U U^T b|| <= ||h|| + gamma_{N+1} || |U| |y| + |b| || + sqrt(1 + eta) u ||y||``
    (Higham, Thm 3.5 for the product and the subtraction). It replaces the a-priori
    ``||I - U U^T||_2 ||b|| <= eta sqrt(2)``, whose ``eta`` is mostly the rounding allowance
    of the orthonormality check, and is never larger than it.
    """
    n = base.size
    eta = base.orthogonality_error
    h = -base.apply(y[:, None])[:, 0]
    h[i] += 1.0
    h[j] -= 1.0
    ab = base.abs_apply(y)
    ab[i] += 1.0
    ab[j] += 1.0
    ynorm = float(np.linalg.norm(y))
    hnorm = float(np.linalg.norm(h))
    bound = (hnorm + gamma(n + 1) * float(np.linalg.norm(ab))) * (1.0 + gamma(n + 2)) + math.sqrt(1.0 + eta) * _U * ynorm * (1.0 + gamma(2))
    return min(bound, math.sqrt(2.0) * eta * (1.0 + gamma(2))), hnorm


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
        The spectrum before the changes: explicit eigenvectors, a block-diagonal spectrum, or
        an :class:`UpdatedSpectrum` (whose chain of factors is continued).
    changes : sequence of (int, int, float)
        ``(i, j, rho)`` per changed link.

    Returns
    -------
    UpdatedSpectrum or None
        None when a factor fails (:func:`~glocal_verify.numerics.rank_one.rank_one_factor`) or
        the certified bounds are not as good as ``eigh``'s (``update_accept`` (:mod:`glocal_verify.config`)): the caller
        decomposes ``matrix`` afresh.
    """
    n = base.size
    if n == 0 or not changes:
        return None
    if isinstance(base, UpdatedSpectrum):  # continue its chain: the previous matrix is base.matrix
        root, factors = base.base, list(base.factors)
        st = base.bounds
        r, frob, est, eta = np.asarray(st.residuals), st.frobenius, np.asarray(st.estimates), st.eta
        row_err, row_norm, entry_rows = st.row_err, st.row_norm, st.entry_rows
    else:
        root, factors = base, []
        r, eta = _base_residual_bounds(base), base.orthogonality_error
        frob = float(np.linalg.norm(r)) * (1.0 + gamma(n + 2))
        est = np.asarray(base.residual_estimates)
        row_err, row_norm, entry_rows = 0.0, math.sqrt(1.0 + base.orthogonality_error), 0.0
    if root.entry_error != 0.0:  # the chain starts from eigenvectors held explicitly (exact floats)
        return None
    mu0 = math.sqrt(1.0 + root.orthogonality_error)
    w = np.asarray(base.values)
    for i, j, rho in changes:
        # z = U_prev^T b = F_k^T ... F_1^T (U_root^T b), its error bounded a posteriori factor by factor
        rows = root.rows([i, j])
        y_root = rows[0] - rows[1]
        zhat = y_root
        zeta = gamma(1) * float(np.linalg.norm(zhat))
        for G in factors:
            zhat, e = G.transpose_vector(zhat)
            zeta = zeta * G.norm + e
        zeta *= 1.0 + gamma(4)
        made = rank_one_factor(w, zhat, rho)
        if made is None:
            return None
        F = made
        # ||(I - U_prev U_prev^T) b||: U_prev = U_root F_1 ... with ||I - F F^T||_2 <= eta_F for square F
        off, off_est = _complement_norm(root, i, j, y_root)
        grow = mu0 * mu0
        for G in factors:
            off += grow * G.orthogonality * math.sqrt(2.0)
            grow *= G.norm**2
        off = min(off * (1.0 + gamma(4)), math.sqrt(2.0) * eta * (1.0 + gamma(2)))
        r, frob, est = _step_residuals(F, w, zhat, zeta, rho, r, frob, est, eta, off, off_est)
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
    mismatch = _mismatch_norm(matrix, base.matrix, changes)  # a Frobenius norm: ||D U||_F <= ||D||_F ||U||_2
    r = r + mismatch * math.sqrt(1.0 + eta) * (1.0 + gamma(2))
    frob = (frob + mismatch * math.sqrt(1.0 + eta)) * (1.0 + gamma(2))
    r.setflags(write=False)
    est.setflags(write=False)
    bounds = _ChainBounds(
        residuals=r,
        frobenius=frob,
        estimates=est,
        eta=eta * (1.0 + gamma(4)),
        row_err=row_err,
        row_norm=row_norm,
        entry_rows=entry_rows,
        entry_error=max(entry_rows, entry_cols) * (1.0 + gamma(8)),
    )
    sp = UpdatedSpectrum(matrix, root, tuple(factors), bounds, base if isinstance(base, UpdatedSpectrum) else None)
    # as good as eigh: within update_accept of the base's radius, or of the radius an eigh of the
    # whole matrix carries (its certificate's product rounding, ~N^2 u for delocalized
    # eigenvectors, times 2 max|w|), whichever is larger: a base built from small blocks is far
    # sharper than eigh, and its links may cost some of that
    eigh_level = 2.0 * gamma(n + 1) * n * float(np.max(np.abs(sp.values)))
    if not sp.error_radius <= config.get("update_accept") * max(base.error_radius, eigh_level):
        return None
    return sp
