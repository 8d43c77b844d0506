"""Robust numeric linear algebra with explicit, recorded tolerances.

Every decision "is this zero?" made by the numeric checkers goes through :class:`Tolerance`:

* a quantity is compared with a *scale* (a matrix norm, the largest singular value ...);
* if ``|value| <= rtol * scale`` it is **zero**;
* if ``|value| > rtol * band * scale`` it is **nonzero**;
* in between the numbers cannot tell, and the decision is **undecided**.

The defaults ``rtol = 1e-9`` and ``band = 1e3`` sit well above the rounding level of double
precision on the problem sizes the toolkit targets (backward errors of ``eigh``/``svd`` are a
small multiple of ``eps * ||M||``, eps = 2.2e-16) and well below the smallest structural
quantities of weighted graphs with moderate weight ratios. Checkers record the ``rtol`` they
used in every result.

What a tolerance is not
-----------------------
``rtol`` is a *modelling / robustness* threshold, not a bound on floating-point error: a value
below ``rtol * scale`` may be a genuine nonzero (a weight changed by 1e-10, a link of weight
1e-11) and reading it as zero gives verdicts that exact arithmetic contradicts. The global
checkers (``switched-observability``, ``privacy.*``, ``switching.*``, ``central.observer``)
therefore decide with certified bounds instead (:class:`~glocal_verify.numerics.spectrum.Spectrum`
``error_radius`` / ``subspace_sine``, SVD backward errors), read exact zeros only from the
spec's structure, and use this class only for robustness (``fragile``) and for the numeric
subspace bases they show as witnesses and margins.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from glocal_verify.errors import ArgumentError
from glocal_verify.spec.arguments import real_arg

__all__ = [
    "Tolerance",
    "DEFAULT_TOLERANCE",
    "Decision",
    "RankInfo",
    "numeric_rank",
    "orth",
    "null_space",
    "EigenGroup",
    "group_eigenvalues",
    "principal_sines",
]

class Decision(str, Enum):
    ZERO = "zero"
    NONZERO = "nonzero"
    UNDECIDED = "undecided"


@dataclass(frozen=True, slots=True)
class Tolerance:
    """Relative tolerance with an undecided band.

    Attributes
    ----------
    rtol : float
        Scaled values at or below ``rtol`` are zero; a real number with ``0 < rtol < 1``.
    band : float
        Scaled values above ``rtol * band`` are nonzero; those in between are undecided; a
        finite real number with ``band >= 1`` and ``rtol * band < 1``.

    Raises
    ------
    ArgumentError
        A value outside these domains (NaN, infinite, a boolean or a non-number included).
    """

    rtol: float = 1e-9
    band: float = 1e3

    def __post_init__(self) -> None:
        for name in ("rtol", "band"):
            object.__setattr__(self, name, real_arg(f"Tolerance {name}", getattr(self, name)))
        if not (0.0 < self.rtol < 1.0) or not (self.band >= 1.0) or self.rtol * self.band >= 1.0:
            raise ArgumentError(f"invalid tolerance rtol={self.rtol:g}, band={self.band:g} (need 0 < rtol < 1, band >= 1, rtol * band < 1)")

    @property
    def upper(self) -> float:
        """Scaled threshold above which a value is certainly nonzero."""
        return self.rtol * self.band

    def decide(self, value: float, scale: float) -> Decision:
        """Classify ``|value|`` relative to ``scale`` (a nonpositive scale means an exact zero matrix)."""
        v = abs(float(value))
        s = float(scale)
        if s <= 0.0 or not np.isfinite(s):
            return Decision.ZERO if v == 0.0 else Decision.NONZERO
        r = v / s
        if r <= self.rtol:
            return Decision.ZERO
        if r > self.upper:
            return Decision.NONZERO
        return Decision.UNDECIDED


DEFAULT_TOLERANCE = Tolerance()


@dataclass(frozen=True, slots=True)
class RankInfo:
    """Numeric rank of a matrix with the evidence behind it.

    Attributes
    ----------
    rank : int
        Number of singular values certainly nonzero (``> rtol * band * s_max``).
    rank_upper : int
        Number of singular values not certainly zero (``> rtol * s_max``).
    singular_values : ndarray
        Descending singular values.
    scale : float
        ``s_max`` (0 for a zero or empty matrix).
    """

    rank: int
    rank_upper: int
    singular_values: np.ndarray
    scale: float

    @property
    def decided(self) -> bool:
        return self.rank == self.rank_upper

    @property
    def smallest_nonzero(self) -> float:
        """Smallest certainly nonzero singular value relative to the scale (1.0 if rank 0)."""
        if self.rank == 0 or self.scale == 0.0:
            return 1.0
        return float(self.singular_values[self.rank - 1] / self.scale)

    @property
    def largest_zero(self) -> float:
        """Largest singular value counted as zero, relative to the scale (0.0 if none)."""
        if self.rank_upper >= len(self.singular_values) or self.scale == 0.0:
            return 0.0
        return float(self.singular_values[self.rank_upper] / self.scale)


def numeric_rank(M: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE, scale: float | None = None) -> RankInfo:
    """Rank of ``M`` by singular values, relative to ``scale`` (default: the largest one).

    Notes
    -----
    Singular values ``s <= rtol * scale`` are zero, ``s > rtol * band * scale`` nonzero; any
    singular value in between makes the rank undecided (``rank < rank_upper``).
    """
    M = np.asarray(M, dtype=float) if not np.iscomplexobj(M) else np.asarray(M)
    if M.size == 0:
        return RankInfo(0, 0, np.zeros(0), 0.0)
    s = np.linalg.svd(M, compute_uv=False)
    smax = float(s[0]) if scale is None else float(scale)
    if smax == 0.0:
        return RankInfo(0, 0, s, 0.0)
    r_lo = int(np.sum(s > tol.upper * smax))
    r_hi = int(np.sum(s > tol.rtol * smax))
    return RankInfo(r_lo, r_hi, s, smax)


def orth(M: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> tuple[np.ndarray, RankInfo]:
    """Orthonormal basis of Im(M) (columns), with the rank evidence.

    The basis holds the left singular vectors of the certainly nonzero singular values.
    """
    M = np.asarray(M)
    if M.size == 0:
        return np.zeros((M.shape[0], 0)), RankInfo(0, 0, np.zeros(0), 0.0)
    U, s, _ = np.linalg.svd(M, full_matrices=False)
    info = numeric_rank(M, tol)
    return U[:, : info.rank], info


def null_space(M: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> tuple[np.ndarray, RankInfo]:
    """Orthonormal basis of ker(M) (columns): right singular vectors beyond the upper rank.

    Uses ``rank_upper`` so that only directions whose singular value is certainly zero (or
    absent) enter the basis; the caller sees undecided ranks through the returned
    :class:`RankInfo`.
    """
    M = np.asarray(M)
    n = M.shape[1]
    if M.shape[0] == 0:
        return np.eye(n), RankInfo(0, 0, np.zeros(0), 0.0)
    _, s, Vh = np.linalg.svd(M, full_matrices=True)
    info = numeric_rank(M, tol)
    return Vh[info.rank_upper :].conj().T, info


@dataclass(frozen=True, slots=True)
class EigenGroup:
    """A cluster of numerically equal eigenvalues of a symmetric matrix.

    Attributes
    ----------
    value : float
        Mean of the clustered eigenvalues.
    indices : tuple of int
        Positions in the ascending eigenvalue array.
    certain : bool
        False when a gap to a neighbouring group lies in the undecided band.
    """

    value: float
    indices: tuple[int, ...]
    certain: bool


def group_eigenvalues(w: np.ndarray, scale: float, tol: Tolerance = DEFAULT_TOLERANCE) -> list[EigenGroup]:
    """Group ascending eigenvalues whose consecutive gaps are zero at ``rtol * scale``.

    A gap in the undecided band neither splits nor joins with certainty: the groups on both
    sides are marked ``certain=False`` (and kept apart).
    """
    groups: list[list[int]] = [[0]] if len(w) else []
    uncertain: set[int] = set()
    for k in range(1, len(w)):
        d = tol.decide(w[k] - w[k - 1], scale)
        if d is Decision.ZERO:
            groups[-1].append(k)
        else:
            if d is Decision.UNDECIDED:
                uncertain.add(len(groups) - 1)
                uncertain.add(len(groups))
            groups.append([k])
    return [EigenGroup(float(np.mean(w[g])), tuple(g), i not in uncertain) for i, g in enumerate(groups)]


def principal_sines(Q1: np.ndarray, Q2: np.ndarray) -> np.ndarray:
    """Singular values of (I - Q2 Q2^T) Q1 for orthonormal Q1, Q2: sines of principal angles."""
    if Q1.shape[1] == 0:
        return np.zeros(0)
    R = Q1 - Q2 @ (Q2.conj().T @ Q1) if Q2.shape[1] else Q1
    return np.linalg.svd(R, compute_uv=False)
