"""The modal structure of the closed loop: eigen-groups of L_q and their unobservable parts.

The closed loop of eq. ``cl_sys`` has a modal structure that reduces every observability
question to N-sized questions on the Laplacian. If ``L_q w = mu w`` then

.. math::

    A_q \\begin{bmatrix} a\\,w \\\\ b\\,w \\end{bmatrix}
    = \\begin{bmatrix} b\\,w \\\\ (-\\alpha\\mu a - \\gamma b)\\,w \\end{bmatrix},

so every space ``X (x) R^2 = {[w; z] : w, z in X}`` with ``X`` inside one eigenspace ``E_mu``
is A_q-invariant, and A_q acts on it as ``B_mu (x) I`` with
``B_mu = [[0, 1], [-alpha mu, -gamma]]`` (a Jordan block when ``gamma^2 = 4 alpha mu``). With
``W^x_mu = E_mu ∩ ker S_{M_x}`` and ``W_mu = E_mu ∩ ker S_M`` (``docs/conditions.md``, "Modal
structure"):

.. math::

    \\mathcal N(A_q, C) = (W^x_0 \\times W_0) \\;\\oplus\\; \\bigoplus_{\\mu > 0} (W_\\mu \\times W_\\mu).

*Why.* Each summand is A_q-invariant and inside ``ker C`` (for ``mu > 0`` the velocity part of
``A_q [w; z]`` is ``-alpha mu w - gamma z``, which must be seen by neither monitor set, hence
``W_mu`` in both slots; for ``mu = 0`` a position ``w in ker L`` only needs ``S_{M_x} w = 0``).
Maximality: the unobservable subspace is A_q-invariant, hence the direct sum of its parts in
the A_q-invariant spaces ``E_mu (x) R^2``; inside ``E_mu (x) R^2`` an eigenvector of
``B_mu (x) I`` is ``[w; lam w]`` and lies in ``ker C`` iff ``S_{M_x} w = 0`` and
``lam S_{M_v} w = 0``, and an invariant subspace of ``ker C`` is spanned by such chains. The
``proofs_checks`` and the property tests compare the formula with exact rational ranks.

This module holds the eigen-groups of ``L_q`` with their parts ``W_mu`` and ``W^x_mu``
(:func:`modal_decomposition`) and the modal exponentials; the subspaces built from them are in
:mod:`glocal_verify.analysis.unobservable.subspace` (per mode) and :mod:`glocal_verify.analysis.unobservable.switched`
(Lemma II.3), the generic staircase in :mod:`glocal_verify.numerics.staircase`. None of them forms the observability matrix ``(C, CA, ..., CA^{2N-1})``: in double precision it is
already wrong at N = 50.

Tolerance rule
--------------
Eigenvalues are grouped with :func:`~glocal_verify.numerics.tolerance.group_eigenvalues` at
``rtol * ||L_q||_2``; a gap in the undecided band is read both ways (split: the *lower* reading,
merged: the *upper* reading). Every other decision compares a quantity on the unit scale
(singular values of ``S E`` for an orthonormal eigenbasis ``E``, sines of principal angles,
distances of unit vectors) with ``rtol`` and ``rtol * band``, after widening it by the estimated
error of the computed subspaces: a value ``s`` with error ``e`` is zero iff
``s + e <= rtol``, nonzero iff ``s - e > rtol * band``, undecided otherwise. The eigenvector
error of a group is the a-posteriori Davis-Kahan bound ``||L E - E Lambda|| / gap``
(:func:`eigen_residuals`; ``gap`` = distance to the nearest other eigenvalue, shrunk by twice the
largest residual); the eigenspace of 0 is taken exactly, spanned by the component indicators. A
:class:`Subspace` carries both readings: the true subspace lies between ``basis`` and ``upper``
and is decided when their dimensions agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Union

import numpy as np

from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.spectrum import Spectrum
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.subspace import decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "EigenGroupPart",
    "GroupBasis",
    "form_bases",
    "ModalDecomposition",
    "modal_decomposition",
    "eigen_residuals",
    "modal_exponential",
    "block_exponentials",
    "apply_A",
]

#: the modal decomposition per (mode, tolerance), kept on the system
_MODAL_KIND: Kind[ModalDecomposition] = Kind("modal", __name__, "ModalDecomposition")

# --------------------------------------------------------------------------------------------
# modal decomposition of one mode


#: how a part of a group is formed from the group's basis E: all of it, none of it (an
#: ``N x 0`` array), or ``E @ K`` for a ``k x r`` coefficient matrix K
PartSpec = Union[str, np.ndarray]


class GroupBasis:
    """The eigenbasis E of one group and its parts ``W``, ``W_upper``, ``Wx``, ``Wx_upper``, formed on first use.

    For a spectrum with explicit eigenvectors E is a column slice of them (a view, no copy);
    for a factored one (:class:`~glocal_verify.numerics.updated_spectrum.UpdatedSpectrum`)
    it is computed when first read, so that the groups nobody reads (the observed ones)
    cost nothing. A part given as coefficients is formed once and kept.

    Parameters
    ----------
    n : int
        N, the length of the basis vectors.
    k : int
        The number of basis vectors.
    source : ndarray or (Spectrum, int)
        E itself, or the spectrum and the first index of the group's columns.
    specs : tuple of four PartSpec
        ``W``, ``W_upper``, ``Wx``, ``Wx_upper`` (a decided reading passes one object twice).
    """

    __slots__ = ("n", "k", "_spectrum", "_start", "_E", "specs", "_formed")

    def __init__(self, n: int, k: int, source: np.ndarray | tuple[Spectrum, int], specs: tuple[PartSpec, PartSpec, PartSpec, PartSpec]) -> None:
        self.n = n
        self.k = k
        self._spectrum: Spectrum | None = None
        self._start = 0
        self._E: np.ndarray | None = None
        if isinstance(source, np.ndarray):
            self._E = source
        else:
            self._spectrum, self._start = source
        self.specs = specs
        self._formed: dict[int, np.ndarray] | None = None  # per group: made only when a part is

    @property
    def E(self) -> np.ndarray:
        """The ``N x k`` basis (computed on first use for a factored spectrum)."""
        if self._E is None:
            assert self._spectrum is not None
            self._E = self._spectrum.columns(slice(self._start, self._start + self.k))
        return self._E

    @property
    def formed(self) -> bool:
        """Whether E is at hand."""
        return self._E is not None

    def provide(self, E: np.ndarray) -> None:
        """Set E, computed by the caller together with other groups' (:func:`form_bases`)."""
        if self._E is None:
            self._E = E

    def dim(self, i: int) -> int:
        """Dimension of part ``i`` (0 W, 1 W_upper, 2 Wx, 3 Wx_upper) without forming it."""
        spec = self.specs[i]
        if isinstance(spec, str):
            return 0 if spec == "none" else self.k
        return int(spec.shape[1])

    def part(self, i: int) -> np.ndarray:
        """Part ``i`` as an ``N x r`` array."""
        spec = self.specs[i]
        if isinstance(spec, str):
            return np.zeros((self.n, 0)) if spec == "none" else self.E
        if self._formed is None:
            self._formed = {}
        key = id(spec)
        if key not in self._formed:
            self._formed[key] = self.E @ spec
        return self._formed[key]


