"""Balancing of a state-space system before its pencil is analysed, and the rounding bounds of the deflation.

Power-of-two diagonal scalings of states, inputs and outputs (exact in floating point, so
ranks, zeros and kernels are unchanged) chosen by a log-least-squares fit of the nonzero
entries (Ward's criterion, as in LAPACK xGGBAL; in the spirit of SLICOT TB01ID and
MatrixPencils.jl), and the orthogonal deflation steps with their certified backward error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.linalg.blas
import scipy.linalg.lapack
import scipy.sparse
import scipy.sparse.csgraph
import scipy.sparse.linalg

from glocal_verify import config
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.threads import ThreadSwitch
from glocal_verify.numerics.tolerance import Tolerance

#: private helpers of :mod:`glocal_verify.numerics.pencil`; nothing here is public API
__all__: list[str] = []

#: components of a direction below this relative size in the imaginary part are made real
_REAL_CUTOFF = 1e-15


def _rosenbrock(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, lam: complex) -> np.ndarray:
    n = A.shape[0]
    top = np.hstack([lam * np.eye(n) - A, -B])
    bottom = np.hstack([C, D])
    return np.vstack([top, bottom])


#: the stated constant c of the backward-error model ``||E|| <= c d eps ||M||`` of one SVD or
#: one application of Householder reflectors to a matrix M with d = rows + columns
_ROUNDING = 8.0
#: unitary operations per deflation step (SVD of D, SVD of the output rows, reflectors on A)
_OPS_PER_STEP = 3
#: balancing exponents are clipped to +-this, so every scaling and its inverse stays normal
_MAX_EXPONENT = 400


def _norm2(M: np.ndarray) -> float:
    if M.size == 0:
        return 0.0
    if min(M.shape) <= config.get("exact_norm_max"):
        return float(np.linalg.norm(M, 2))
    # power iteration on M^H M: a lower estimate within a few per cent after 60 steps
    rng = np.random.default_rng(0)
    x: np.ndarray = np.asarray(rng.standard_normal(M.shape[1]))
    est = 0.0
    for _ in range(60):
        y = M.conj().T @ (M @ x)
        ny = float(np.linalg.norm(y))
        if ny == 0.0:
            return float(np.abs(M).max())
        est = math.sqrt(ny / float(np.linalg.norm(x)))
        x = y / ny
    return max(est, float(np.abs(M).max()))


def block_norm(a: float, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> float:
    """||[[a, ||B||], [||C||, ||D||]]||_2 with a = ||A||_2: an upper bound of ||[A B; C D]||_2 when
    ``a`` is exact (thin B, C, D: their norms by :func:`_norm2`, exact up to 600 columns)."""
    blocks = np.array([[a, _norm2(B)], [_norm2(C), _norm2(D)]])
    return float(np.linalg.norm(blocks, 2))


def _rounding(d: int, norm: float) -> float:
    """Stated backward-error bound ``c d eps ||M||`` (c = ``_ROUNDING``) of one SVD or one
    application of Householder reflectors to a matrix with d = rows + columns (LAPACK Users'
    Guide section 4.9; Higham, Accuracy and Stability of Numerical Algorithms, ch. 19)."""
    return _ROUNDING * max(int(d), 1) * EPS * float(norm)


# ------------------------------------------------------------------------------------------
# balancing


def _balance_exponents(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integer exponents (e_t, e_u, e_y) of the power-of-two balancing t = 2^e_t, su = 2^e_u, sy = 2^e_y.

    The balanced system is (T^-1 A T, T^-1 B Su, Sy C T, Sy D Su). The exponents minimise

    .. math::

        \\sum_{a_{ij} \\ne 0, i \\ne j} (\\log_2|a_{ij}| + x_j - x_i)^2
        + \\sum_{b_{ij} \\ne 0} (\\log_2|b_{ij}| + w_j - x_i)^2
        + \\sum_{c_{kj} \\ne 0} (\\log_2|c_{kj}| + x_j + y_k)^2
        + \\sum_{d_{kj} \\ne 0} (\\log_2|d_{kj}| + w_j + y_k)^2

    (Ward, "Balancing the generalized eigenvalue problem", SIAM J. Sci. Stat. Comput. 2 (1981)
    141-152, the criterion of LAPACK ``xGGBAL``; here with one exponent per state for its row
    and its column, so that lambda I stays lambda I, as in SLICOT TB01ID's system-matrix
    balancing). With z = (x, w, -y) every term reads (z_col - z_row - h)^2: the normal
    equations are a graph Laplacian L z = g, solved per connected component with one node
    grounded. The gauge (a constant per component, which leaves the balanced data unchanged)
    is fixed by a zero mean over the component's input and output nodes, so a scaling of the
    states by powers of two shifts the state exponents by exactly those powers. The exponents
    are rounded to integers and clipped to +-``_MAX_EXPONENT``.
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    N = n + m + p
    e = np.zeros(N)
    if n + p > 0 and n + m > 0:
        S = np.abs(np.block([[A, B], [C, D]])).astype(np.float64)
        if n:
            S[np.arange(n), np.arange(n)] = 0.0
        S[~np.isfinite(S)] = 0.0
        r, c = np.nonzero(S)
        if r.size:
            h = -np.log2(S[r, c])
            rn = np.where(r < n, r, r + m)  # state i -> node i, output k (row n + k) -> node n + m + k
            cn = c  # state j -> node j, input j (column n + j) -> node n + j
            ones = np.ones_like(h)
            L = scipy.sparse.coo_matrix(
                (np.concatenate([ones, ones, -ones, -ones]), (np.concatenate([cn, rn, cn, rn]), np.concatenate([cn, rn, rn, cn]))),
                shape=(N, N),
            ).tocsr()
            g = np.bincount(cn, weights=h, minlength=N) - np.bincount(rn, weights=h, minlength=N)
            ncomp, labels = scipy.sparse.csgraph.connected_components(L, directed=False)
            order = np.argsort(labels, kind="stable")
            bounds = np.searchsorted(labels[order], np.arange(ncomp + 1))
            for k in range(ncomp):
                idx = order[bounds[k] : bounds[k + 1]]
                if idx.size < 2:
                    continue
                Lr = L[idx[1:]][:, idx[1:]]
                if idx.size <= 800:
                    sol = np.linalg.solve(Lr.toarray(), g[idx[1:]])
                else:
                    sol = scipy.sparse.linalg.spsolve(Lr.tocsc(), g[idx[1:]])
                zc = np.concatenate([[0.0], np.asarray(sol, dtype=float)])
                io = idx >= n
                zc = zc - (zc[io].mean() if io.any() else zc.mean())
                e[idx] = zc
    ei = np.clip(np.round(e), -_MAX_EXPONENT, _MAX_EXPONENT).astype(np.int64)
    return ei[:n], ei[n : n + m], -ei[n + m :]


@dataclass(frozen=True, slots=True)
class _Balanced:
    """A system balanced by exact power-of-two scalings (see :func:`_balance_exponents`)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    t: np.ndarray
    su: np.ndarray
    sy: np.ndarray
    #: exponents of diag(T, Su), the map from balanced to caller coordinates of a direction
    right_exp: np.ndarray

    def pencil(self, lam: complex) -> np.ndarray:
        """P_b(lam) = diag(T^-1, Sy) P(lam) diag(T, Su)."""
        return _rosenbrock(self.A, self.B, self.C, self.D, lam)

    def norm(self) -> float:
        """||[A, B; C, D]||_2 of the balanced system (the scale of the rank decisions).

        Small systems: exact. Large ones: the 2-norm of the 2 x 2 matrix of block norms, with
        ||B||, ||C||, ||D|| exact (thin blocks) and ||A|| exact when A is diagonal (the modal
        pencils): then an upper bound within a factor sqrt(2). For another A, ||A|| is the
        power-iteration estimate of :func:`_norm2` (a lower estimate within a few per cent, as
        the whole-matrix estimate was). The whole matrix is never formed.
        """
        n, m, p = self.A.shape[0], self.B.shape[1], self.C.shape[0]
        if not ((n + p) and (n + m)):
            return 0.0
        if min(n + p, n + m) <= config.get("exact_norm_max"):
            return _norm2(np.block([[self.A, self.B], [self.C, self.D]]))
        diagonal = np.count_nonzero(self.A) == np.count_nonzero(np.diagonal(self.A))
        a = float(np.abs(np.diagonal(self.A)).max(initial=0.0)) if diagonal else _norm2(self.A)
        return block_norm(a, self.B, self.C, self.D)

    def to_caller(self, vb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(v, v_b'): v = diag(T, Su) v_b normalised (``||v|| = 1``, largest entry real and
        positive) and v_b' = diag(T, Su)^-1 v, the same direction in balanced coordinates."""
        if vb.size == 0:
            return vb, vb
        shift = self.right_exp - int(self.right_exp.max())  # <= 0: no overflow
        up = np.ldexp(1.0, shift)
        v = vb * up
        k = int(np.argmax(np.abs(v)))
        if v[k] != 0:
            ph = v[k] / abs(v[k])
            vb = vb / ph
        if np.iscomplexobj(vb) and np.all(np.abs(vb.imag) <= _REAL_CUTOFF * np.max(np.abs(vb.real), initial=0.0)):
            vb = vb.real.copy()
        v = vb * up
        nv = float(np.linalg.norm(v))
        if nv > 0.0:
            v = v / nv
        return v, v * np.ldexp(1.0, -shift)


def _read_only(X: np.ndarray) -> np.ndarray:
    """A read-only view of X (X itself keeps its flags)."""
    v = X.view()
    v.setflags(write=False)
    return v


def _balance(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, enabled: bool = True) -> _Balanced:
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    if not enabled:  # unit scalings: read-only views of the data (the deflation forms new arrays), no N x N exponent arrays
        Ab, Bb, Cb, Db = (_read_only(np.asarray(X, dtype=np.result_type(X, np.float64))) for X in (A, B, C, D))
        return _Balanced(Ab, Bb, Cb, Db, np.ones(n), np.ones(m), np.ones(p), np.zeros(n + m, np.int64))
    et, eu, ey = _balance_exponents(A, B, C, D)
    # exponent differences are within +-2 _MAX_EXPONENT: every factor is an exact normal power of two
    Ab = A * np.ldexp(1.0, et[None, :] - et[:, None])
    Bb = B * np.ldexp(1.0, eu[None, :] - et[:, None])
    Cb = C * np.ldexp(1.0, ey[:, None] + et[None, :])
    Db = D * np.ldexp(1.0, ey[:, None] + eu[None, :])
    return _Balanced(
        Ab, Bb, Cb, Db, np.ldexp(1.0, et), np.ldexp(1.0, eu), np.ldexp(1.0, ey), np.concatenate([et, eu]).astype(np.int64)
    )


# ------------------------------------------------------------------------------------------
# deflation


def _count(s: np.ndarray, scale: float, tol: Tolerance, delta: float) -> tuple[int, bool, float]:
    """Rank decision on computed singular values ``s`` (descending) of a deflation block.

    Returns (kept, undecided, dropped): ``kept`` singular values exceed ``rtol * scale`` (the
    others are set to zero, a perturbation of 2-norm ``dropped``); the decision is certain
    only if every kept one also exceeds ``rtol * band * scale + delta``, with delta the
    backward error accumulated so far (by Weyl's inequality a perturbation of norm delta
    cannot remove such a singular value).
    """
    if s.size == 0:
        return 0, False, 0.0
    lo, hi = tol.rtol * scale, tol.upper * scale + delta
    if s.size <= 8:  # the usual deflation block: plain floats, no array reductions (one call per step)
        sv = s.tolist()
        kept = sum(1 for x in sv if x > lo)
        certain = sum(1 for x in sv if x > hi)
        return kept, certain != kept, (float(sv[kept]) if kept < len(sv) else 0.0)
    kept = int(np.sum(s > lo))
    certain = int(np.sum(s > hi))
    dropped = float(s[kept]) if kept < s.size else 0.0
    return kept, certain != kept, dropped


def _block_reflector(V1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Compact-WY form Q = I - Y T Y^H of the Householder QR of V1 (n x nu).

    Q is unitary and its first nu columns span Im V1. Applying Q to an n x n matrix costs two
    thin matrix products (O(nu n^2)), never an n x n orthogonal factor.
    """
    # LAPACK's geqrt directly: the Householder QR with its compact-WY factor T in one call
    # (14 against 24 us with geqrf and T assembled here, for a 200 x 2 block; one per deflation step)
    cplx = np.iscomplexobj(V1)
    geqrt = scipy.linalg.lapack.zgeqrt if cplx else scipy.linalg.lapack.dgeqrt
    n, nu = V1.shape
    qr, T, info = geqrt(max(nu, 1), np.asarray(V1, dtype=complex if cplx else float))
    if info != 0:  # pragma: no cover - geqrt reports only illegal arguments
        raise ArithmeticError(f"geqrt failed (info = {info})")
    Y = np.tril(qr[:, :nu], -1)
    Y[np.arange(nu), np.arange(nu)] = 1.0
    return Y, T[:nu, :nu]


def _qh_left(Y: np.ndarray, T: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Q^H M with Q = I - Y T Y^H."""
    if M.size == 0:
        return M
    return M - Y @ (T.conj().T @ (Y.conj().T @ M))


def _q_right(Y: np.ndarray, T: np.ndarray, M: np.ndarray) -> np.ndarray:
    """M Q with Q = I - Y T Y^H."""
    if M.size == 0:
        return M
    return M - ((M @ Y) @ T) @ Y.conj().T


#: rows per strip of :func:`_mirror_upper` and :func:`_is_symmetric`
_STRIP_ROWS = 256


def _similarity_blocks(Y: np.ndarray, T: np.ndarray, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Q^H A Q)[nu:, nu:]`` (a new contiguous array) and ``(Q^H A Q)[:nu, nu:]`` for ``Q = I - Y T Y^H``.

    With ``X1 = Y^H A``, ``X2 = A Y`` and ``Z = X1 Y``,
    ``Q^H A Q = A - [Y, X2 T] [T^H X1 - (T^H Z T) Y^H; Y^H]``: one product of inner
    dimension 2 nu, evaluated only on the columns that are kept, so a deflation step reads
    A about three times instead of the ten passes of two separate reflector applications
    and a copy (the steps are memory-bound when nu is small).
    """
    nu = Y.shape[1]
    Yh = Y.conj().T
    X1 = Yh @ A
    X2 = A @ Y
    Th = T.conj().T
    R1 = Th @ X1 - (Th @ (X1 @ Y) @ T) @ Yh
    left = np.hstack([Y, X2 @ T])
    right = np.vstack([R1[:, nu:], Yh[:, nu:]])
    trailing = left[nu:] @ right
    np.subtract(A[nu:, nu:], trailing, out=trailing)
    top = A[:nu, nu:] - left[:nu] @ right
    return trailing, top


def _symmetric_similarity_blocks(Y: np.ndarray, T: np.ndarray, A: np.ndarray, bufs: list[np.ndarray], switch: ThreadSwitch) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_similarity_blocks` for a real symmetric A of which only the upper triangle is read.

    ``A`` is C-contiguous and represents the symmetric matrix of its upper triangle (the
    entries below the diagonal are not read). For ``Q = I - Y T Y^T`` and symmetric A,

    .. math:: Q^T A Q = A - V Y^T - Y V^T, \\qquad W = A Y T,\\quad
              Z = T^T Y^T W,\\quad V = W - \\tfrac12 Y Z

    (Z is symmetric; its computed value is symmetrised). One ``dsymm`` forms W and one
    ``dsyr2k`` updates the kept triangle: half the arithmetic of the general step (which forms
    both ``Y^T A`` and ``A Y`` and the whole trailing block), so the step costs half as much.
    The matrix a step leaves is symmetric by construction, and the step is still one two-sided
    application of a block reflector. Its rounding error is covered by the same stated
    backward-error model ``c d eps ||M||`` as the general step (``_OPS_PER_STEP``).

    ``bufs`` holds two flat float arrays (the second one empty until the second step, which
    allocates it): the trailing block goes into the one A is not a view of (the steps
    alternate between them). A fresh
    array per step costs its page faults: 1.15 s against 0.06 s for an 8000 x 8000 copy into
    memory already touched. (Moving the block down within one buffer, in row blocks that do
    not overlap their source, saves one array but costs a copy call per ``nu`` rows: 5.9 s
    of Python calls at 10,000 agents, where a cluster pencil deflates two states per step.)

    Returns ``(trailing, top)``. ``trailing`` is ``(Q^T A Q)[nu:, nu:]``, a C-contiguous view
    at the start of one buffer of which, again, only the upper triangle is valid. ``top`` is
    ``(Q^T A Q)[:nu, nu:]``, in full.
    """
    nu = Y.shape[1]
    YT = Y @ T
    # the two O(n^2 nu) products on every core from threaded_min states on, the rest (small
    # products, the copy) on the one thread the deflation runs with
    cores = None if A.shape[0] >= config.get("threaded_min") else 1
    # A.T is the Fortran-ordered view of the same memory: its lower triangle is A's upper one
    with switch.limit(cores):
        W = scipy.linalg.blas.dsymm(1.0, A.T, YT, side=0, lower=1)
    Z = YT.T @ W
    Z = 0.5 * (Z + Z.T)
    V = W - 0.5 * (Y @ Z)
    top = A[:nu, nu:] - V[:nu] @ Y[nu:].T - Y[:nu] @ V[nu:].T
    k = A.shape[0] - nu
    dest = bufs[1] if np.shares_memory(A, bufs[0]) else bufs[0]
    if dest.size < k * k:  # the second buffer, allocated at the second step
        dest = bufs[1] = np.empty(k * k)
    trailing = dest[: k * k].reshape(k, k)
    np.copyto(trailing, A[nu:, nu:])
    # the Fortran view trailing.T, updated in place on its lower triangle (= trailing's upper one)
    with switch.limit(cores):
        out = scipy.linalg.blas.dsyr2k(-1.0, V[nu:], Y[nu:], beta=1.0, c=trailing.T, trans=0, lower=1, overwrite_c=1)
    if not np.shares_memory(out, trailing):  # pragma: no cover - f2py copies only non-contiguous input
        np.copyto(trailing, out.T)
    return trailing, top


def _mirror_upper(A: np.ndarray) -> np.ndarray:
    """A made the full symmetric matrix of its upper triangle, in place, in blocks of rows.

    The blocks keep the temporaries at ``_STRIP_ROWS`` rows (a whole-matrix ``triu`` would
    take three more N x N arrays at the peak).
    """
    n = A.shape[0]
    for a in range(0, n, _STRIP_ROWS):
        b = min(a + _STRIP_ROWS, n)
        A[a:b, :a] = A[:a, a:b].T
        blk = A[a:b, a:b]
        low = np.tril_indices(b - a, -1)
        blk[low] = blk.T[low]
    return A


def _is_symmetric(A: np.ndarray) -> bool:
    """A is real and exactly symmetric (then the deflation may use the symmetric step).

    Compared in strips of ``_STRIP_ROWS`` rows against the matching columns: it stops at the
    first strip that differs, and reads a 10,000 x 10,000 symmetric matrix in 0.26 s against
    0.59 s for ``array_equal(A, A.T)``.
    """
    if A.ndim != 2 or A.shape[0] != A.shape[1] or np.iscomplexobj(A):
        return False
    n = A.shape[0]
    for a in range(0, n, _STRIP_ROWS):
        b = a + _STRIP_ROWS
        if not np.array_equal(A[a:b, a:], A[a:, a:b].T):
            return False
    return True


def _reduce(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, tol: Tolerance, scale: float, delta: float, *, symmetric_step: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, bool, float]:
    """Deflate until D has full row rank; rank P(lam) = acc + rank P_reduced(lam) for all lam.

    One step: rotate the outputs so that D = [0; D2] with D2 of full row rank; the rows
    [C1, 0] with C1 != 0 have a row space of dimension nu; with a state rotation whose first
    nu coordinates span it, those rows read [C12, 0, 0] with C12 of full column rank, so (by
    unimodular row operations) the first nu states contribute exactly nu to the rank for
    every lambda. The rows of their state equation become new output rows.

    ``delta`` is the backward error accumulated before the call; the returned one adds the
    singular values set to zero and ``_OPS_PER_STEP`` rounding bounds
    ``c d eps scale`` (d = rows + columns of the current system matrix) per step.

    A real, exactly symmetric A (the modal ZDA pencil's diagonal state matrix) stays symmetric
    under the similarity. From ``_FUSED_MIN`` states on, its steps keep the upper triangle only
    (:func:`_symmetric_similarity_blocks`): its small products on one BLAS thread, its two large
    ones on every core, its trailing blocks in two buffers used in turn. Measured on the 2-core machine, on
    the modal shape (diagonal A, orthonormal B and C^T): 4000 states and 37 outputs take
    2.9-3.0 s, against 5.6-7.1 s for the general step with two threads and 6.2-6.6 s with
    one; 10,000 states and 97 outputs 27 s against 63 s. With every product on two threads the
    symmetric step took 8.8-11 s at 4000: the many small products pay for the thread
    synchronisation.
    ``symmetric_step=False`` uses the general step throughout (the benchmark's baseline).
    """
    # a complex B, C or D makes the reflectors complex: the real BLAS calls of the symmetric step do not
    # apply (analyze_pencil gives all four one dtype; this guards direct calls)
    real = not any(np.iscomplexobj(X) for X in (B, C, D))
    symmetric = symmetric_step and real and A.shape[0] >= config.get("fused_min") and _is_symmetric(A)
    if not symmetric:
        return _reduce_steps(A, B, C, D, tol, scale, delta, None)
    switch = ThreadSwitch()
    with switch.limit(1):
        return _reduce_steps(A, B, C, D, tol, scale, delta, switch)


def _reduce_steps(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, tol: Tolerance, scale: float, delta: float, switch: ThreadSwitch | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, bool, float]:
    """The loop of :func:`_reduce` (``switch`` given: A is real and exactly symmetric, and the
    symmetric steps switch threads with it)."""
    acc = 0
    undecided = False
    # `upper`: A holds only its upper triangle (after a symmetric step); it is mirrored back
    # before the small steps and on return
    if switch is not None and not A.flags.c_contiguous and A.T.flags.c_contiguous:
        A = A.T  # the same matrix (it is symmetric), in the C order the symmetric step reads
    upper = False
    bufs: list[np.ndarray] | None = None  # the symmetric steps' trailing blocks, alternately
    while True:
        n, m, p = A.shape[0], B.shape[1], C.shape[0]
        if p == 0:
            break
        delta += _OPS_PER_STEP * _rounding(2 * n + m + p, scale)
        if m > 0:
            Ud, sd, _ = np.linalg.svd(D)
            rho, und, dropped = _count(sd, scale, tol, delta)
            undecided |= und
            delta += dropped
        else:
            Ud, rho = np.eye(p, dtype=C.dtype), 0
        T = Ud.conj().T
        Ct, Dt = T @ C, T @ D
        if rho == p:
            C, D = Ct, Dt
            break
        C1, C2, D2 = Ct[rho:], Ct[:rho], Dt[:rho]
        if n == 0:
            C, D = C2, D2
            break
        _, sc, Vh = np.linalg.svd(C1, full_matrices=False)
        nu, und, dropped = _count(sc, scale, tol, delta)
        undecided |= und
        delta += dropped
        if nu == 0:  # the rows [C1, 0] are zero: they do not count
            C, D = C2, D2
            break
        Y, Tw = _block_reflector(Vh[:nu].conj().T)
        if switch is not None and A.shape[0] >= config.get("fused_min"):
            if bufs is None:
                bufs = [np.empty((A.shape[0] - nu) ** 2), np.empty(0)]
            A, top = _symmetric_similarity_blocks(Y, Tw, A, bufs, switch)
            upper = True
        elif A.shape[0] >= config.get("fused_min"):
            A, top = _similarity_blocks(Y, Tw, A)
        else:  # small: fewer, cheaper calls win
            if upper:  # a copy: the buffers are not kept alive by the small steps
                A, upper, bufs = _mirror_upper(A).copy(), False, None
            At = _q_right(Y, Tw, _qh_left(Y, Tw, A))
            A, top = np.ascontiguousarray(At[nu:, nu:]), At[:nu, nu:]
        Bt = _qh_left(Y, Tw, B)
        C2t = _q_right(Y, Tw, C2)
        B = np.ascontiguousarray(Bt[nu:])
        C = np.vstack([top, C2t[:, nu:]])
        D = np.vstack([Bt[:nu], D2])
        acc += nu
    if upper:
        A = _mirror_upper(A)
        if A.base is not None and 2 * A.size < A.base.size:  # not a view that keeps a much larger buffer alive
            A = A.copy()
    return A, B, C, D, acc, undecided, delta
