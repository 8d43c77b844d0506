"""Existence of an unknown-input observer for a cluster and the certificates it rests on.

The observer of Chen, Patton & Zhang (1996) exists iff ``rank(C E) = rank(E)`` and
``(C, (I - h C) A)`` is detectable with ``h = E (C E)^+``. Here: the observable split of a
pair, default poles and the pole ladder, Hurwitz certificates (numeric with an error bound,
exact by Routh-Hurwitz) and :func:`uio_existence` / :func:`uio_existence_exact`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

import flint

from glocal_verify.errors import NotApplicableError
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.hurwitz import matrix_operator, routh_hurwitz
from glocal_verify.numerics.threads import single_threaded
from glocal_verify.numerics.tolerance import (
    DEFAULT_TOLERANCE,
    Decision,
    Tolerance,
    numeric_rank,
)
from glocal_verify.results import Status

__all__ = [
    "Decoupling",
    "Detectability",
    "ObservableSplit",
    "UIOExistence",
    "cluster_detectability",
    "decoupling",
    "default_poles",
    "observable_split",
    "uio_existence",
    "uio_existence_exact",
]

# --------------------------------------------------------------------------------------------
# observable / unobservable split


@dataclass(frozen=True, slots=True)
class ObservableSplit:
    """Orthonormal bases of the observable and unobservable subspaces of (A, C).

    Attributes
    ----------
    Qo : ndarray
        Columns span the observable subspace Im [C; C A; ...]^T.
    Qu : ndarray
        Columns span its orthogonal complement, the unobservable subspace (A-invariant).
    decided : bool
        False when some rank step had a singular value in the undecided band.
    """

    Qo: np.ndarray
    Qu: np.ndarray
    decided: bool


def observable_split(A: np.ndarray, C: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> ObservableSplit:
    """Observable subspace of (A, C) by an orthogonal Krylov iteration on (A^T, C^T).

    Starting from an orthonormal basis V of Im C^T, the new directions (I - V V^T) A^T V are
    added while they have singular values above ``rtol * band * max(||A||_2, ||C||_2)``;
    singular values between ``rtol`` and ``rtol * band`` times that scale make the split
    undecided. The observability matrix is never formed.
    """
    n = A.shape[0]
    scale = max(float(np.linalg.norm(A, 2)) if n else 0.0, float(np.linalg.norm(C, 2)) if C.size else 0.0)
    return _observable_split(A, C, tol, scale)


def _observable_split(A: np.ndarray, C: np.ndarray, tol: Tolerance, scale: float) -> ObservableSplit:
    """:func:`observable_split` with ``scale = max(||A||_2, ||C||_2)`` given by the caller."""
    n = A.shape[0]
    scale = max(scale, 1e-300)
    decided = True
    if C.size == 0:
        return ObservableSplit(np.zeros((n, 0)), np.eye(n), True)
    At = matrix_operator(A.T)
    U, s, _ = np.linalg.svd(C.T, full_matrices=False)
    keep = s > tol.upper * scale
    if np.any((s > tol.rtol * scale) & ~keep):
        decided = False
    # the basis grows in place: every new block is orthonormal (left singular vectors) and
    # orthogonal to the current basis (two Gram-Schmidt passes), so no re-factorisation of the
    # whole basis is needed (that made the iteration O(n^4))
    Vbuf = np.zeros((n, n))
    k = int(np.sum(keep))
    Vbuf[:, :k] = U[:, keep]
    new = Vbuf[:, :k]
    while k < n and new.shape[1] > 0:
        V = Vbuf[:, :k]
        W = At @ new
        W = W - V @ (V.T @ W)
        W = W - V @ (V.T @ W)  # re-orthogonalise
        U, s, _ = np.linalg.svd(W, full_matrices=False)
        keep = s > tol.upper * scale
        if np.any((s > tol.rtol * scale) & ~keep):
            decided = False
        b = min(int(np.sum(keep)), n - k)
        Vbuf[:, k : k + b] = U[:, keep][:, :b]
        new = Vbuf[:, k : k + b]
        k += b
    V = Vbuf[:, :k].copy()
    if k >= n:
        return ObservableSplit(V, np.zeros((n, 0)), decided)
    Qfull = np.linalg.qr(V, mode="complete")[0]
    Qu = np.ascontiguousarray(Qfull[:, k:])
    return ObservableSplit(V, Qu, decided)


def _keep_threshold(gamma: float) -> float:
    return 0.9 * float(gamma) / 2.0


def default_poles(eigenvalues: np.ndarray, gamma: float = 1.0) -> np.ndarray:
    """Default observer poles from the observable eigenvalues mu of A_1.

    With sigma = gamma / 2 (the decay rate of the agents' underdamped modes, Re of the roots of
    lam^2 + gamma lam + alpha mu_L = 0), an eigenvalue with Re mu <= -0.9 sigma is kept where
    it is (no gain is spent on it); any other becomes -|Re mu| - sigma + i Im mu, so every pole
    has Re <= -0.9 sigma and conjugate pairs stay pairs. Moving only the slow modes keeps K_1
    small: placing all poles of a large cluster far from the open-loop spectrum makes the gain
    (and the eigenvalue sensitivity of F) grow like a power of the distance. Repeated moved
    values are spread by multiples of -0.01 sigma so no pole is requested more often than
    place_poles allows; the two members of a conjugate pair get the same shift.

    Parameters
    ----------
    eigenvalues : ndarray
        Eigenvalues of A_1 on its observable part.
    gamma : float
        Velocity damping of the agents.
    """
    sigma = float(gamma) / 2.0
    keep = _keep_threshold(gamma)
    mu = np.asarray(eigenvalues, dtype=complex)
    out = mu.copy()
    seen: dict[tuple[float, float, int], int] = {}
    for k, m in enumerate(mu):
        if m.real <= -keep:
            continue
        p = complex(-abs(m.real) - sigma, m.imag)
        # the sign of Im is part of the key: the two members of a conjugate pair are counted
        # separately and get the same shift (rounding Im alone merged x + 1e-10 i with its
        # conjugate, shifted only one of them and broke the pair)
        key = (round(p.real, 8), round(abs(p.imag), 8), int(np.sign(p.imag)))
        c = seen.get(key, 0)
        seen[key] = c + 1
        out[k] = p - 0.01 * sigma * c
    if np.all(np.abs(out.imag) == 0.0):
        return out.real
    return out


def _schur_eigvals(T: np.ndarray) -> np.ndarray:
    """Eigenvalues of a real quasi-triangular Schur factor, read off its 1x1 and 2x2 blocks."""
    n = T.shape[0]
    out: list[complex] = []
    k = 0
    while k < n:
        if k + 1 < n and T[k + 1, k] != 0.0:
            a, b, c, d = T[k, k], T[k, k + 1], T[k + 1, k], T[k + 1, k + 1]
            tr, det = (a + d) / 2.0, a * d - b * c
            r = np.sqrt(complex(tr * tr - det))
            out += [complex(tr + r), complex(tr - r)]
            k += 2
        else:
            out.append(complex(T[k, k]))
            k += 1
    return np.asarray(out)


def _slow_schur(Aoo: np.ndarray, gamma: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Real Schur form of Aoo^T ordered with the eigenvalues Re <= -0.9 sigma first."""
    import scipy.linalg

    keep = _keep_threshold(gamma)
    T, Q, k = scipy.linalg.schur(Aoo.T, output="real", sort=lambda x, y: x <= -keep)
    return T, Q, int(k)