@dataclass(frozen=True, slots=True)
class EigenGroupPart:
    """One group of numerically equal eigenvalues of L_q and its unobservable parts.

    Attributes
    ----------
    value : float
        Mean eigenvalue ``mu`` of the group.
    indices : tuple of int
        Positions in the ascending eigenvalue array.
    zero : Decision
        Is ``mu = 0`` (decided at ``rtol * ||L_q||_2``)?
    sv : ndarray
        Singular values of ``S_M E`` padded with zeros to ``k``.
    svx : ndarray
        Singular values of ``S_{M_x} E`` padded with zeros to ``k``.
    error : float
        Estimated eigenvector error of the group (Davis-Kahan, plus the error of the computed
        monitored rows).
    basis : GroupBasis
        E and the parts below, formed on first use.

    The properties ``E`` (``N x k`` orthonormal eigenbasis: a column slice of the eigenvector
    matrix, or the exact component indicators for ``mu = 0``), ``W`` / ``W_upper`` (bases of
    ``W_mu = E ∩ ker S_M``, lower and upper reading) and ``Wx`` / ``Wx_upper`` (``W^x_mu = E ∩ ker
    S_{M_x}``, used for ``mu = 0``) are arrays; ``dim_W`` and the like give their dimensions
    without forming them.
    """

    value: float
    indices: tuple[int, ...]
    zero: Decision
    sv: np.ndarray
    svx: np.ndarray
    error: float
    basis: GroupBasis

    @property
    def E(self) -> np.ndarray:
        return self.basis.E

    @property
    def W(self) -> np.ndarray:
        return self.basis.part(0)

    @property
    def W_upper(self) -> np.ndarray:
        return self.basis.part(1)

    @property
    def Wx(self) -> np.ndarray:
        return self.basis.part(2)

    @property
    def Wx_upper(self) -> np.ndarray:
        return self.basis.part(3)

    @property
    def dim_W(self) -> int:
        return self.basis.dim(0)

    @property
    def dim_W_upper(self) -> int:
        return self.basis.dim(1)

    @property
    def dim_Wx(self) -> int:
        return self.basis.dim(2)

    @property
    def dim_Wx_upper(self) -> int:
        return self.basis.dim(3)

    @property
    def decided(self) -> bool:
        """Both readings of ``W`` and of ``Wx`` are one subspace."""
        sp = self.basis.specs
        return sp[0] is sp[1] and sp[2] is sp[3]


