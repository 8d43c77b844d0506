"""Fast exact unobservable restriction for the UIO existence test over Q.

The reference of :func:`glocal_verify.observers.uio_existence.uio_existence_exact` grows the
observable row space of ``(A_1, C)`` by re-stacking ``[R; R A_1]`` through
:class:`fractions.Fraction` lists and takes the restriction to the unobservable subspace
with a normal-equation inverse. This module computes the same subspace and the same
characteristic polynomial without leaving python-flint and without any rational inverse:

* the observable row space is grown Krylov-wise, ``R_{j+1} = R_j + span(F_j A_1)``, keeping
  ``R_j`` in reduced row echelon form and reducing only the new frontier against it (a few
  matrix products and one small RREF per step instead of an RREF of the whole stack);
* the kernel basis ``N`` of the final RREF has the identity on the free columns, so the
  restriction ``X`` with ``A_1 N = N X`` is read off the free rows of ``A_1 N`` exactly.

Everything is exact; the characteristic polynomial of ``X`` does not depend on the kernel
basis, so it equals the reference's coefficient for coefficient. No flint object outlives a
call.
"""

from __future__ import annotations

from fractions import Fraction

import flint

__all__ = ["unobservable_charpoly_exact"]


def _head(M: flint.fmpq_mat, r: int) -> flint.fmpq_mat:
    """The first ``r`` rows of ``M``."""
    return flint.fmpq_mat(r, M.ncols(), M.entries()[: r * M.ncols()])


def _columns(M: flint.fmpq_mat, cs: list[int]) -> flint.fmpq_mat:
    """The columns ``cs`` of ``M``, in that order."""
    e, nc = M.entries(), M.ncols()
    return flint.fmpq_mat(M.nrows(), len(cs), [e[i * nc + c] for i in range(M.nrows()) for c in cs])


def _pivots(R: flint.fmpq_mat, r: int) -> list[int]:
    """Pivot columns of the first ``r`` rows of a reduced row echelon form."""
    out: list[int] = []
    j = 0
    for i in range(r):
        while R[i, j] == 0:
            j += 1
        out.append(j)
        j += 1
    return out


def _observable_rref(A1: flint.fmpq_mat, C: flint.fmpq_mat) -> tuple[flint.fmpq_mat, list[int]]:
    """RREF (rows ``r x n``) and pivot columns of the observable row space of ``(A1, C)``.

    The smallest row space containing the rows of ``C`` and closed under right multiplication
    by ``A1``: ``R_{j+1} = R_j + span(F_j A1)`` where ``F_j`` spans a complement of ``R_{j-1}``
    in ``R_j`` (``R_{j-1} A1 ⊆ R_j``). The frontier ``F_j A1`` is reduced against the current
    RREF (whose pivot columns are unit columns), its own RREF ``B`` gives the new rows and the
    next frontier, ``B``'s pivot columns are eliminated from the old rows and the two are merged
    by pivot, which is again an RREF. The growth stops when a reduced frontier is zero.
    """
    n = A1.nrows()
    R, rk = C.rref()
    r = int(rk)
    R = _head(R, r)
    P = _pivots(R, r)
    frontier = R
    while 0 < r < n:
        G = frontier * A1
        G = G - _columns(G, P) * R
        B, rb_ = G.rref()
        rb = int(rb_)
        if rb == 0:
            break
        B = _head(B, rb)
        Pb = _pivots(B, rb)
        R = R - _columns(R, Pb) * B
        order = sorted([(P[i], i, 0) for i in range(r)] + [(Pb[i], i, 1) for i in range(rb)])
        eR, eB = R.entries(), B.entries()
        R = flint.fmpq_mat(r + rb, n, [x for _, i, s in order for x in (eR if s == 0 else eB)[i * n : (i + 1) * n]])
        P = [p for p, _, _ in order]
        r += rb
        frontier = B
    return R, P


def unobservable_charpoly_exact(A1: flint.fmpq_mat, C: flint.fmpq_mat) -> tuple[int, list[Fraction]]:
    """Dimension and characteristic polynomial of ``A1`` restricted to the unobservable
    subspace of ``(A1, C)``, exactly.

    Parameters
    ----------
    A1 : flint.fmpq_mat
        The ``n x n`` matrix ``(I - h C) A`` over Q.
    C : flint.fmpq_mat
        The ``p x n`` output matrix over Q.

    Returns
    -------
    tuple of (int, list of Fraction)
        ``k``, the dimension of the unobservable subspace (the right kernel of the
        observability matrix), and the monic characteristic polynomial of the restriction,
        lowest degree first (``[1]`` when ``k = 0``).
    """
    n = A1.nrows()
    R, pivots = _observable_rref(A1, C)
    ps = set(pivots)
    free = [j for j in range(n) if j not in ps]
    k = len(free)
    if k == 0:
        return 0, [Fraction(1)]
    # kernel basis N: identity on the free rows, -R[l, f_i] on the pivot rows
    N = flint.fmpq_mat(n, k)
    for i, f in enumerate(free):
        N[f, i] = 1
        for l, c in enumerate(pivots):
            N[c, i] = -R[l, f]
    # A1 N = N X (ker R is A1-invariant) and N[free, :] = I, so X = (A1 N)[free, :]
    AN = A1 * N
    X = flint.fmpq_mat(k, k, [AN[f, i] for f in free for i in range(k)])
    p = X.charpoly()
    return k, [Fraction(int(p[j].p), int(p[j].q)) for j in range(p.degree() + 1)]