@dataclass(frozen=True, slots=True)
class _Reduction:
    """Orthogonal Q (n_o x n_o) with Q^T (Aoo - Lo Co)^T Q = [[T11, *], [0, *]], T11 (kept x kept)
    quasi-triangular; ``sub[i]`` says whether T11[i + 1, i] opens a 2 x 2 block."""

    Q: np.ndarray
    kept: int
    sub: np.ndarray


def _place_slow(
    Aoo: np.ndarray, Co: np.ndarray, gamma: float, tol: Tolerance, theta: float = 0.9, schur: tuple[np.ndarray, np.ndarray, int] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, _Reduction]:
    """Gain Lo moving only the slow modes of Aoo (partial placement through an ordered Schur form).

    The real Schur form of Aoo^T is ordered with the kept eigenvalues first:
    Q^T Aoo^T Q = [[T11, T12], [0, T22]]. With Lo = Q2 G^T, Q^T (Aoo - Lo Co)^T Q =
    [[T11, T12 - Y1 G], [0, T22 - Y2 G]] (Y = Q^T Co^T), so the kept eigenvalues stay and
    eig(T22 - Y2 G) are placed at the default poles of the slow ones. With ``theta`` < 0.9 the
    small block T22 is reordered once more (its eigenvalues with Re <= -theta sigma join the
    kept ones), so fewer, only the slowest, modes are moved.

    Returns (Lo, requested poles, eigenvalues of Aoo - Lo Co, the reduction), the eigenvalues
    read off the (block) triangular form instead of a new eigen-decomposition; the reduction
    (the orthogonal basis and the size of the untouched quasi-triangular block) lets
    :func:`~glocal_verify.numerics.hurwitz.hurwitz_reduced` certify F without a new dense eigen-decomposition.
    """
    import scipy.linalg

    no = Aoo.shape[0]
    T, Q, k = schur if schur is not None else _slow_schur(Aoo, gamma)
    kept = _schur_eigvals(T[:k, :k])
    sub = np.diag(T[:k, :k], -1) != 0.0
    T22, Q2 = T[k:, k:], Q[:, k:]
    if theta < 0.9 and k < no:
        S, Z, j = scipy.linalg.schur(T22, output="real", sort=lambda x, y: x <= -theta * float(gamma) / 2.0)
        j = int(j)
        kept = np.concatenate([kept, _schur_eigvals(S[:j, :j])])
        if j:
            sub = np.concatenate([sub, [False] if k else [], np.diag(S[:j, :j], -1) != 0.0]).astype(bool)
        T22, Q2 = S[j:, j:], (Q2 @ Z)[:, j:]
        Q = np.hstack([Q[:, :k], Q[:, k:] @ Z])
        k += j
    red = _Reduction(Q, k, sub)
    if T22.shape[0] == 0:
        return np.zeros((no, Co.shape[0])), default_poles(kept, gamma), kept, red
    Y2 = Q2.T @ Co.T
    want = default_poles(_schur_eigvals(T22), gamma)
    G = _place_dual(T22, Y2, want, tol)
    placed = np.concatenate([kept, np.linalg.eigvals(T22 - Y2 @ G)])
    return np.asarray(Q2 @ G.T), np.concatenate([kept, np.asarray(want, dtype=complex)]), placed, red