@dataclass(frozen=True, slots=True)
class ModalDecomposition:
    """Eigen-groups of L_q with their unobservable parts (both readings of undecided gaps).

    Attributes
    ----------
    mode : str
        The mode.
    groups : tuple of EigenGroupPart
        Groups of the split reading (undecided gaps split).
    merged : tuple of EigenGroupPart
        Groups of the merged reading (undecided gaps merged); equal to ``groups`` when every
        gap is decided.
    scale : float
        ``||L_q||_2`` (1.0 for the zero Laplacian).
    gaps_decided : bool
        No gap between consecutive eigenvalues fell in the undecided band.
    """

    mode: str
    groups: tuple[EigenGroupPart, ...]
    merged: tuple[EigenGroupPart, ...]
    scale: float
    gaps_decided: bool


def _kernel_readings(S: np.ndarray, k: int, err: float, tol: Tolerance) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Kernel of a ``p x k`` matrix with orthonormal-scale singular values, both readings.

    Returns (kernel lower reading, kernel upper reading, padded singular values, decided)
    as coefficient matrices ``k x r``.
    """
    if k == 0:
        z = np.zeros((0, 0))
        return z, z, np.zeros(0), True
    if S.shape[0] == 0:
        I = np.eye(k)
        return I, I, np.zeros(k), True
    _, s, Vh = np.linalg.svd(S, full_matrices=True)
    sp = np.zeros(k)
    sp[: len(s)] = s
    dec = [decide_with_error(x, err, tol) for x in sp]
    r_lo = sum(1 for d in dec if d is Decision.NONZERO)  # certainly nonzero
    r_hi = sum(1 for d in dec if d is not Decision.ZERO)  # not certainly zero
    V = Vh.T
    return V[:, r_hi:], V[:, r_lo:], sp, r_lo == r_hi


def _partition(w: np.ndarray, scale: float, tol: Tolerance) -> tuple[list[list[int]], list[list[int]], bool]:
    split: list[list[int]] = [[0]] if len(w) else []
    merged: list[list[int]] = [[0]] if len(w) else []
    decided = True
    for k in range(1, len(w)):
        d = tol.decide(w[k] - w[k - 1], scale)
        if d is Decision.ZERO:
            split[-1].append(k)
            merged[-1].append(k)
        elif d is Decision.UNDECIDED:
            decided = False
            split.append([k])
            merged[-1].append(k)
        else:
            split.append([k])
            merged.append([k])
    return split, merged, decided


def _group_parts(
    sp: Spectrum,
    partition: list[list[int]],
    scale: float,
    mx: list[int],
    m: list[int],
    tol: Tolerance,
    kernel_basis: np.ndarray | None,
) -> tuple[EigenGroupPart, ...]:
    """The parts of every group of ``partition`` (consecutive index runs), formed from ``sp`` on first use.

    Memory: ``E`` is the column slice ``U[:, a:b+1]`` of an explicit spectrum (a view, no copy;
    a factored spectrum computes it when it is read); ``W``/``Wx`` are ``E`` itself for a simple
    eigenvalue in the kernel (or a monitor set with no rows), an empty array when the kernel is
    ``{0}``, and a new ``N x r`` array only for a multiple group with a nonzero kernel; decided
    readings share one array. The rows of the monitors, ``U[M, :]`` and ``U[M_x, :]``
    (``|M| x N``), are taken once; a simple eigenvalue needs only the norm of its column there
    (no SVD), so the loop is O(|M| N) in all plus one small SVD per multiple group. The
    decisions add the estimated error of the computed rows (``sqrt(|M| k)`` times
    :attr:`Spectrum.entry_estimate <glocal_verify.numerics.spectrum.Spectrum.entry_estimate>`;
    the certified checks add the bound :attr:`~glocal_verify.numerics.spectrum.Spectrum.entry_error`).
    """
    w = sp.values
    n = len(w)
    residuals = sp.residual_estimates  # a tolerance reading: the computed residuals, not their rigorous bounds
    rmax = float(np.max(residuals)) if len(residuals) else 0.0
    Um = sp.rows(m) if len(m) else np.zeros((0, n))
    Umx = sp.rows(mx) if len(mx) else np.zeros((0, n))
    col_m = np.linalg.norm(Um, axis=0) if len(m) else np.zeros(n)
    col_mx = np.linalg.norm(Umx, axis=0) if len(mx) else np.zeros(n)
    entry = sp.entry_estimate  # a tolerance reading: the typical error of a computed entry, not its bound
    out = []
    for gi, g in enumerate(partition):
        a, b = g[0], g[-1] + 1
        lo = w[a]
        hi = w[b - 1]
        gap_left = lo - w[partition[gi - 1][-1]] if gi > 0 else math.inf
        gap_right = w[partition[gi + 1][0]] - hi if gi + 1 < len(partition) else math.inf
        gap = min(gap_left, gap_right) - 2.0 * rmax
        value = float(w[a]) if b - a == 1 else float(np.mean(w[a:b]))
        zero = tol.decide(value, scale)
        k = b - a
        source: np.ndarray | tuple[Spectrum, int]
        if zero is Decision.ZERO and kernel_basis is not None and kernel_basis.shape[1] == k:
            # ker L is spanned by the component indicators: known exactly
            source = kernel_basis
            err = math.sqrt(n) * EPS
            W, W_up, sv = _kernel_of(kernel_basis[m, :], k, err, tol)
            Wx, Wx_up, svx = _kernel_of(kernel_basis[mx, :], k, err, tol)
        else:
            source = (sp, a)  # formed when read: a view of explicit eigenvectors, computed for a factored spectrum
            rg = float(abs(residuals[a])) if k == 1 else float(np.linalg.norm(residuals[a:b]))
            err = (rg / gap if gap > 0 else math.inf) + math.sqrt(n) * EPS
            err_m = err + math.sqrt(len(m) * k) * entry
            err_mx = err + math.sqrt(len(mx) * k) * entry
            err = max(err_m, err_mx)
            if k == 1:
                W, W_up, sv = _simple_kernel(float(col_m[a]), len(m), err_m, tol)
                Wx, Wx_up, svx = _simple_kernel(float(col_mx[a]), len(mx), err_mx, tol)
            else:
                W, W_up, sv = _kernel_of(Um[:, a:b], k, err_m, tol)
                Wx, Wx_up, svx = _kernel_of(Umx[:, a:b], k, err_mx, tol)
        out.append(
            EigenGroupPart(
                value=value,
                indices=tuple(range(a, b)),
                zero=zero,
                sv=sv,
                svx=svx,
                error=err,
                basis=GroupBasis(n, k, source, (W, W_up, Wx, Wx_up)),
            )
        )
    return tuple(out)


def form_bases(sp: Spectrum, groups: list[EigenGroupPart]) -> None:
    """Form the bases E of ``groups`` (eigen-groups of ``sp``) in one call of ``sp.columns``.

    For a factored spectrum each call goes through every factor once, so reading many groups'
    bases one by one would cost a pass per group; explicit eigenvectors are views already.
    """
    todo = [g for g in groups if not g.basis.formed]
    if not todo or sp.explicit:
        return
    idx = np.concatenate([np.asarray(g.indices, dtype=np.intp) for g in todo])
    cols = sp.columns(idx)
    start = 0
    for g in todo:
        k = len(g.indices)
        g.basis.provide(cols[:, start : start + k])
        start += k


#: the padded singular values of a simple group seen by no monitor: one shared read-only array
_NO_ROWS = np.zeros(1)
_NO_ROWS.setflags(write=False)


def _simple_kernel(s: float, rows: int, err: float, tol: Tolerance) -> tuple[PartSpec, PartSpec, np.ndarray]:
    """Both readings of ``span(E) ∩ ker S`` for one column ``E`` with ``||S E|| = s``: ``"all"`` or ``"none"``.

    The singular value of the ``rows x 1`` matrix ``S E`` is its norm; the kernel is ``E`` or
    ``{0}`` (same decision as :func:`_kernel_readings`; ``S`` with no rows has kernel ``E``).
    """
    if rows == 0:
        return "all", "all", _NO_ROWS
    d = decide_with_error(s, err, tol)
    if d is Decision.UNDECIDED:
        return "none", "all", np.array([s])
    part = "all" if d is Decision.ZERO else "none"
    return part, part, np.array([s])  # decided: one specification for both readings


def _kernel_of(SE: np.ndarray, k: int, err: float, tol: Tolerance) -> tuple[PartSpec, PartSpec, np.ndarray]:
    """Both readings of ``span(E) ∩ ker S`` from ``SE = S E``: ``"all"`` (no rows), ``"none"``, or coefficients."""
    ker_lo, ker_hi, sv, _ = _kernel_readings(SE, k, err, tol)

    def spec(ker: np.ndarray) -> PartSpec:
        if ker.shape[1] == 0:
            return "none"
        if SE.shape[0] == 0:  # no rows: the kernel is the identity, E @ I = E
            return "all"
        return ker

    lower = spec(ker_lo)
    # decided: both readings keep the same singular vectors, so they share one specification
    return lower, (lower if ker_hi.shape[1] == ker_lo.shape[1] else spec(ker_hi)), sv


def eigen_residuals(system: System, mode: str = NORMAL_MODE) -> np.ndarray:
    """Residual norms ``||L_q u_i - w_i u_i||_2`` of the computed eigenpairs (cached).

    With the gap ``delta`` between a group of computed eigenvalues and the rest of the
    spectrum, the Davis-Kahan sin-theta theorem bounds the angle between the computed and the
    exact eigenspace by ``||R_g|| / delta`` (``R_g`` the group's residual block; each computed
    eigenvalue lies within its residual of an exact one, so ``delta`` is shrunk by twice the
    largest residual). This a-posteriori bound replaces the a-priori ``N eps ||L|| / gap``.
    L_q is applied as a sparse matrix: O(nnz * N). For a spectrum kept in factored form these
    are :attr:`~glocal_verify.numerics.spectrum.Spectrum.residual_estimates` (the computed
    residuals carried through the factors); the certified checks read the rigorous
    :attr:`~glocal_verify.numerics.spectrum.Spectrum.residuals` instead.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        The mode q.
    """
    return system.spectrum(mode).residual_estimates


def _kernel_indicators(system: System, mode: str) -> np.ndarray:
    comps = system.components(mode)
    K = np.zeros((system.n, len(comps)))
    for c, comp in enumerate(comps):
        idx = system.idx(comp)
        K[idx, c] = 1.0 / math.sqrt(len(idx))
    return K


def modal_decomposition(system: System, mode: str = NORMAL_MODE, tol: Tolerance = DEFAULT_TOLERANCE) -> ModalDecomposition:
    """Eigen-groups of L_q and, per group, ``W_mu = E_mu ∩ ker S_M`` and ``W^x_mu = E_mu ∩ ker S_{M_x}``.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        Mode whose Laplacian is decomposed.
    tol : Tolerance
        Tolerance of the eigenvalue grouping and of the kernel decisions (module docstring).

    Notes
    -----
    Cost and memory: after the cached spectrum, O(|M| N) time for the simple eigenvalues (the
    singular value of ``S_M u_i`` is the norm of the monitored rows of column ``u_i``) plus a
    ``|M| x k`` SVD per multiple group; memory O(|M| N) beyond the eigenvector matrix ``U``.
    Groups are runs of consecutive indices, so every ``E`` is a view ``U[:, a:b]`` (no copy) and
    ``W``, ``W^x`` are ``E`` itself, an empty array, or (a multiple group with a nonzero
    kernel) a new ``N x r`` array: the new parts of all groups together are at most four
    ``N x N`` arrays (the kernel dimensions of each of ``W``, ``W^x`` and their upper readings sum
    to at most N) on top of ``U``, and O(|M| N) when the multiple groups are few or observed.
    For a safe mode kept in factored form only the monitored rows are computed (``|M| N^2``
    per factor), and a group's ``E`` only when it is read.
    """
    params = (mode, tol.rtol, tol.band)
    kept = _MODAL_KIND.peek(system, params)
    if kept is not None:
        return kept
    system.check_mode(mode)
    sp = system.spectrum(mode)
    w = sp.values
    scale = float(np.max(np.abs(w))) if len(w) else 0.0
    if scale == 0.0:
        scale = 1.0
    split, merged, decided = _partition(w, scale, tol)
    mx = system.idx(system.monitored_positions)
    m = system.idx(system.monitored)
    K = _kernel_indicators(system, mode)
    groups = _group_parts(sp, split, scale, mx, m, tol, K)
    mgroups = groups if decided else _group_parts(sp, merged, scale, mx, m, tol, K)
    md = ModalDecomposition(mode, groups, mgroups, scale, decided)
    _MODAL_KIND.put(system, params, md)
    return md


# --------------------------------------------------------------------------------------------
# modal exponentials and the switched recursion


def block_exponentials(mu: np.ndarray, alpha: float, gamma: float, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Entries of ``exp(B_mu t)``, ``B_mu = [[0, 1], [-alpha mu, -gamma]]``, for each ``mu``.

    With ``d = gamma^2 / 4 - alpha mu`` (so that ``(B + gamma/2 I)^2 = d I``),

    .. math:: e^{B t} = e^{-\\gamma t / 2} \\left( c\\, I + s\\, (B + \\tfrac{\\gamma}{2} I) \\right),
              \\quad c = \\cosh(\\sqrt{d} t),\\; s = \\frac{\\sinh(\\sqrt d t)}{\\sqrt d},

    read as ``cos``/``sin`` for ``d < 0`` and as ``c = 1, s = t`` at the double root ``d = 0``
    (the Jordan case ``gamma^2 = 4 alpha mu``); a series is used near ``d t^2 = 0``, so the
    formula is continuous through the double root.

    Parameters
    ----------
    mu : ndarray
        Eigenvalues of L.
    alpha, gamma : float
        Gains.
    t : float
        Time (negative for the inverse map).

    Returns
    -------
    tuple of ndarray
        ``(p11, p12, p21, p22)``, each of the shape of ``mu``.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        return _block_exponentials(np.asarray(mu, dtype=float), alpha, gamma, t)


def _block_exponentials(mu: np.ndarray, alpha: float, gamma: float, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Body of :func:`block_exponentials` (overflow for huge ``alpha mu t^2`` gives inf/nan, which callers check)."""
    d = gamma * gamma / 4.0 - alpha * mu
    z = d * t * t
    c = np.empty_like(z)
    sfac = np.empty_like(z)
    small = np.abs(z) < 1e-4
    pos = (z >= 1e-4)
    neg = (z <= -1e-4)
    zs = z[small]
    c[small] = 1 + zs / 2 + zs**2 / 24 + zs**3 / 720
    sfac[small] = 1 + zs / 6 + zs**2 / 120 + zs**3 / 5040
    rp = np.sqrt(z[pos])
    c[pos] = np.cosh(rp)
    sfac[pos] = np.sinh(rp) / rp
    rn = np.sqrt(-z[neg])
    c[neg] = np.cos(rn)
    sfac[neg] = np.sin(rn) / rn
    s = t * sfac
    e = math.exp(-gamma * t / 2.0)
    p11 = e * (c + s * gamma / 2.0)
    p12 = e * s
    p21 = e * (-alpha * mu * s)
    p22 = e * (c - s * gamma / 2.0)
    return p11, p12, p21, p22


