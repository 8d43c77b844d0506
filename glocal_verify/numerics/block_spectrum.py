"""The spectrum of a block-diagonal symmetric matrix, each block decomposed on its own.

A clustered network's Laplacian is ``L = L_0 + sum_e w_e b_e b_e^T``: ``L_0`` the Laplacian of
the links inside the clusters (block diagonal over the clusters, in any order of the agents)
and one rank-one term per link between clusters. :class:`BlockSpectrum` is the spectrum of
``L_0``: one ``eigh`` per cluster, ``sum n_i^3`` instead of ``N^3`` (a ninth of it for three
equal clusters), and its eigenvectors are the blocks' eigenvectors placed in their rows. The
links between clusters then come as rank-one factors
(:func:`~glocal_verify.numerics.updated_spectrum.update_spectrum`), so the normal mode of a
network with a few such links is never decomposed whole.

Every bound is the blocks' own: ``L_0 U - U diag(w)`` and ``U^T U - I`` are block diagonal, so
the residual of a column is its block's residual and ``||U^T U - I||_F^2`` is the sum of the
blocks' squares. Rows and columns are copies of the blocks' floats (no rounding:
:attr:`entry_error` is 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Iterable, Sequence

import numpy as np
import scipy.sparse

from glocal_verify.numerics.rounding import gamma_bound

from glocal_verify.numerics.spectrum import Spectrum

__all__ = ["BlockSpectrum", "clustered_spectrum", "laplacian_csr"]

#: above this size of the weights' common denominator the degrees are summed as Fractions
_COMMON_DENOMINATOR_BITS = 2048


def laplacian_csr(n: int, links: Iterable[tuple[int, int, Fraction]]) -> scipy.sparse.csr_matrix:
    """The Laplacian of weighted links ``(i, j, w)`` in CSR form, each entry formed exactly and rounded once (read-only data).

    The degrees are rational sums and only then rounded to the nearest double, so
    ``|fl(L)_ij - L_ij| <= u |L_ij|``; exactly zero degrees are not stored, and no entry is a
    floating-point sum of duplicates.
    """
    links = list(links)
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    den = 1  # the degrees as integers over one common denominator: exact sums without Fraction arithmetic
    for _, _, w in links:
        q = w.denominator
        if den % q:
            den = den * q // math.gcd(den, q)
            if den.bit_length() > _COMMON_DENOMINATOR_BITS:
                break
    for u, v, w in links:
        fw = -float(w)
        rows += [u, v]
        cols += [v, u]
        vals += [fw, fw]
    diagonal: list[tuple[int, float]]
    if den.bit_length() <= _COMMON_DENOMINATOR_BITS:
        ideg = [0] * n
        for u, v, w in links:
            x = w.numerator * (den // w.denominator)
            ideg[u] += x
            ideg[v] += x
        diagonal = [(i, d / den) for i, d in enumerate(ideg) if d != 0]  # int / int is correctly rounded
    else:
        fdeg = [Fraction(0)] * n
        for u, v, w in links:
            fdeg[u] += w
            fdeg[v] += w
        diagonal = [(i, float(d)) for i, d in enumerate(fdeg) if d != 0]
    for i, d in diagonal:
        rows.append(i)
        cols.append(i)
        vals.append(d)
    L = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(n, n))
    L.sort_indices()
    for arr in (L.data, L.indices, L.indptr):
        arr.setflags(write=False)
    return L


def clustered_spectrum(L: scipy.sparse.csr_matrix, inside: scipy.sparse.csr_matrix, blocks: Sequence[np.ndarray], cut: Sequence[tuple[int, int, float]]) -> Spectrum | None:
    """The spectrum of ``L = inside + sum_cut w (e_i - e_j)(e_i - e_j)^T``: one ``eigh`` per block, the cut links as rank-one factors.

    Parameters
    ----------
    L, inside : scipy.sparse matrix
        ``fl(L)`` and ``fl(L_0)``, the Laplacian of the links inside the blocks, each rounded once.
    blocks : sequence of ndarray
        Index sets that partition the agents, ``inside`` block diagonal over them.
    cut : sequence of (int, int, float)
        The links between blocks.

    Returns
    -------
    Spectrum or None
        An :class:`~glocal_verify.numerics.updated_spectrum.UpdatedSpectrum` on a
        :class:`BlockSpectrum`; None when an update is refused (decompose L whole).
    """
    from glocal_verify.numerics.updated_spectrum import update_spectrum

    return update_spectrum(L, BlockSpectrum(inside, tuple(blocks)), cut)


@dataclass(frozen=True, eq=False, repr=False)
class BlockSpectrum(Spectrum):
    """``L_0 = U diag(w) U^T`` for a block-diagonal ``L_0``, from one decomposition per block.

    Parameters
    ----------
    matrix : scipy.sparse matrix
        ``fl(L_0)``, entries rounded once from exact values (as for :class:`Spectrum`), with no
        entry outside the blocks.
    blocks : tuple of ndarray
        Index sets (ascending) that partition ``0 .. N-1``.
    """

    blocks: tuple[np.ndarray, ...]

    def __post_init__(self) -> None:
        super().__post_init__()
        seen = np.zeros(self.size, dtype=int)
        for idx in self.blocks:
            seen[np.asarray(idx)] += 1
        if not np.all(seen == 1):
            raise ValueError("the blocks must partition the indices")
        S = self._sparse
        owner = np.empty(self.size, dtype=np.intp)
        for b, idx in enumerate(self.blocks):
            owner[np.asarray(idx)] = b
        rows = np.repeat(np.arange(self.size), np.diff(S.indptr))
        if np.any(owner[rows] != owner[S.indices]):
            raise ValueError("the matrix has entries outside its blocks")

    def __repr__(self) -> str:
        return f"BlockSpectrum(N={self.size}, blocks={[len(b) for b in self.blocks]})"

    @cached_property
    def parts(self) -> tuple[Spectrum, ...]:
        """The spectrum of each diagonal block (its own ``eigh`` and bounds)."""
        S = self._sparse
        return tuple(Spectrum(S[np.asarray(idx)][:, np.asarray(idx)].tocsr()) for idx in self.blocks)

    @cached_property
    def _layout(self) -> tuple[np.ndarray, tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
        """(ascending values, per block the global columns of its local ones, owner block and local row of each index)."""
        vals = np.concatenate([np.asarray(p.values) for p in self.parts]) if self.parts else np.zeros(0)
        order = np.argsort(vals, kind="stable")
        position = np.empty(len(vals), dtype=np.intp)
        position[order] = np.arange(len(vals))
        cols, start = [], 0
        for p in self.parts:
            cols.append(position[start : start + p.size])
            start += p.size
        owner = np.empty(self.size, dtype=np.intp)
        local = np.empty(self.size, dtype=np.intp)
        for b, idx in enumerate(self.blocks):
            owner[np.asarray(idx)] = b
            local[np.asarray(idx)] = np.arange(len(idx))
        values = vals[order]
        values.setflags(write=False)
        return values, tuple(cols), owner, local

    @property
    def values(self) -> np.ndarray:
        """Eigenvalues of ``L_0``, ascending (the blocks' merged)."""
        return self._layout[0]

    @cached_property
    def _pairs(self) -> tuple[np.ndarray, np.ndarray]:
        U = np.zeros((self.size, self.size))
        for idx, c, p in zip(self.blocks, self._layout[1], self.parts):
            U[np.ix_(np.asarray(idx), c)] = p.vectors
        U.setflags(write=False)
        return self.values, U

    @cached_property
    def residuals(self) -> np.ndarray:
        """The blocks' computed residual norms, in the merged order."""
        r = np.empty(self.size)
        for c, p in zip(self._layout[1], self.parts):
            r[c] = p.residuals
        r.setflags(write=False)
        return r

    @cached_property
    def orthogonality_error(self) -> float:
        """``sqrt(sum_b eta_b^2)``: ``U^T U - I`` is block diagonal (each ``eta_b`` rigorous)."""
        return math.sqrt(sum(p.orthogonality_error**2 for p in self.parts)) * (1.0 + gamma_bound(len(self.parts) + 2))

    def rows(self, idx: Sequence[int] | np.ndarray) -> np.ndarray:
        """Rows ``U[idx, :]``: each the row of its block, placed at the block's columns (exact copies)."""
        idx = np.asarray(idx, dtype=np.intp).ravel()
        _, cols, owner, local = self._layout
        out = np.zeros((len(idx), self.size))
        for k, i in enumerate(idx):
            b = owner[i]
            out[k, cols[b]] = self.parts[b].vectors[local[i], :]
        return out

    def columns(self, idx: Sequence[int] | np.ndarray | slice) -> np.ndarray:
        """Columns ``U[:, idx]``: each its block's column, placed at the block's rows (exact copies)."""
        idx = np.arange(self.size)[idx] if isinstance(idx, slice) else np.asarray(idx, dtype=np.intp)
        _, cols, _, _ = self._layout
        out = np.zeros((self.size, len(idx)))
        for b, (rows, c) in enumerate(zip(self.blocks, cols)):
            hit = np.flatnonzero(np.isin(idx, c))
            if len(hit):
                where = np.empty(self.size, dtype=np.intp)
                where[c] = np.arange(len(c))
                out[np.ix_(np.asarray(rows), hit)] = self.parts[b].vectors[:, where[idx[hit]]]
        return out

    def _apply_real(self, Y: np.ndarray) -> np.ndarray:
        out = np.zeros((self.size,) + Y.shape[1:])
        for rows, c, p in zip(self.blocks, self._layout[1], self.parts):
            out[np.asarray(rows)] = p.vectors @ Y[c]
        return out

    def _project_real(self, X: np.ndarray) -> np.ndarray:
        out = np.empty((self.size,) + X.shape[1:])
        for rows, c, p in zip(self.blocks, self._layout[1], self.parts):
            out[c] = p.vectors.T @ X[np.asarray(rows)]
        return out

    def abs_apply(self, y: np.ndarray) -> np.ndarray:
        """``|U| |y|``, block by block."""
        y = np.asarray(y, dtype=float)
        out = np.empty(self.size)
        for rows, c, p in zip(self.blocks, self._layout[1], self.parts):
            out[np.asarray(rows)] = p.abs_apply(y[c])
        return out