def _placed(M: np.ndarray, p: np.ndarray) -> bool:
    """Every requested pole is within 1e-8 max(1, max |p|) of an eigenvalue of M."""
    got = np.linalg.eigvals(M)
    return bool(max(float(np.min(np.abs(got - z))) for z in p) <= 1e-8 * max(1.0, float(np.max(np.abs(p)))))


def _place_square(X: np.ndarray, B: np.ndarray, p: np.ndarray) -> np.ndarray | None:
    """G = B^{-1} (X - Lambda) for B square and invertible: X - B G = Lambda, the real block
    diagonal matrix of the poles (real ones ascending, then each pair re +- i im, ascending, as
    the block [[re, |im|], [-|im|, re]]), the choice :func:`scipy.signal.place_poles` makes for
    full-rank B.
    None when the poles are not closed under conjugation."""
    real = np.sort(p[p.imag == 0.0].real)
    pairs = np.sort(p[p.imag < 0.0])
    ns = X.shape[0]
    if len(real) + 2 * len(pairs) != ns:
        return None
    Lam = np.zeros((ns, ns))
    Lam[np.arange(len(real)), np.arange(len(real))] = real
    for j, z in enumerate(pairs):
        i = len(real) + 2 * j
        Lam[i : i + 2, i : i + 2] = [[z.real, -z.imag], [z.imag, z.real]]  # z.imag < 0
    return np.asarray(np.linalg.lstsq(B, X - Lam, rcond=None)[0])


