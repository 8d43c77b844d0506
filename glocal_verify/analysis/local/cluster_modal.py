"""Modal structure of a cluster model after the UIO's decoupling: one symmetric n-sized eigenproblem.

For the cluster model of eq. ``cluster_dyn2`` with the velocities of every boundary agent
measured (Proposition III.2 (ii)), h C_loc is the projector D_b onto the boundary
velocities and the UIO's decoupled matrix is

.. math::

    A_1 = (I - h C_{loc}) A^i = \\begin{bmatrix} 0 & I \\\\ -\\alpha (I - D_b) L & -\\gamma (I - D_b)
    \\end{bmatrix},\\qquad L = L[P_i, P_i].

Let I = P_i \\ dP_i be the interior agents and L_II U = U diag(mu) the eigendecomposition of
the interior block (symmetric, an n-sized problem). With u_k extended by zeros on dP_i,
z^a_k = [u_k; 0] and z^c_k = [0; u_k] span an A_1-invariant plane,

.. math:: A_1 [z^a_k, z^c_k] = [z^a_k, z^c_k] \\begin{bmatrix} 0 & 1 \\\\ -\\alpha\\mu_k & -\\gamma \\end{bmatrix},

because the rows of the boundary velocities vanish. The boundary coordinates (p_b, v_b) form
the rest: ṗ_b = v_b, v̇_b = 0 (a nilpotent block, eigenvalue 0 with 2 x 2 Jordan chains), coupled
into the interior modes through g = U^T L_Ib. So A_1 is block triangular in the orthonormal
basis [z^a, z^c, e_b] and its eigenvalues are the roots of lam^2 + gamma lam + alpha mu_k = 0
and 0 (2 |dP_i| times): everything the UIO design and its certificate need comes from one
``eigh`` of L_II, shared by the observers of the cluster and by the modes that leave the
cluster block unchanged (:func:`interior_modes` keys the result by the block's value).

This module holds the shared data (:class:`InteriorModes`) and the rounding of the cluster's
state matrix (:func:`state_rounding_bound`); the design and the Hurwitz certificate built on
them are in :mod:`glocal_verify.observers.uio_modal`.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Sequence

import numpy as np
import scipy.sparse

from glocal_verify import config
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.spec.types import NORMAL_MODE
from glocal_verify.numerics.rounding import EPS, gamma_bound
from glocal_verify.numerics.threads import blas_threads

__all__ = [
    "InteriorModes",
    "gamma_bound",
    "interior_modes",
    "interior_modes_of",
    "state_rounding_bound",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_INTERIOR_MODES_KIND: Kind[InteriorModes] = Kind("interior-modes", __name__, "InteriorModes")
_STATE_ROUNDING_KIND: Kind[float] = Kind("state-rounding", __name__, "float")

@dataclass(frozen=True, slots=True)
class InteriorModes:
    """Eigen-decomposition of the interior block L[I, I] of a cluster (I = P_i \\ dP_i).

    Attributes
    ----------
    interior, boundary : ndarray of int
        Cluster indices of I and of dP_i (ascending).
    mu : ndarray
        Computed eigenvalues of L_II (ascending).
    U : ndarray
        Computed eigenvectors (columns), |I| x |I|.
    orthogonality : float
        Rigorous upper bound of ||U^T U - I||_2: ||fl(U^T U) - I||_F plus the rounding of
        the product, gamma_{|I|} || |U| ||_F^2.
    g : ndarray
        U^T L_Ib (|I| x |dP_i|): how the boundary positions drive the interior modes.
    """

    interior: np.ndarray
    boundary: np.ndarray
    mu: np.ndarray
    U: np.ndarray
    orthogonality: float
    g: np.ndarray

    @property
    def size(self) -> int:
        """Number of agents of the cluster."""
        return int(len(self.interior) + len(self.boundary))


def interior_modes_of(L: np.ndarray, boundary: Sequence[int]) -> InteriorModes:
    """:class:`InteriorModes` of the block L (float, symmetric) with boundary indices ``boundary``.

    Cost: one ``eigh`` of L_II and one product U^T U (the orthogonality bound), both of size
    |I|; g = U^T L_Ib is |I| x |dP_i|.

    Parameters
    ----------
    L : ndarray
        Principal block L[P_i, P_i] of the mode's Laplacian.
    boundary : sequence of int
        Cluster indices of the boundary agents.
    """
    n = L.shape[0]
    b = np.asarray(sorted(int(i) for i in boundary), dtype=int)
    inner = np.setdiff1d(np.arange(n), b)
    LII = np.asarray(L, dtype=float)[np.ix_(inner, inner)]
    if len(inner):
        # a large symmetric factorization: every core, also inside the single-threaded
        # observer designs that call this (eigh of 3300 interior agents: 7.1-7.2 s on one
        # thread, 3.5-4.6 s on two; see glocal_verify.numerics.threads)
        with blas_threads(None) if len(inner) >= config.get("all_cores_min_agents") else contextlib.nullcontext():
            mu, U = np.linalg.eigh(LII)
            G = U.T @ U
        G[np.diag_indices_from(G)] -= 1.0
        orth = float(np.linalg.norm(G)) * (1.0 + 4 * len(inner) * EPS) + gamma_bound(len(inner)) * float(np.sum(U * U)) * (1.0 + 4 * EPS)
    else:
        mu, U, orth = np.zeros(0), np.zeros((0, 0)), 0.0
    g = U.T @ np.asarray(L, dtype=float)[np.ix_(inner, b)] if len(inner) and len(b) else np.zeros((len(inner), len(b)))
    return InteriorModes(inner, b, mu, U, orth, g)


def interior_modes(system: System, name: str, mode: str) -> InteriorModes:
    """The :class:`InteriorModes` of cluster ``name`` in ``mode``, kept on ``system.analysis``.

    The key is a digest of the block L[P_i, P_i] and of the boundary, by value: a safe mode
    that leaves the cluster block unchanged shares the decomposition of the normal mode, and
    every observer of the cluster shares it.

    Parameters
    ----------
    system : System
    name : str
        Cluster name.
    mode : str
    """
    cm = system.cluster_model(name, mode)
    idx = {a: k for k, a in enumerate(cm.nodes)}
    b = tuple(sorted(idx[a] for a in cm.boundary))
    h = hashlib.sha256(np.ascontiguousarray(cm.L).tobytes())
    h.update(repr((cm.L.shape, b)).encode())
    return _INTERIOR_MODES_KIND.get(system, (name, h.hexdigest()), lambda: interior_modes_of(cm.L, b))  # type: ignore[no-any-return]


def state_rounding_bound(system: System, name: str, mode: str) -> float:
    """Rigorous upper bound of ||fl(A^i) - A^i_exact||_2 for the cluster's state matrix.

    A^i = [[0, I], [-alpha L, -gamma I]] has rounded entries only where -alpha L_ij and
    -gamma are; each difference is formed exactly (``Fraction`` of the double against the
    spec's rational), converted with a relative error of at most eps / 2, and the Frobenius
    norm of the k differences is enlarged by (k + 4) eps. Reads the exact block's nonzeros
    only (O(nnz) rational operations). Kept on ``system.analysis``.

    Parameters
    ----------
    system : System
    name : str
        Cluster name.
    mode : str
    """

    def compute() -> float:
        cm = system.cluster_model(name, mode)
        Lq = system.cluster_laplacian_entries(name, mode)
        n = len(cm.nodes)
        a, g = Fraction(system.alpha_q), Fraction(system.gamma_q)
        loc = {lab: i for i, lab in enumerate(cm.nodes)}
        adj = system.adjacency(mode)
        total = 0.0
        k = 0
        block = scipy.sparse.csr_matrix(cm.A_sparse[n:, :n])  # every float nonzero of the block, row by row
        block.sort_indices()
        vel = cm.A_sparse.diagonal()[n:]
        zero = Fraction(0)
        # |fl - exact| depends only on the pair (the double, the exact entry): each distinct
        # pair is formed exactly once (a network has few distinct weights and degrees)
        seen: dict[tuple[float, Fraction, Fraction], float] = {}

        def gap(x: float, v: Fraction, scale: Fraction) -> float:
            """|x + scale v| (x the double, scale v the exact entry it stands for)."""
            key = (x, v, scale)
            d = seen.get(key)
            if d is None:
                d = seen[key] = abs(float(Fraction(x) + scale * v))
            return d

        for i, lab in enumerate(cm.nodes):
            lo, hi = block.indptr[i], block.indptr[i + 1]
            Ai = dict(zip(block.indices[lo:hi].tolist(), block.data[lo:hi].tolist()))
            # the exact support of row i: the diagonal and the neighbours inside the cluster
            # (read from the graph, not from rounded floats), and every float nonzero
            cols = {i} | {loc[b] for b in adj[lab] if b in loc} | set(Ai)
            for j in cols:
                d = gap(Ai.get(j, 0.0), Lq.get((i, j), zero), a)
                total += d * d
                k += 1
            d = gap(float(vel[i]), Fraction(1), g)
            total += d * d
            k += 1
        return math.sqrt(total) * (1.0 + (k + 4) * EPS) + 1e-300 if total > 0 else 0.0

    if system.cluster_unchanged(name, mode):  # the normal mode's block, entries and bound
        mode = NORMAL_MODE
    return _STATE_ROUNDING_KIND.get(system, (name, mode), compute)  # type: ignore[no-any-return]