def modal_exponential(system: System, mode: str, t: float, X: np.ndarray) -> np.ndarray:
    """``exp(A_q t) X`` through the eigendecomposition of L_q (2 x 2 blocks per eigenvalue).

    Cost O(N^2 k) for ``X`` of shape ``2N x k`` (after the cached ``eigh``); never forms A_q.

    Parameters
    ----------
    system : System
        The multi-agent system.
    mode : str
        The mode q.
    t : float
        Time (negative values give ``exp(-A_q |t|)``).
    X : ndarray
        ``2N x k`` (or length-2N) array.
    """
    sp = system.spectrum(mode)
    w = sp.values
    n = system.n
    X = np.asarray(X, dtype=float)
    vec = X.ndim == 1
    if vec:
        X = X[:, None]
    k = X.shape[1]
    ab = sp.project(np.hstack([X[:n], X[n:]]))
    a, b = ab[:, :k], ab[:, k:]
    p11, p12, p21, p22 = block_exponentials(w, system.alpha, system.gamma, t)
    with np.errstate(over="ignore", invalid="ignore"):
        a2 = p11[:, None] * a + p12[:, None] * b
        b2 = p21[:, None] * a + p22[:, None] * b
        out = sp.apply(np.hstack([a2, b2]))
        out = np.vstack([out[:, :k], out[:, k:]])
    return out[:, 0] if vec else out


def apply_A(system: System, mode: str, X: np.ndarray) -> np.ndarray:
    """``A_q X`` for a 2N x k array X, through the sparse Laplacian (no 2N x 2N matrix).

    Parameters
    ----------
    system : System
    mode : str
    X : ndarray
    """
    n = system.n
    L = system.laplacian_sparse(mode)
    return np.vstack([X[n:], -system.alpha * (L @ X[:n]) - system.gamma * X[n:]])