def _place_dual(X: np.ndarray, Y: np.ndarray, poles: np.ndarray, tol: Tolerance) -> np.ndarray:
    """G with eig(X - Y G) = poles (Y compressed to full column rank r first).

    When r equals the number of states (compressed Y square and invertible) G is the closed
    form of :func:`_place_square`, checked by recomputing the eigenvalues; otherwise (or if
    that check fails) :func:`scipy.signal.place_poles` (method YT).
    """
    U, s, Vh = np.linalg.svd(Y, full_matrices=False)
    r = int(np.sum(s > tol.upper * max(float(s[0]) if len(s) else 0.0, 1e-300)))
    Bp = U[:, :r] * s[:r]
    p = np.asarray(poles, dtype=complex)
    if r == X.shape[0] and r > 0:
        # the slow blocks of the default design usually have as many outputs as states: the
        # closed form below is what place_poles computes then, without importing scipy.signal
        Gs = _place_square(X, Bp, p)
        if Gs is not None and np.all(np.isfinite(Gs)) and _placed(X - Bp @ Gs, p):
            return np.asarray(Vh[:r].T @ Gs)
    if np.all(p.imag == 0):
        p = p.real
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # YT convergence is about robustness, not accuracy
            from scipy.signal import (
                place_poles,  # lazily: importing scipy.signal costs seconds
            )

            res = place_poles(X, Bp, p, method="YT", maxiter=10)
    except ValueError as exc:
        raise NotApplicableError(f"pole placement failed: {exc}") from None
    return np.asarray(Vh[:r].T @ res.gain_matrix)


# --------------------------------------------------------------------------------------------
# existence


@dataclass(frozen=True, slots=True)
class UIOExistence:
    """Whether a UIO exists for (A, E, C), with the evidence.

    Attributes
    ----------
    status : Status
        HOLDS when rank(C E) = rank(E) and (C, A_1) is detectable.
    rank_condition : Status
        Verdict of rank(C E) = rank(E).
    detectable : Status
        Verdict of the detectability of (C, A_1) (FAILS also when the rank condition fails).
    h, T, A1 : ndarray or None
        The decoupling matrices (None when the rank condition fails).
    split : ObservableSplit or None
        Observable/unobservable split of (A_1, C).
    unobservable_eigenvalues : ndarray
        Eigenvalues of A_1 on the unobservable subspace (fixed eigenvalues of F).
    unstable_mode : tuple (eigenvalue, vector) or None
        An unobservable eigenvalue with Re >= 0 and its eigenvector (state coordinates).
    margin : float
        -max Re of the unobservable eigenvalues (inf when there are none); negative when
        detectability fails.
    """

    status: Status
    rank_condition: Status
    detectable: Status
    h: np.ndarray | None
    T: np.ndarray | None
    A1: np.ndarray | None
    split: ObservableSplit | None
    unobservable_eigenvalues: np.ndarray
    unstable_mode: tuple[complex, np.ndarray] | None
    margin: float


@dataclass(frozen=True, slots=True)
class Decoupling:
    """The rank condition rank(C E) = rank(E) of a UIO and, when it holds, h = E (C E)^+.

    Attributes
    ----------
    status : Status
    h : ndarray or None
    """

    status: Status
    h: np.ndarray | None = None


def decoupling(E: np.ndarray, C: np.ndarray, tol: Tolerance) -> Decoupling:
    """Decide rank(C E) = rank(E) at ``tol`` (:func:`~glocal_verify.numerics.tolerance.numeric_rank`) and give h.

    Parameters
    ----------
    E, C : ndarray
    tol : Tolerance
    """
    rE = numeric_rank(E, tol)
    rCE = numeric_rank(C @ E, tol, scale=max(rE.scale, 1e-300))
    if not (rE.decided and rCE.decided):
        return Decoupling(Status.UNDECIDED)
    if rCE.rank < rE.rank:
        return Decoupling(Status.FAILS)
    return Decoupling(Status.HOLDS, E @ np.linalg.pinv(C @ E, rcond=tol.upper))


