"""Stability tests, in one place: certified Hurwitz tests of a float matrix, exact Hurwitz and Schur tests over Q.

Floating point. F is certified Hurwitz when every eigenvalue lies left of the imaginary axis
by more than ``band`` times its uncertainty ``rho_i = kappa_i * delta`` (``kappa_i`` the
eigenvalue condition number, ``delta = rtol ||F||_2`` the backward error):
:func:`hurwitz_certificate` (one dense eigen-decomposition with left and right vectors), and
:func:`hurwitz_reduced` from a known block triangularisation (triangular back substitution for
the condition numbers). :func:`hurwitz_enclosure` encloses every eigenvalue of the exact
matrix a float one stands for (Bauer-Fike). Used by the observer designs of
:mod:`glocal_verify.observers`.

Exact (python-flint). :func:`routh_hurwitz` (coefficients) and :func:`routh_hurwitz_poly`
(an ``fmpq_poly``): every root in the open left half-plane, by the Routh array;
:func:`schur_cohn`: every root in the open unit disc; :func:`unobservable_schur_stable`: the
unobservable part of a rational pair (A, C) is Schur stable (discrete detectability). These
are the only exact stability tests of the package: the central observer, the UIO existence
test and the sampled checkers call them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import flint
import numpy as np

from glocal_verify import config
from glocal_verify.numerics.exact import observable_rows
from glocal_verify.numerics.pencil_exact import rational_kernel
from glocal_verify.numerics.rounding import EPS, gamma_bound, svd_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import Status

__all__ = [
    "HurwitzCertificate",
    "HurwitzEnclosure",
    "hurwitz_certificate",
    "hurwitz_eigenvalues",
    "hurwitz_enclosure",
    "hurwitz_reduced",
    "matrix_operator",
    "norm2",
    "routh_hurwitz",
    "routh_hurwitz_poly",
    "schur_cohn",
    "unobservable_schur_stable",
]


@dataclass(frozen=True, slots=True)
class HurwitzCertificate:
    """Is F Hurwitz, allowing for eigenvalue sensitivity (:func:`hurwitz_certificate`)?

    Attributes
    ----------
    status : Status
    ratio : float
        The worst ratio -Re lambda_i / rho_i (the margin in units of uncertainty).
    eigenvalues : ndarray
        The eigenvalues of F the certificate read (empty when not kept).
    """

    status: Status
    ratio: float
    eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))


def hurwitz_certificate(F: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> HurwitzCertificate:
    """Decide whether F is Hurwitz, allowing for eigenvalue sensitivity.

    With backward error delta = rtol * ||F||_2 and kappa_i = 1 / |y_i^H x_i| the condition
    number of eigenvalue lambda_i (unit left and right eigenvectors), lambda_i is known to within
    rho_i = kappa_i * delta. F is certified Hurwitz when Re lambda_i < -band * rho_i for every i,
    certainly not Hurwitz when some Re lambda_i > band * rho_i, undecided otherwise.

    Parameters
    ----------
    F : ndarray
    tol : Tolerance

    Returns
    -------
    HurwitzCertificate
        The verdict and the worst ratio -Re lambda_i / rho_i (no eigenvalues kept).
    """
    got = hurwitz_eigenvalues(F, tol)
    return HurwitzCertificate(got.status, got.ratio)


def hurwitz_eigenvalues(F: np.ndarray, tol: Tolerance) -> HurwitzCertificate:
    """:func:`hurwitz_certificate` with the eigenvalues of F (one eigen-decomposition).

    Parameters
    ----------
    F : ndarray
    tol : Tolerance
    """
    import scipy.linalg

    if F.size == 0:
        return HurwitzCertificate(Status.HOLDS, float("inf"))
    w, vl, vr = scipy.linalg.eig(F, left=True, right=True)
    vl = vl / np.linalg.norm(vl, axis=0)
    vr = vr / np.linalg.norm(vr, axis=0)
    kappa = 1.0 / np.maximum(np.abs(np.sum(vl.conj() * vr, axis=0)), 1e-300)
    rho = kappa * tol.rtol * max(norm2(F), 1e-300)
    ratio = -w.real / rho
    return HurwitzCertificate(_decide_ratios(ratio, tol), float(np.min(ratio)), w)


def _real_to_complex_schur(S: np.ndarray) -> np.ndarray:
    """Complex upper triangular unitarily similar to the real quasi-triangular S (each 2 x 2
    block split by a Givens rotation, as :func:`scipy.linalg.rsf2csf`, without the basis)."""
    T = S.astype(complex)
    n = T.shape[0]
    for m in range(n - 1, 0, -1):
        if T[m, m - 1] != 0.0:
            mu = np.linalg.eigvals(T[m - 1 : m + 1, m - 1 : m + 1]) - T[m, m]
            r = float(np.hypot(abs(mu[0]), abs(T[m, m - 1])))
            c, sn = mu[0] / r, T[m, m - 1] / r
            G = np.array([[np.conj(c), sn], [-sn, c]])
            T[m - 1 : m + 1, m - 1 :] = G @ T[m - 1 : m + 1, m - 1 :]
            T[: m + 1, m - 1 : m + 1] = T[: m + 1, m - 1 : m + 1] @ G.conj().T
        T[m, m - 1] = 0.0
    return T


def _triangular_kappa(T: np.ndarray, twin: np.ndarray | None = None) -> np.ndarray:
    """Condition numbers kappa_i = ||x_i|| ||y_i|| / |y_i^H x_i| of the eigenvalues T[i, i] of an
    upper triangular T, from its right (x_i) and left (y_i) eigenvectors by back substitution.

    x_i has x_i[i] = 1 and zeros below i, y_i^H has y_i[i] = 1 and zeros before i, so
    y_i^H x_i = 1. A divisor T[j, j] - T[i, i] smaller than u (|Re| + |Im|) of T[i, i] is
    replaced by that value (the perturbation of LAPACK's xTREVC); a non-finite result gives
    kappa = inf (nothing can be certified from it). ``twin[i]`` True means that T[i, i] is the
    conjugate of T[i - 1, i - 1] in a T unitarily similar to a real matrix: its condition number
    is the same (conjugate eigenvectors of the real matrix) and is not computed again.
    """
    n = T.shape[0]
    lam = np.diag(T).copy()
    smin = np.maximum(EPS / 2 * (np.abs(lam.real) + np.abs(lam.imag)), np.finfo(float).tiny)
    tw = np.zeros(n, dtype=bool) if twin is None else np.asarray(twin, dtype=bool)
    cols = np.flatnonzero(~tw)  # ascending; the eigenvalues whose vectors are computed
    nc = len(cols)
    lc, sc = lam[cols], smin[cols]

    def guard(d: np.ndarray, m: np.ndarray) -> np.ndarray:
        return np.where(np.abs(d) < m, m, d)

    X = np.zeros((n, nc), dtype=complex)  # columns: right eigenvectors of T[cols, cols]
    Yh = np.zeros((nc, n), dtype=complex)  # rows: left eigenvectors (conjugated)
    X[cols, np.arange(nc)] = 1.0
    Yh[np.arange(nc), cols] = 1.0
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for j in range(n - 2, -1, -1):
            a = int(np.searchsorted(cols, j + 1))  # columns c with cols[c] > j
            if a < nc:
                X[j, a:] = -(T[j, j + 1 :] @ X[j + 1 :, a:]) / guard(T[j, j] - lc[a:], sc[a:])
        for j in range(1, n):
            b = int(np.searchsorted(cols, j))  # rows c with cols[c] < j
            if b:
                Yh[:b, j] = -(Yh[:b, :j] @ T[:j, j]) / guard(T[j, j] - lc[:b], sc[:b])
        kc = np.linalg.norm(X, axis=0) * np.linalg.norm(Yh, axis=1)
    kappa = np.empty(n)
    kappa[cols] = kc
    for i in np.flatnonzero(tw):
        kappa[i] = kappa[i - 1]
    return np.where(np.isfinite(kappa), kappa, np.inf)


def hurwitz_reduced(F: np.ndarray, W: np.ndarray, kept: int, sub: np.ndarray, tol: Tolerance) -> HurwitzCertificate | None:
    """:func:`hurwitz_eigenvalues` from a known block triangularisation of F^T; None when it does not apply.

    W (n x n, orthonormal columns) is such that R = W^T F^T W is block upper triangular with a
    quasi-triangular leading block of size ``kept`` (2 x 2 blocks where ``sub`` is True): for
    the UIO, W = [Qo Q, Qu] with Q the ordered Schur basis of the default design (the kept
    eigenvalues stay, the moved ones and the unobservable ones form the trailing block). The
    trailing block is brought to real Schur form, the rest of R is kept upper quasi-triangular
    and the entries dropped below it (rounding, and the part of A_1 Qu outside Qu that the
    numerical observable split leaves) have Frobenius norm ``d``. Then F^T is within d (plus
    the rounding of orthogonal transformations, far below rtol ||F||_2) of a matrix similar to
    the quasi-triangular S, and the certificate of :func:`hurwitz_certificate` is applied to
    the eigenvalues of S (its diagonal blocks) and their condition numbers
    (:func:`_triangular_kappa`, invariant under the unitary similarities) with
    delta = rtol ||F||_2 + d, never smaller than the dense certificate's. Used only when
    d <= rtol ||F||_2 and the trailing block has at most ``hurwitz_reduced_tail`` (:mod:`glocal_verify.config`) states.
    """
    import scipy.linalg

    n = F.shape[0]
    m = n - kept
    if n == 0 or m > config.get("hurwitz_reduced_tail") or W.shape != (n, n) or len(sub) != max(kept - 1, 0):
        return None
    R = W.T @ np.asarray(matrix_operator(F.T) @ W)
    if m:
        S2, Z2 = scipy.linalg.schur(R[kept:, kept:], output="real")
        R[:, kept:] = R[:, kept:] @ Z2
        R[kept:, :] = Z2.T @ R[kept:, :]
        R[kept:, kept:] = S2
    keep_sub = np.zeros(max(n - 1, 0), dtype=bool)
    keep_sub[: max(kept - 1, 0)] = sub
    if m:
        keep_sub[kept:] = np.diag(R[kept:, kept:], -1) != 0.0
    S = np.triu(R)
    i = np.flatnonzero(keep_sub)
    S[i + 1, i] = R[i + 1, i]
    dropped = float(np.linalg.norm(R - S))
    delta = tol.rtol * max(norm2(F), 1e-300)
    if not dropped <= delta:
        return None
    Tc = _real_to_complex_schur(S)
    w = np.diag(Tc).copy()
    twin = np.zeros(n, dtype=bool)
    twin[i + 1] = True  # the second eigenvalue of every 2 x 2 block: the conjugate of the first
    rho = _triangular_kappa(Tc, twin) * (delta + dropped)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(np.isfinite(rho), -w.real / rho, 0.0)
    return HurwitzCertificate(_decide_ratios(ratio, tol), float(np.min(ratio)), w)


def norm2(M: np.ndarray) -> float:
    """``||M||_2`` (an SVD; the norm enters the uncertainty rho, so it is never underestimated)."""
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def matrix_operator(A: np.ndarray) -> Any:
    """``A`` as a CSR matrix when it is sparse (the cluster matrices A_1 are: a few nonzeros per
    row), else A itself; products A V are then O(nnz(A) k) instead of O(n^2 k) and differ from
    the dense ones only by rounding (each entry is the same sum of products)."""
    n = A.shape[0]
    if n < config.get("sparse_min") or np.count_nonzero(A) > config.get("sparse_density") * n * n:
        return A
    import scipy.sparse

    return scipy.sparse.csr_matrix(A)


def _decide_ratios(ratio: np.ndarray, tol: Tolerance) -> Status:
    """Hurwitz from the ratios -Re(w_i) / rho_i: holds when all exceed the band, fails when one is below -band."""
    if np.all(ratio > tol.band):
        return Status.HOLDS
    if np.any(ratio < -tol.band):
        return Status.FAILS
    return Status.UNDECIDED


@dataclass(frozen=True, slots=True)
class HurwitzEnclosure:
    """Eigenvalue enclosure of an exact matrix from a computed eigen-decomposition.

    Attributes
    ----------
    certified : bool or None
        True: every eigenvalue of the exact matrix has Re < 0; False: some has Re > 0 (an
        isolated disc right of the axis); None: the enclosure cannot tell.
    max_real_upper : float
        max_i Re(lambda_i) + radius: an upper bound of the spectral abscissa.
    radius : float
        Every eigenvalue of the exact matrix lies within ``radius`` of a computed one.
    eigenvalues : ndarray
        The computed eigenvalues.
    """

    certified: bool | None
    max_real_upper: float
    radius: float
    eigenvalues: np.ndarray


def hurwitz_enclosure(F: np.ndarray, input_error: float = 0.0) -> HurwitzEnclosure:
    """Certify that the exact matrix F_exact (||F - F_exact||_2 <= ``input_error``) is Hurwitz.

    With the computed eigen-decomposition F V ~ V D, the residual R = F V - V D (bounded
    including the rounding of its own evaluation, gamma_{n+2} (|F||V| + |V||D|)) gives
    V^{-1} F_exact V = D + V^{-1}(R + (F_exact - F) V), so by Bauer-Fike every eigenvalue of
    F_exact lies within

    .. math:: r = \\frac{\\lVert R \\rVert_F + \\delta_R + \\varepsilon_{in}\\,\\sigma_{max}(V)}{\\sigma_{min}(V)}

    of an entry of D, with sigma_min(V) bounded below by its computed value minus
    :func:`svd_error`. Hurwitz is certified when max Re d_i + r < 0; a failure when some disc
    lies right of the axis and meets no other disc (a component of one disc holds exactly
    one eigenvalue).

    Parameters
    ----------
    F : ndarray
        Square float matrix.
    input_error : float
        Upper bound of ``||F - F_exact||_2``.
    """
    F = np.asarray(F)
    n = F.shape[0]
    if n == 0:
        return HurwitzEnclosure(True, -math.inf, 0.0, np.zeros(0, dtype=complex))
    w, V = np.linalg.eig(F)
    R = F @ V - V * w
    g = gamma_bound(2 * (n + 2))  # (n + 2) eps / (1 - (n + 2) eps)
    dR = g * float(np.linalg.norm(np.abs(F) @ np.abs(V) + np.abs(V) * np.abs(w)))
    sv = np.linalg.svd(V, compute_uv=False)
    e = svd_error(V)
    smin = float(sv[-1]) - e
    if smin <= 0.0:
        return HurwitzEnclosure(None, math.inf, math.inf, w)
    r = (float(np.linalg.norm(R)) * (1.0 + 4 * n * EPS) + dR + float(input_error) * (float(sv[0]) + e)) / smin
    r *= 1.0 + 8 * EPS
    top = float(np.max(w.real)) + r
    if top < 0.0:
        return HurwitzEnclosure(True, top, r, w)
    for k in range(n):
        if w[k].real - r > 0.0 and all(abs(w[k] - w[j]) > 2 * r for j in range(n) if j != k):
            return HurwitzEnclosure(False, top, r, w)
    return HurwitzEnclosure(None, top, r, w)


# --------------------------------------------------------------------------------------------
# exact tests over Q


def routh_hurwitz(coeffs: Sequence[Fraction]) -> bool:
    """Exact Routh-Hurwitz test: are all roots of the real polynomial in the open left half-plane?

    ``coeffs`` are rational, highest degree first. A polynomial is Hurwitz iff every entry of
    the first column of its Routh array is nonzero and has the sign of the leading coefficient;
    a zero entry already implies a root with ``Re >= 0``, so no epsilon trick is needed.
    Computed by :func:`routh_hurwitz_poly`.

    Parameters
    ----------
    coeffs : sequence of Fraction
        Coefficients ``a_n, ..., a_0`` with ``a_n != 0``.
    """
    c = [Fraction(x) for x in coeffs]
    while c and c[0] == 0:
        c.pop(0)
    return routh_hurwitz_poly(flint.fmpq_poly([flint.fmpq(x.numerator, x.denominator) for x in reversed(c)]))


def routh_hurwitz_poly(q: Any) -> bool:
    r"""The Routh-Hurwitz test of :func:`routh_hurwitz` on a python-flint ``fmpq_poly``, fraction-free.

    A row r_k is the polynomial sum_j r_k[j] t^j. The Routh recurrence
    R_{k+1} = (R_k[0] R_{k-1} - R_{k-1}[0] R_k) / (t R_k[0]) is run on the integer rows
    F_k = Delta_{k-1} R_k (Delta_k the Hurwitz determinants, F_k[0] = Delta_k for k >= 1,
    F_0 = R_0, F_1 = R_1 for the integer coefficients):

    .. math:: F_{k+1} = \frac{F_k[0] F_{k-1} - F_{k-1}[0] F_k}{t\, c_{k-1}},\qquad
              c_0 = c_1 = 1,\ c_j = F_{j-1}[0]\ (j \ge 2),

    an exact integer division (Bareiss-like; a division that is not exact sends the
    polynomial to the rational reference, :func:`_routh_hurwitz_rational`). The test stops at
    the first F_k[0] <= 0; before that every c_k is positive, so the signs of the first
    column and which rows vanish are those of the rational Routh array, without a gcd per
    rational entry (the cost that dominated at degree 400).

    Parameters
    ----------
    q : flint.fmpq_poly
    """
    if q.is_zero():
        return False
    c = [flint.fmpz(int(x.p)) for x in reversed((q * q.denom()).coeffs())]
    if len(c) == 1:
        return True
    if (rows := _first_rows(c, flint.fmpz_poly)) is None:
        return False
    r0, n0, r1, n1 = rows
    lead = [flint.fmpz(1), flint.fmpz(1), r1[0]]  # c_0, c_1 (= Delta_0), Delta_1, Delta_2, ...
    while n1:
        if r1[0] <= 0:
            return False
        nxt, nn = (r0 * r1[0] - r1 * r0[0]).truncate(n0).right_shift(1), n0 - 1
        div = lead[-3]
        if div != 1:
            quo = [x // div for x in nxt.coeffs()]
            if any(a * div != x for a, x in zip(quo, nxt.coeffs())):  # pragma: no cover - Sylvester's identity
                return _routh_hurwitz_rational(q)
            nxt = flint.fmpz_poly(quo)
        while nn > 1 and nxt[nn - 1] == 0:
            nn -= 1
        if nn and nxt.is_zero():
            return False
        r0, n0, r1, n1 = r1, n1, nxt, nn
        lead.append(r1[0] if n1 else flint.fmpz(0))
    return bool(r0[0] > 0)


def _first_rows(c: list[Any], poly: Any) -> tuple[Any, int, Any, int] | None:
    """The first two rows of the Routh array of the coefficients ``c`` (highest degree first,
    as polynomials ``poly``, with their lengths), the leading sign made positive; None when a
    coefficient is not of the leading sign (then the polynomial is not Hurwitz)."""
    sign = 1 if c[0] > 0 else -1
    c = [sign * x for x in c]
    if any(x <= 0 for x in c):
        return None
    return poly(c[0::2]), len(c[0::2]), poly(c[1::2]), len(c[1::2])


def _routh_hurwitz_rational(q: Any) -> bool:
    """The Routh array in exact rationals, row by row (the reference of :func:`routh_hurwitz_poly`).

    r_{k+1} = (r_{k-1} - (r_{k-1}[0] / r_k[0]) r_k) / t, of length len(r_{k-1}) - 1 with
    trailing zeros dropped.

    Parameters
    ----------
    q : flint.fmpq_poly
    """
    c = list(reversed(q.coeffs()))
    if not c:
        return False
    if len(c) == 1:
        return True
    if (rows := _first_rows(c, flint.fmpq_poly)) is None:
        return False
    r0, n0, r1, n1 = rows
    while n1:
        if r1[0] <= 0:
            return False
        nxt, nn = (r0 - r1 * (r0[0] / r1[0])).truncate(n0).right_shift(1), n0 - 1
        while nn > 1 and nxt[nn - 1] == 0:
            nn -= 1
        if nn and nxt.is_zero():
            return False
        r0, n0, r1, n1 = r1, n1, nxt, nn
    return bool(r0[0] > 0)


def schur_cohn(p: Any) -> bool:
    """Exact Schur-Cohn test over Q: every root of the rational polynomial ``p`` has modulus < 1.

    Recursion: with ``a_0, a_n`` the constant and leading coefficients and ``p*`` the
    reversed polynomial, ``p`` is Schur-stable iff ``|a_0| < |a_n|`` and
    ``(a_n p - a_0 p*) / z`` is (Schur-Cohn, real coefficients). Each step is made primitive
    over Z (a positive scaling changes no root), so the coefficients grow slowly.

    Parameters
    ----------
    p : flint.fmpq_poly or fmpz_poly
    """
    c = [Fraction(int(x.p), int(x.q)) if hasattr(x, "p") else Fraction(x) for x in (p[k] for k in range(p.degree() + 1))]
    ints = _primitive(c)
    while len(ints) > 1:
        a0, an = ints[0], ints[-1]
        if abs(a0) >= abs(an):
            return False
        rev = ints[::-1]
        ints = _primitive([Fraction(an * ints[k] - a0 * rev[k]) for k in range(1, len(ints))])
    return True


def _primitive(c: list[Fraction]) -> list[int]:
    """The coefficients times their common denominator, divided by their gcd (sign kept)."""
    den = math.lcm(*(x.denominator for x in c)) if c else 1
    ints = [int(x * den) for x in c]
    g = math.gcd(*ints) if any(ints) else 1
    return [x // g for x in ints]


def unobservable_schur_stable(A: Any, C: Any) -> bool:
    """Exactly: the unobservable part of the rational pair ``(A, C)`` is Schur stable.

    R spans the observable rows (the Krylov closure of the rows of C under A,
    :func:`~glocal_verify.numerics.exact.observable_rows`); with X a basis of its kernel
    (the unobservable subspace, A-invariant), the restriction of A to it is
    ``(X^T X)^-1 X^T A X``, whose characteristic polynomial is tested by :func:`schur_cohn`.

    Parameters
    ----------
    A, C : flint.fmpq_mat
        n x n and p x n.
    """
    R = observable_rows(A, C)
    if R.nrows() == A.ncols():
        return True
    X = rational_kernel(R)
    XT = X.transpose()
    return schur_cohn(((XT * X).inv() * (XT * A * X)).charpoly())
