"""The transfer function of the agents' input dynamics over Q: ``adj(s I + alpha L_q) S_F^T``.

With ``A = -alpha L_q``, the map from the inputs of the agents F to the positions is
``(s I + alpha L_q)^{-1} S_F^T = P(s) / d(s)``. The exact ZDA analysis
(:mod:`glocal_verify.analysis.stealthy.zda_exact`) reads its zeros from it, the exact central observer
(:func:`~glocal_verify.observers.central.observer_charpoly_exact`) its characteristic
polynomial; both share one computation per (F, mode), kept on the system.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Sequence

import flint

from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.cluster_transfer import adjugate_columns
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["laplacian_transfer"]

#: the transfer function per (F, mode), kept on the system
_TRANSFER_KIND: Kind[tuple[Any, list[list[Any]]]] = Kind("laplacian-transfer", __name__, "tuple[fmpq_poly, list[list[fmpq_poly]]]")


def _fq(x: Fraction) -> Any:
    return flint.fmpq(x.numerator, x.denominator)


def laplacian_transfer(system: System, F: Sequence[int], mode: str = NORMAL_MODE) -> tuple[Any, list[list[Any]]]:
    """d(s) = det(sI + alpha L_q) and the numerators P(s) = adj(sI + alpha L_q) S_F^T (N x m, in s).

    Faddeev-LeVerrier on the input columns only: with A = -alpha L_q and d(s) = sum_j c_j s^j,
    adj(sI - A) = sum_{j<N} s^j B_j, B_{N-1} = I, B_{j-1} = A B_j + c_j I; so W_j = B_j S_F^T
    costs N products of A with an N x m matrix over Q. Kept on the system (:data:`_TRANSFER_KIND`); the
    mode q is the normal one unless given.

    Parameters
    ----------
    system : System
    F : sequence of int
        Input agent indices.
    mode : str
    """
    params = (tuple(F),) if mode == NORMAL_MODE else (tuple(F), mode)
    kept = _TRANSFER_KIND.peek(system, params)
    if kept is not None:
        return kept
    N = system.n
    L = system.laplacian_exact(mode)
    a = system.alpha_q
    A = flint.fmpq_mat(N, N, [_fq(-a * L[i][j]) for i in range(N) for j in range(N)])
    d, cols = adjugate_columns(A, F)
    P = [list(row) for row in cols]
    _TRANSFER_KIND.put(system, params, (d, P))
    return d, P