@single_threaded
def uio_existence(A: np.ndarray, E: np.ndarray, C: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> UIOExistence:
    """Decide UIO existence numerically (Chen, Patton & Zhang 1996, Theorem 1).

    Rank condition decided by :func:`~glocal_verify.numerics.tolerance.numeric_rank` (singular values of
    C E relative to ||E||_2). Detectability: eigenvalues of A_1 on the unobservable subspace of
    (A_1, C) (:func:`observable_split`); Re(mu) <= -rtol * band * ||A_1|| is stable,
    Re(mu) > -rtol * ||A_1|| unstable, in between undecided.
    """
    n = A.shape[0]
    dc = decoupling(E, C, tol)
    rank_st, h = dc.status, dc.h
    empty = np.zeros(0, dtype=complex)
    if h is None:
        return UIOExistence(rank_st if rank_st is Status.UNDECIDED else Status.FAILS, rank_st, Status.FAILS if rank_st is Status.FAILS else Status.UNDECIDED, None, None, None, None, empty, None, -np.inf)
    T = np.eye(n) - h @ C
    A1 = A - h @ (C @ A)  # = T A, in O(n^2 p) instead of a dense n^3 product
    scale = max(float(np.linalg.norm(A1, 2)), 1e-300)
    split = _observable_split(A1, C, tol, max(scale, float(np.linalg.norm(C, 2)) if C.size else 0.0))
    Qu = split.Qu
    if Qu.shape[1] == 0:
        det = Status.HOLDS if split.decided else Status.UNDECIDED
        return UIOExistence(det, rank_st, det, h, T, A1, split, empty, None, np.inf)
    Auu = Qu.T @ A1 @ Qu
    mu, W = np.linalg.eig(Auu)
    worst = int(np.argmax(mu.real))
    dec = [tol.decide(min(m.real, 0.0), scale) for m in mu]
    unstable = [k for k, m in enumerate(mu) if m.real >= 0 or dec[k] is Decision.ZERO]
    undecided = [k for k, d in enumerate(dec) if d is Decision.UNDECIDED and k not in unstable]
    mode = None
    if unstable:
        k = max(unstable, key=lambda j: mu[j].real)
        det = Status.FAILS
        mode = (complex(mu[k]), Qu @ W[:, k])
    elif undecided or not split.decided:
        det = Status.UNDECIDED
    else:
        det = Status.HOLDS
    return UIOExistence(det, rank_st, det, h, T, A1, split, mu, mode, float(-mu[worst].real))


@dataclass(frozen=True, slots=True)
class Detectability:
    """The structured detectability verdict of a cluster model (:func:`cluster_detectability`).

    Attributes
    ----------
    status : Status
    positions : ndarray or None
        On failure the positions p of an unobservable mode at lam = 0 (the mode is [p; 0]).
    by : str
        ``"zero forcing"`` or ``"rank"``.
    """

    status: Status
    positions: np.ndarray | None
    by: str


@single_threaded
def cluster_detectability(
    L: np.ndarray, boundary: Sequence[int], positions: Sequence[int], tol: Tolerance = DEFAULT_TOLERANCE
) -> Detectability:
    """Detectability of (C_loc, A_1) for the cluster model of eq. ``cluster_dyn2``, structurally.

    Assumes A = [[0, I], [-alpha L, -gamma I]] with alpha, gamma > 0 and L = L[P_i, P_i]
    symmetric positive semidefinite (positive weights), E^i the boundary velocity columns and
    C_loc = blkdiag(S_{M_x}, S_{M_v}) with Proposition III.2 (ii) holding (every boundary
    velocity measured). Then h C_loc is the projector onto the boundary velocities, so
    A_1 = (I - h C_loc) A is A with the velocity rows of the boundary agents set to zero, and
    a PBH vector x = [p; v] of (C_loc, A_1) at lam satisfies v = lam p and

    * lam != 0: p vanishes on M ∪ dP_i (boundary rows give lam v_b = 0) and, on the remaining
      agents U', (s I + alpha L[U', U']) p_{U'} = 0 with s = lam^2 + gamma lam; so s =
      -alpha mu with mu >= 0 an eigenvalue of the PSD matrix L[U', U'], and the roots of
      lam^2 + gamma lam + alpha mu have Re lam < 0 unless mu = 0, where lam in {0, -gamma};
      every unobservable mode with lam != 0 is stable;
    * lam = 0: v = 0, p_{M_x} = 0 and (L p)_{P_i \\ dP_i} = 0.

    Hence (C_loc, A_1) is detectable iff L[P_i \\ dP_i, P_i \\ M_x] has full column rank. Zero
    forcing from M_x with the boundary rows as inputs proves it combinatorially
    (:func:`glocal_verify.analysis.local.cluster_pencil.zero_forcing_closure`); otherwise the smallest singular
    value relative to the largest is decided at ``tol``.

    Parameters
    ----------
    L : ndarray
        Laplacian block L[P_i, P_i].
    boundary : sequence of int
        Cluster indices of dP_i.
    positions : sequence of int
        Cluster indices of M_x (measured positions).
    tol : Tolerance

    Returns
    -------
    Detectability
        The verdict, on failure the positions p of an unobservable mode at lam = 0 (the mode
        is [p; 0]), and how it was decided (``"zero forcing"`` or ``"rank"``).
    """
    from glocal_verify.analysis.local.cluster_pencil import (
        intra_neighbours,
        zero_forcing_closure,
    )

    n = L.shape[0]
    inp = set(boundary)
    known = set(positions)
    if len(zero_forcing_closure(intra_neighbours(L), known, inp)) == n:
        return Detectability(Status.HOLDS, None, "zero forcing")
    rows = [k for k in range(n) if k not in inp]
    cols = [k for k in range(n) if k not in known]
    p = np.zeros(n)
    if not rows:  # every agent on the boundary: nothing constrains the unmeasured positions
        p[cols[0]] = 1.0
        return Detectability(Status.FAILS, p, "rank")
    M0 = np.asarray(L, dtype=float)[np.ix_(rows, cols)]
    if len(rows) < len(cols):
        p[cols] = np.linalg.svd(M0, full_matrices=True)[2][-1]
        return Detectability(Status.FAILS, p, "rank")
    # the singular values decide; the vectors (a 2-5 times dearer SVD) only for a failure
    sv = np.linalg.svd(M0, compute_uv=False)
    d = tol.decide(sv[-1], sv[0]) if sv[0] > 0 else Decision.ZERO
    if d is Decision.ZERO:
        p[cols] = np.linalg.svd(M0, full_matrices=True)[2][-1]
        return Detectability(Status.FAILS, p, "rank")
    return Detectability(Status.HOLDS if d is Decision.NONZERO else Status.UNDECIDED, None, "rank")


# --------------------------------------------------------------------------------------------
# exact existence


@dataclass(frozen=True, slots=True)
class _ExactExistence:
    status: Status
    rank_condition: Status
    rank_E: int
    rank_CE: int
    unobservable_dim: int
    unobservable_charpoly: list[Fraction]
    h: list[list[Fraction]] | None


def uio_existence_exact(A: ex.Rows, E: ex.Rows, C: ex.Rows, *, _reference: bool = False) -> _ExactExistence:
    """UIO existence over Q: rank(C E) = rank(E) and the characteristic polynomial of A_1
    restricted to the unobservable subspace of (A_1, C) is Hurwitz (Routh test).

    Parameters
    ----------
    A, E, C : Rows
        The cluster matrices over Q (``n x n``, ``n x m``, ``p x n``).
    _reference : bool
        Use the original Fraction-list implementation (kept as the reference the fast path
        is tested against) instead of :func:`~glocal_verify.observers.uio_exact.unobservable_charpoly_exact`.

    Returns
    -------
    _ExactExistence
        The exact verdict, ranks, unobservable dimension and characteristic polynomial, and h.
    """
    if _reference:
        return _uio_existence_exact_reference(A, E, C)
    from glocal_verify.observers.uio_exact import unobservable_charpoly_exact

    n = len(A)
    got = _exact_decoupling(E, C, n)
    if isinstance(got, _ExactExistence):
        return got
    rE, rCE, h, Cm = got
    A1 = _decoupled_state(A, h, Cm, n)
    k, coeffs = unobservable_charpoly_exact(A1, Cm)
    hq = [[ex.to_fraction(x) for x in h.entries()[i * h.ncols() : (i + 1) * h.ncols()]] for i in range(h.nrows())]
    if k == 0:
        return _ExactExistence(Status.HOLDS, Status.HOLDS, rE, rCE, 0, [Fraction(1)], hq)
    st = Status.HOLDS if routh_hurwitz(coeffs[::-1]) else Status.FAILS
    return _ExactExistence(st, Status.HOLDS, rE, rCE, k, coeffs, hq)


def _exact_decoupling(E: ex.Rows, C: ex.Rows, n: int) -> _ExactExistence | tuple[int, int, Any, Any]:
    """The rank condition over Q and, when it holds, ``h = E (C E)^+`` (flint matrices, local
    to the caller): ``(rank E, rank C E, h, C)`` or the failing verdict."""
    m = len(E[0]) if E else 0
    Em = ex.to_fmpq_mat(E, m)
    Cm = ex.to_fmpq_mat(C, n)
    CE = Cm * Em
    rE, rCE = int(Em.rank()), int(CE.rank()) if CE.nrows() else 0
    if rCE < rE:
        return _ExactExistence(Status.FAILS, Status.FAILS, rE, rCE, -1, [], None)
    if m == 0 or rE == 0:
        h = flint.fmpq_mat(n, Cm.nrows())
    else:
        # E full column rank (as built by the model); C E then has full column rank too
        CEt = CE.transpose()
        h = Em * ((CEt * CE).inv() * CEt)
    return rE, rCE, h, Cm


def _decoupled_state(A: ex.Rows, h: Any, Cm: Any, n: int) -> Any:
    """A_1 = (I - h C) A over Q (flint)."""
    T = flint.fmpq_mat(n, n, [int(i == j) for i in range(n) for j in range(n)]) - h * Cm
    return T * ex.to_fmpq_mat(A, n)


def _uio_existence_exact_reference(A: ex.Rows, E: ex.Rows, C: ex.Rows) -> _ExactExistence:
    """Reference implementation of :func:`uio_existence_exact` (Fraction round trips, the
    observable row space by re-stacking ``[R; R A_1]``, restriction by a normal-equation
    inverse); slow, kept to test the fast path against."""
    n = len(A)
    got = _exact_decoupling(E, C, n)
    if isinstance(got, _ExactExistence):
        return got
    rE, rCE, h, Cm = got
    A1 = _decoupled_state(A, h, Cm, n)
    # observable row space: the smallest space of row vectors containing the rows of C and
    # closed under right multiplication by A1; R := rref([R; R A1]) until the rank is stable
    R, rk = Cm.rref()
    r = int(rk)
    while 0 < r < n:
        Rb = ex.to_fmpq_mat([[ex.to_fraction(R[i, j]) for j in range(n)] for i in range(r)], n)
        stacked = ex.to_fmpq_mat(
            [[ex.to_fraction(M[i, j]) for j in range(n)] for M in (Rb, Rb * A1) for i in range(r)], n
        )
        R2, rk2 = stacked.rref()
        if int(rk2) == r:
            break
        R, r = R2, int(rk2)
    rows = [[ex.to_fraction(R[i, j]) for j in range(n)] for i in range(r)]
    N = ex.nullspace(rows, n) if rows else [[Fraction(int(i == j)) for i in range(n)] for j in range(n)]
    hq = [[ex.to_fraction(h[i, j]) for j in range(h.ncols())] for i in range(h.nrows())]
    if not N:
        return _ExactExistence(Status.HOLDS, Status.HOLDS, rE, rCE, 0, [Fraction(1)], hq)
    Nb = ex.to_fmpq_mat([list(col) for col in zip(*N)], len(N))  # n x k
    X = (Nb.transpose() * Nb).inv() * (Nb.transpose() * (A1 * Nb))
    p = X.charpoly()
    coeffs = [ex.to_fraction(p[k]) for k in range(p.degree() + 1)]
    st = Status.HOLDS if routh_hurwitz(coeffs[::-1]) else Status.FAILS
    return _ExactExistence(st, Status.HOLDS, rE, rCE, len(N), coeffs, hq)
