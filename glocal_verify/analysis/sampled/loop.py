"""The sampled implementation of the closed loop, mode by mode, in the modal structure.

With ``[implementation]`` the detectors sample every measurement at ``t_k = k h`` and a held
signal is constant over a period (zero-order hold). Two deployments are modelled
(``implementation.controller``):

``"sampled"`` (a sampled-data consensus controller)
    every agent samples its neighbours at ``t_k`` and holds ``u_i = -gamma v_i -
    alpha sum_j a_ij (x_i - x_j) + u_a,i`` over the period. The exact discretisation is
    rational in ``h``:

    .. math::

        \\Phi_q = \\begin{bmatrix} I - \\tfrac{\\alpha h^2}{2} L_q & (h - \\tfrac{\\gamma h^2}{2}) I \\\\
                                 -\\alpha h L_q & (1 - \\gamma h) I \\end{bmatrix},\\qquad
        \\Gamma = \\begin{bmatrix} \\tfrac{h^2}{2} I \\\\ h I \\end{bmatrix}

    (:math:`x_{k+1} = \\Phi_q x_k + \\Gamma (u_{a,k} + \\text{disturbance})`).
``"continuous"`` (the consensus loop runs in continuous time; only the detectors sample and
the attacker's injection is held)
    :math:`\\Phi_q = e^{A_q h}`, :math:`\\Gamma_q = \\int_0^h e^{A_q s} ds\\,[0; I]`.

**Modal structure.** Both are functions of ``L_q`` block by block: in the eigenbasis of
``L_q`` (``L_q w = mu w``) the pair (position, velocity) of mode ``mu`` evolves by the 2 x 2
block :math:`\\Phi(\\mu)` and receives the held input through :math:`\\Gamma(\\mu)`; the
eigenvalues of :math:`\\Phi(\\mu)` are :math:`z_\\pm(\\mu)`, the roots of
:math:`(z - 1)(z - 1 + \\gamma h) + \\tfrac{\\alpha \\mu h^2}{2} (z + 1)` (sampled controller)
or :math:`e^{\\lambda_\\pm h}`, :math:`\\lambda_\\pm = (-\\gamma \\pm \\sqrt{\\gamma^2 - 4 \\alpha\\mu})/2`
(continuous loop). No 2N x 2N observability matrix is formed: every question below is one on
these N blocks.

**Certification.** Each eigenvalue of ``L_q`` is known to lie within the certified radius
``rho`` of :attr:`~glocal_verify.numerics.spectrum.Spectrum.error_radius`; the discrete
eigenvalues are enclosed by evaluating the formulas in ball arithmetic (python-flint
``arb``/``acb``) on ``[mu - rho, mu + rho]``, so a separation or an inequality decided on the
enclosures is proven for the exact system.

**Exact facts used by the exact path.** Sampled controller: two blocks share an eigenvalue only
at ``z = -1`` when ``gamma h = 2`` (subtract the two characteristic polynomials), which is also
the only way a block becomes a multiple of I; the loop is stable iff ``gamma h < 2`` and every
eigenvalue of ``L_q`` is below ``2 gamma / (alpha h)`` (Jury's test on the quadratic, linear in
``mu``). Continuous loop at a rational period: two distinct algebraic eigenvalues never
alias, :math:`e^{(\\lambda_a - \\lambda_b) h} \\ne 1` (Lindemann-Weierstrass: otherwise
:math:`\\pi` would be algebraic), so aliasing needs an irrational period (:mod:`.scan`).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Iterator

import flint
import numpy as np
import scipy.linalg
import scipy.spatial

from glocal_verify.derived import Kind
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.exact import observable_rows
from glocal_verify.numerics.rounding import EPS
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE, ImplementationSpec

#: derived results this module keeps on the system (glocal_verify.derived)
_SAMPLED_MODES_KIND: Kind["SampledModes"] = Kind("sampled-modes", __name__, "SampledModes")

__all__ = [
    "ARB_PREC",
    "arb_precision",
    "implementation_of",
    "SampledModes",
    "sampled_modes",
    "block_formulas",
    "sampled_matrices",
    "sampled_matrices_exact",
    "SampledStability",
    "sampled_stability",
    "Aliasing",
    "sampled_aliasing",
    "SampledObservability",
    "sampled_observability",
    "exact_unobservable_dimension",
]

#: working precision (bits) of the ball arithmetic
ARB_PREC = 128


@contextlib.contextmanager
def arb_precision(bits: int = ARB_PREC) -> Iterator[None]:
    """Run the enclosed ball arithmetic at ``bits`` of precision, then restore the previous one."""
    old = flint.ctx.prec
    flint.ctx.prec = bits
    try:
        yield
    finally:
        flint.ctx.prec = old


def implementation_of(system: System, implementation: ImplementationSpec | None = None) -> ImplementationSpec:
    """The given implementation, else the spec's ``[implementation]``.

    Raises
    ------
    NotApplicableError
        When neither is given.
    """
    impl = implementation if implementation is not None else system.spec.implementation
    if impl is None:
        raise NotApplicableError("the spec has no [implementation] (sampling period)")
    return impl


def _ball(q: Fraction) -> flint.arb:
    return flint.arb(flint.fmpq(q.numerator, q.denominator))


def block_formulas(mu: Any, alpha: Any, gamma: Any, h: Any, controller: str) -> tuple[Any, Any, Any, Any, Any, Any]:
    """``(phi11, phi12, phi21, phi22, g1, g2)`` of the block of one Laplacian eigenvalue ``mu``.

    Works on floats, numpy arrays (vectorised over ``mu``) and ``arb`` balls alike for the
    sampled controller; the continuous loop's exponential is written with
    :math:`\\Phi(t) = e^{-\\gamma t/2} (\\cos\\omega t\\, I + \\tfrac{\\sin \\omega t}{\\omega} (M + \\tfrac{\\gamma}{2} I))`
    and its analytic continuation (``omega`` imaginary when overdamped), evaluated through the
    entire functions ``c(x) = cos(sqrt x)`` and ``s(x) = sin(sqrt x)/sqrt x`` of
    ``x = omega^2 t^2`` so that no branch of a square root is ever chosen.

    Parameters
    ----------
    mu, alpha, gamma, h
        The eigenvalue, gains and period (same kinds).
    controller : str
        ``"sampled"`` or ``"continuous"``.
    """
    if controller == "sampled":
        one = h * 0 + 1
        return (one - alpha * mu * h * h / 2, h - gamma * h * h / 2 + mu * 0, -alpha * mu * h, one - gamma * h + mu * 0, h * h / 2 + mu * 0, h + mu * 0)
    x = (alpha * mu - gamma * gamma / 4) * h * h  # (omega h)^2
    c, s = _cos_sinc(x)
    e = _exp(-gamma * h / 2)
    p12 = e * s * h
    p11 = e * c + gamma / 2 * p12
    p21 = -alpha * mu * p12
    p22 = e * c - gamma / 2 * p12
    # Gamma = int_0^h Phi(s) ds [0; 1] = M^{-1} (Phi(h) - I) [0; 1] for mu != 0, written without the
    # inverse: g1 = int phi12, g2 = phi12(h) (since d/ds phi11 ... ); g1 = (1 - phi11 - gamma g... )
    # From M Gamma = (Phi - I) e2: g2 = phi12, -alpha mu g1 - gamma g2 = phi22 - 1.
    g2 = p12
    g1 = _g1(mu, alpha, gamma, h, p22, p12)
    return p11, p12, p21, p22, g1, g2


def _cos_sinc(x: Any) -> tuple[Any, Any]:
    """``cos(sqrt x)`` and ``sin(sqrt x) / sqrt x`` for real x of any sign (entire in x)."""
    if isinstance(x, flint.arb):
        if x > 0:
            r = x.sqrt()
            return r.cos(), r.sin() / r
        if x < 0:
            r = (-x).sqrt()
            return r.cosh(), r.sinh() / r
        # a ball around 0: the series sum_k (-x)^k / (2k)! (resp. (2k+1)!) with a remainder bound
        rr = float(abs(x).upper())
        if rr > 1.0:
            b = math.cosh(math.sqrt(rr)) * (1 + 8 * EPS)
            return flint.arb(0, b), flint.arb(0, b)
        c, s, term = flint.arb(0), flint.arb(0), flint.arb(1)
        for k in range(30):
            c += term / flint.arb(math.factorial(2 * k))
            s += term / flint.arb(math.factorial(2 * k + 1))
            term *= -x
        tail = flint.arb(0, 2.0 / math.factorial(60))  # |x|^30 / 60! (1 + |x| + ...) for |x| <= 1
        return c + tail, s + tail
    xf = np.asarray(x, dtype=float)
    pos = np.sqrt(np.maximum(xf, 0.0))
    neg = np.sqrt(np.maximum(-xf, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        cf = np.where(xf >= 0, np.cos(pos), np.cosh(neg))
        sf = np.where(xf > 0, np.sin(pos) / np.where(pos > 0, pos, 1.0), np.where(xf < 0, np.sinh(neg) / np.where(neg > 0, neg, 1.0), 1.0))
    small = np.abs(xf) < 1e-8
    return np.where(small, 1.0 - xf / 2.0, cf), np.where(small, 1.0 - xf / 6.0, sf)


def _exp(x: Any) -> Any:
    return x.exp() if isinstance(x, flint.arb) else np.exp(x)


def _g1(mu: Any, alpha: Any, gamma: Any, h: Any, p22: Any, p12: Any) -> Any:
    """``int_0^h phi12(s) ds``: from ``-alpha mu g1 = phi22 - 1 + gamma phi12`` when mu is away from 0,
    else by the series of the exponential (the integral of ``e^{M s}`` at small ``alpha mu``)."""
    if isinstance(mu, flint.arb):
        if abs(alpha * mu * h * h).upper() > 1e-3 and not mu.contains(0):
            return -(p22 - 1 + gamma * p12) / (alpha * mu)
        # augmented exponential [[M h, e2 h], [0, 0]] (3 x 3), certified by arb_mat.exp
        M = flint.arb_mat([[0, h, 0], [-alpha * mu * h, -gamma * h, h], [0, 0, 0]])
        return M.exp()[0, 2]
    mu = np.asarray(mu, dtype=float)
    out = np.empty_like(mu)
    far = np.abs(alpha * mu * h * h) > 1e-3
    with np.errstate(invalid="ignore", divide="ignore"):
        out[far] = -(np.asarray(p22)[far] - 1 + gamma * np.asarray(p12)[far]) / (alpha * mu[far])
    if np.any(~far):
        A = np.zeros((int(np.sum(~far)), 3, 3))
        A[:, 0, 1] = h
        A[:, 1, 0] = -alpha * mu[~far] * h
        A[:, 1, 1] = -gamma * h
        A[:, 1, 2] = h
        out[~far] = scipy.linalg.expm(A)[:, 0, 2]
    return out


@dataclass(frozen=True, slots=True)
class SampledModes:
    """The blocks of one mode's sampled loop, one per Laplacian eigenvalue.

    Attributes
    ----------
    mode : str
    period : Fraction
    controller : str
    mu : ndarray
        Eigenvalues of ``L_q`` (ascending, from ``system.spectrum(mode)``).
    mu_radius : float
        Their certified radius.
    clusters : tuple of tuple of int
        Certified clusters of ``mu`` (:attr:`~glocal_verify.numerics.spectrum.Spectrum.clusters`).
    blocks : ndarray
        (N, 2, 2) floating-point :math:`\\Phi(\\mu_l)`.
    inputs : ndarray
        (N, 2) floating-point :math:`\\Gamma(\\mu_l)`.
    z : ndarray
        (N, 2) the two eigenvalues of each block (midpoints of the enclosures).
    z_radius : ndarray
        (N,) certified radius of both enclosures (the exact eigenvalue lies within it for
        the exact ``mu`` in ``[mu - rho, mu + rho]``).
    phi12 : ndarray
        (N, 2) midpoint and radius of the off-diagonal entry :math:`\\Phi_{12}(\\mu)`.
    phi21 : ndarray
        (N, 2) midpoint and radius of :math:`\\Phi_{21}(\\mu)`.
    consensus : int
        Number of zero eigenvalues of ``L_q`` (connected components, exact).
    """

    mode: str
    period: Fraction
    controller: str
    mu: np.ndarray
    mu_radius: float
    clusters: tuple[tuple[int, ...], ...]
    blocks: np.ndarray
    inputs: np.ndarray
    z: np.ndarray
    z_radius: np.ndarray
    phi12: np.ndarray
    phi21: np.ndarray
    consensus: int


def _acb_float(x: flint.acb) -> tuple[complex, float]:
    """Midpoint (rounded) and a radius covering the rounding too."""
    m = complex(float(x.real.mid()), float(x.imag.mid()))
    r = float(x.real.rad()) + float(x.imag.rad()) + 2 * EPS * abs(m) + 1e-300
    return m, r


def _block_eigs(p11: Any, p12: Any, p21: Any, p22: Any) -> tuple[flint.acb, flint.acb]:
    """Enclosures of the eigenvalues of a 2 x 2 block of balls (trace / determinant, branch free)."""
    t = p11 + p22
    d = p11 * p22 - p12 * p21
    disc = t * t - 4 * d
    if disc > 0:
        r = flint.acb(disc.sqrt())
    elif disc < 0:
        r = flint.acb(0, (-disc).sqrt())
    else:
        b = float(abs(disc).upper())
        r = flint.acb(flint.arb(0, math.sqrt(b) * (1 + 4 * EPS)), flint.arb(0, math.sqrt(b) * (1 + 4 * EPS)))
    return (flint.acb(t) + r) / 2, (flint.acb(t) - r) / 2


def sampled_modes(system: System, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None) -> SampledModes:
    """The sampled blocks of ``mode`` with certified eigenvalue enclosures (module docstring).

    Parameters
    ----------
    system : System
    mode : str
    implementation : ImplementationSpec, optional
        Default the spec's ``[implementation]``.
    """
    impl = implementation_of(system, implementation)
    mode = system.check_mode(mode)
    key = (mode, impl.period, impl.controller)

    def build() -> SampledModes:
        sp = system.spectrum(mode)
        mu = np.asarray(sp.values, dtype=float)
        rho = float(sp.error_radius)
        a, g, h = system.alpha_q, system.gamma_q, impl.period
        p11, p12, p21, p22, g1, g2 = block_formulas(mu, float(a), float(g), float(h), impl.controller)
        n = len(mu)
        blocks = np.empty((n, 2, 2))
        blocks[:, 0, 0], blocks[:, 0, 1], blocks[:, 1, 0], blocks[:, 1, 1] = p11, p12, p21, p22
        inputs = np.stack([np.broadcast_to(g1, mu.shape), np.broadcast_to(g2, mu.shape)], axis=1).astype(float)
        z = np.empty((n, 2), dtype=complex)
        zr = np.empty(n)
        f12 = np.empty((n, 2))
        f21 = np.empty((n, 2))
        consensus = len(system.components(mode))
        with arb_precision():
            ab, gb, hb = _ball(a), _ball(g), _ball(h)
            for l in range(n):
                m = flint.arb(0) if l < consensus else flint.arb(float(mu[l]), rho)
                q11, q12, q21, q22, _, _ = block_formulas(m, ab, gb, hb, impl.controller)
                zp, zm = _block_eigs(q11, q12, q21, q22)
                (z[l, 0], r0), (z[l, 1], r1) = _acb_float(zp), _acb_float(zm)
                zr[l] = max(r0, r1)
                f12[l] = (float(q12.mid()), float(q12.rad()) + 2 * EPS * abs(float(q12.mid())))
                f21[l] = (float(q21.mid()), float(q21.rad()) + 2 * EPS * abs(float(q21.mid())))
        return SampledModes(mode, h, impl.controller, mu, rho, sp.clusters, blocks, inputs, z, zr, f12, f21, consensus)

    return _SAMPLED_MODES_KIND.get(system, key, build)


def sampled_matrices(system: System, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Dense floating-point :math:`(\\Phi_q, \\Gamma_q)` (2N x 2N and 2N x N), for small systems.

    The sampled controller's matrices from their rational formula (one rounding per entry);
    the continuous loop's by ``scipy.linalg.expm`` of the augmented
    ``[[A_q h, [0; I] h], [0, 0]]`` (scaling and squaring, backward error of the order of the
    unit roundoff times its norm).
    """
    impl = implementation_of(system, implementation)
    n = system.n
    h = float(impl.period)
    L = system.laplacian(mode)
    a, g = system.alpha, system.gamma
    if impl.controller == "sampled":
        I = np.eye(n)
        Phi = np.block([[I - a * h * h / 2 * L, (h - g * h * h / 2) * I], [-a * h * L, (1 - g * h) * I]])
        Gam = np.vstack([h * h / 2 * I, h * I])
        return Phi, Gam
    M = np.zeros((3 * n, 3 * n))
    M[: 2 * n, : 2 * n] = system.A(mode) * h
    M[n : 2 * n, 2 * n :] = np.eye(n) * h
    E = scipy.linalg.expm(M)
    return E[: 2 * n, : 2 * n].copy(), E[: 2 * n, 2 * n :].copy()


def sampled_matrices_exact(system: System, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None, prec: int = ARB_PREC) -> tuple[Any, Any]:
    """:math:`(\\Phi_q, \\Gamma_q)` exactly: ``fmpq_mat`` for the sampled controller, certified
    ``arb_mat`` enclosures (``arb_mat.exp`` of the augmented matrix, at ``prec`` bits) for the
    continuous loop."""
    impl = implementation_of(system, implementation)
    n = system.n
    L = system.laplacian_exact(mode)
    a, g, h = system.alpha_q, system.gamma_q, impl.period
    if impl.controller == "sampled":
        c12, c22 = h - g * h * h / 2, 1 - g * h
        rows: list[list[Any]] = []
        for i in range(n):
            rows.append([(1 if i == j else 0) - a * h * h / 2 * L[i][j] for j in range(n)] + [c12 if i == j else 0 for j in range(n)])
        for i in range(n):
            rows.append([-a * h * L[i][j] for j in range(n)] + [c22 if i == j else 0 for j in range(n)])
        grows: list[list[Any]] = [[h * h / 2 if i == j else 0 for j in range(n)] for i in range(n)] + [[h if i == j else 0 for j in range(n)] for i in range(n)]
        return _fmpq(rows, 2 * n, 2 * n), _fmpq(grows, 2 * n, n)
    with arb_precision(prec):
        M = flint.arb_mat(3 * n, 3 * n)
        hb = _ball(h)
        for i in range(n):
            M[i, n + i] = hb
            M[n + i, n + i] = -_ball(g) * hb
            M[n + i, 2 * n + i] = hb
            for j in range(n):
                if L[i][j]:
                    M[n + i, j] = -_ball(a * L[i][j]) * hb
        E = M.exp()
        Phi = flint.arb_mat(2 * n, 2 * n)
        Gam = flint.arb_mat(2 * n, n)
        for i in range(2 * n):
            for j in range(2 * n):
                Phi[i, j] = E[i, j]
            for j in range(n):
                Gam[i, j] = E[i, 2 * n + j]
    return Phi, Gam


def _fmpq(rows: list[list[Any]], m: int, k: int) -> flint.fmpq_mat:
    flat = []
    for r in rows:
        for x in r:
            q = Fraction(x)
            flat.append(flint.fmpq(q.numerator, q.denominator))
    return flint.fmpq_mat(m, k, flat)


# --------------------------------------------------------------------------------------------
# stability


@dataclass(frozen=True, slots=True)
class SampledStability:
    """Is the sampled loop stable apart from the consensus (one eigenvalue 1 per component)?

    Attributes
    ----------
    mode : str
    status : Status
        HOLDS: every other eigenvalue of :math:`\\Phi_q` has modulus < 1.
    spectral_radius : float
        Largest modulus of the other eigenvalues (midpoint).
    error_bound : float
        Certified radius of that modulus.
    limit_period : Fraction or float or None
        Sampled controller: the largest stable period ``min(2 / gamma, 2 gamma / (alpha mu_max))``
        (a float when ``mu_max`` is irrational); None for the continuous loop (stable for every h).
    method : str
        ``"enclosure"`` or ``"exact"`` (Jury's test over Q).
    """

    mode: str
    status: Status
    spectral_radius: float
    error_bound: float
    limit_period: Fraction | float | None
    method: str

    @property
    def margin(self) -> float:
        """``1 - spectral_radius``."""
        return 1.0 - self.spectral_radius


def _non_consensus(sm: SampledModes) -> tuple[np.ndarray, np.ndarray]:
    """Moduli and radii of every eigenvalue but the consensus 1 of each zero eigenvalue of L_q."""
    z = sm.z.copy()
    r = np.repeat(sm.z_radius[:, None], 2, axis=1)
    mods = np.abs(z)
    keep = np.ones_like(mods, dtype=bool)
    for l in range(sm.consensus):
        keep[l, int(np.argmin(np.abs(z[l] - 1.0)))] = False
    return mods[keep], r[keep]


def _mu_max_below(system: System, mode: str, c: Fraction) -> bool:
    """Exact: every eigenvalue of L_q is < c (Descartes on p(c - y): all roots real, so its sign
    changes count its positive roots exactly)."""
    from glocal_verify.numerics import exact as ex

    p = ex.charpoly(system.laplacian_exact(mode))
    n = p.degree()
    # q(y) = p(c - y) via the Taylor shift of p at c, then y -> -y
    cq = flint.fmpq(c.numerator, c.denominator)
    shifted = p(flint.fmpq_poly([cq, -1]))
    coeffs = [shifted[k] for k in range(n + 1)]
    if any(x == 0 for x in coeffs):
        return False
    return all((coeffs[k] > 0) != (coeffs[k + 1] > 0) for k in range(n))


def sampled_stability(system: System, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None, *, exact: bool = False) -> SampledStability:
    """Stability of the sampled loop (module docstring): certified from the enclosures, or exact.

    Parameters
    ----------
    system : System
    mode : str
    implementation : ImplementationSpec, optional
    exact : bool
        Decide the sampled controller by Jury's test over Q (``gamma h < 2`` and
        ``L_q < 2 gamma / (alpha h)``); the continuous loop is stable for every h (alpha, gamma > 0).
    """
    impl = implementation_of(system, implementation)
    sm = sampled_modes(system, mode, impl)
    mods, rad = _non_consensus(sm)
    rmax = float(mods.max()) if len(mods) else 0.0
    err = float(rad.max()) if len(rad) else 0.0
    limit: Fraction | float | None = None
    a, g, h = system.alpha_q, system.gamma_q, impl.period
    if impl.controller == "sampled":
        mu_max = float(sm.mu[-1]) if len(sm.mu) else 0.0
        cand: list[Fraction | float] = [Fraction(2) / g] + ([float(2 * g / a) / mu_max] if mu_max > 0 else [])
        limit = min(cand)
    if exact or impl.controller == "continuous":
        if impl.controller == "continuous":
            status = Status.HOLDS
        else:
            status = Status.HOLDS if (g * h < 2 and _mu_max_below(system, mode, 2 * g / (a * h))) else Status.FAILS
        return SampledStability(sm.mode, status, rmax, err, limit, "exact")
    if np.all(mods + rad < 1.0):
        status = Status.HOLDS
    elif np.any(mods - rad > 1.0) or g * h >= 2:
        status = Status.FAILS
    else:
        status = Status.UNDECIDED
    return SampledStability(sm.mode, status, rmax, err, limit, "enclosure")


# --------------------------------------------------------------------------------------------
# aliasing


@dataclass(frozen=True, slots=True)
class Aliasing:
    """Do distinct eigenvalues of ``L_q`` keep distinct sampled eigenvalues?

    :math:`\\Phi_q` is non-derogatory on the sampled modes when no two blocks of distinct
    eigenvalue clusters share an eigenvalue and no block is a multiple of I; then
    :math:`\\Phi_q` has the eigenvectors of ``A_q`` and every subspace invariant under one is
    invariant under the other.

    Attributes
    ----------
    mode : str
    status : Status
        HOLDS: certified no aliasing; FAILS: proven aliasing (sampled controller at
        ``gamma h = 2``); UNDECIDED: an enclosure overlap (escalation decides).
    margin : float
        Smallest distance between sampled eigenvalues of distinct clusters, and of the
        off-diagonal entry of a block from 0 (midpoints).
    error_bound : float
        The certified radius involved at the closest pair.
    closest : dict
        The closest pair: ``mu`` values, sampled eigenvalues, and for the continuous loop the
        winding ``k`` and the pathological period ``h* = 2 pi k / |omega_a -/+ omega_b|`` nearest h.
    overlaps : tuple of (int, int)
        Cluster indices (first positions) whose enclosures overlap (at most 20).
    method : str
    """

    mode: str
    status: Status
    margin: float
    error_bound: float
    closest: dict[str, Any]
    overlaps: tuple[tuple[int, int], ...]
    method: str


def _omega(mu: float, a: float, g: float) -> float:
    x = a * mu - g * g / 4
    return math.sqrt(x) if x > 0 else 0.0


def sampled_aliasing(system: System, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None, *, exact: bool = False) -> Aliasing:
    """Aliasing of the sampled modes (class docstring); ``exact`` decides by the module's exact facts.

    Complexity: O(c log c) for c certified eigenvalue clusters (a k-d tree finds the nearest
    sampled eigenvalue of another cluster and every pair close enough to overlap), plus one
    enclosure per eigenvalue (:func:`sampled_modes`).
    """
    impl = implementation_of(system, implementation)
    sm = sampled_modes(system, mode, impl)
    a, g, h = float(system.alpha_q), float(system.gamma_q), float(impl.period)
    cl = [list(c) for c in sm.clusters]
    reps = np.array([c[0] for c in cl], dtype=int)
    # one enclosure per cluster: the members' balls together
    zc = sm.z[reps]  # (c, 2)
    spread = np.array([float(np.max(np.abs(sm.z[c] - sm.z[c[0]][None, :]))) + float(sm.z_radius[c].max()) for c in cl])
    # off-diagonal entries: a block is a multiple of I only if both vanish
    off = np.maximum(np.abs(sm.phi12[reps, 0]) - sm.phi12[reps, 1], np.abs(sm.phi21[reps, 0]) - sm.phi21[reps, 1])
    off_mid = np.maximum(np.abs(sm.phi12[reps, 0]), np.abs(sm.phi21[reps, 0]))
    flat = zc.reshape(-1)
    rad = np.repeat(spread, 2)
    owner = np.repeat(np.arange(len(cl)), 2)
    # candidate pairs by a k-d tree (O(c log c)): the nearest points of other clusters, and every
    # pair close enough to overlap; only those are compared
    pts = np.column_stack([flat.real, flat.imag])
    tree = scipy.spatial.cKDTree(pts)
    kq = min(len(flat), 4)
    dist, nb = tree.query(pts, k=kq)
    dist, nb = np.atleast_2d(dist), np.atleast_2d(nb)
    other = owner[nb] != owner[:, None]
    dnear = np.where(other, dist, np.inf)
    first = np.argmin(dnear, axis=1) if dnear.size else np.zeros(0, dtype=int)
    near_d = dnear[np.arange(len(flat)), first] if dnear.size else np.zeros(0)
    near_j = nb[np.arange(len(flat)), first] if dnear.size else np.zeros(0, dtype=int)
    reach = 2.0 * (float(rad.max(initial=0.0)) * (1 + 8 * EPS) + 4 * EPS * float(np.abs(flat).max(initial=1.0)))
    pairs = tree.query_pairs(reach, output_type="ndarray") if len(flat) > 1 else np.zeros((0, 2), dtype=int)
    pairs = pairs[owner[pairs[:, 0]] != owner[pairs[:, 1]]] if len(pairs) else pairs

    def bound(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        return (rad[i] + rad[j]) * (1 + 8 * EPS) + 4 * EPS * np.maximum(np.abs(flat[i]), np.abs(flat[j]))

    bad = pairs[np.abs(flat[pairs[:, 0]] - flat[pairs[:, 1]]) <= bound(pairs[:, 0], pairs[:, 1])] if len(pairs) else pairs
    certified = len(bad) == 0 and bool(np.all(off > 0))
    overlaps = []
    if not certified:
        overlaps = [(int(reps[owner[i]]), int(reps[owner[j]])) for i, j in bad[:20]]
        overlaps += [(int(reps[k]), int(reps[k])) for k in np.flatnonzero(off <= 0)[:20]]
    dmin = float(near_d.min()) if near_d.size else math.inf
    margin = float(min(dmin, off_mid.min() if off_mid.size else math.inf))
    i = int(np.argmin(near_d)) if near_d.size else 0
    j = int(near_j[i]) if near_d.size else 0
    closest: dict[str, Any] = {}
    if math.isfinite(dmin):
        la, lb = int(reps[owner[i]]), int(reps[owner[j]])
        closest = {"mu": [float(sm.mu[la]), float(sm.mu[lb])], "z": [complex(flat[i]), complex(flat[j])], "distance": dmin}
        if impl.controller == "continuous":
            wa, wb = _omega(float(sm.mu[la]), a, g), _omega(float(sm.mu[lb]), a, g)
            best = None
            for dw in (abs(wa - wb), wa + wb):
                if dw > 0:
                    k = max(1, round(dw * h / (2 * math.pi)))
                    hs = 2 * math.pi * k / dw
                    if best is None or abs(hs - h) < abs(best[1] - h):
                        best = (k, hs)
            if best is not None:
                closest["winding"], closest["nearest_pathological_period"] = best
    err = float(bound(np.array([i]), np.array([j]))[0]) if math.isfinite(dmin) else 0.0
    gh = system.gamma_q * impl.period
    if exact:
        status = Status.FAILS if (impl.controller == "sampled" and gh == 2) else Status.HOLDS
        return Aliasing(sm.mode, status, margin, err, closest, tuple(overlaps), "exact")
    if impl.controller == "sampled" and gh == 2:
        status = Status.FAILS
    else:
        status = Status.HOLDS if certified else Status.UNDECIDED
    return Aliasing(sm.mode, status, margin, err, closest, tuple(overlaps), "enclosure")


# --------------------------------------------------------------------------------------------
# observability


@dataclass(frozen=True, slots=True)
class SampledObservability:
    """Does sampling hide more than the continuous loop? ``N(Phi_q, C)`` against ``N(A_q, C)``.

    Attributes
    ----------
    mode : str
    status : Status
        HOLDS: the two unobservable subspaces coincide; FAILS: sampling hides more.
    dim_continuous : int or None
        ``dim N(A_q, C)`` (None when not decided).
    dim_sampled : int or None
        ``dim N(Phi_q, C)`` (None when not decided).
    reason : str
        Why (no aliasing; the exact dimensions; the proven extra directions).
    aliasing : Aliasing
    """

    mode: str
    status: Status
    dim_continuous: int | None
    dim_sampled: int | None
    reason: str
    aliasing: Aliasing


def exact_unobservable_dimension(A: flint.fmpq_mat, C: flint.fmpq_mat) -> int:
    """``dim`` of the unobservable subspace of a rational pair: n minus the rank of the Krylov
    closure of the rows of C under A over Q (:func:`~glocal_verify.numerics.exact.observable_rows`;
    the exact path, for small systems)."""
    return A.ncols() - observable_rows(A, C).nrows()


def sampled_observability(system: System, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None, *, exact: bool = False) -> SampledObservability:
    """Sampled against continuous unobservable subspace (Kalman-Ho-Narendra).

    Without aliasing (:func:`sampled_aliasing`) :math:`A_q` is a polynomial in
    :math:`\\Phi_q` (the map ``z = f(lambda)`` is injective on the spectrum and :math:`\\Phi_q`
    non-derogatory on the sampled modes), so both have the same invariant subspaces and the
    same unobservable subspace: HOLDS. The sampled controller at ``gamma h = 2`` maps every
    ``[0; v]`` to ``[0; -v]`` exactly, so ``[0; v]`` with ``S_M [0; v] = 0`` is unobservable:
    FAILS when those directions outnumber ``dim N(A_q, C)`` (exact mode compares the exact
    dimensions, computed over Q for the sampled controller). Otherwise UNDECIDED.
    """
    impl = implementation_of(system, implementation)
    al = sampled_aliasing(system, mode, impl, exact=exact)
    if al.status is Status.HOLDS:
        return SampledObservability(al.mode, Status.HOLDS, None, None, "no aliasing: A_q is a polynomial in Phi_q, so N(Phi_q, C) = N(A_q, C)", al)
    if impl.controller == "sampled" and system.gamma_q * impl.period == 2:
        n = system.n
        free_v = n - len(system.monitored_velocities)
        if exact or n <= 200:
            from glocal_verify.analysis.unobservable.subspace import unobservable_subspace_exact

            Phi, _ = sampled_matrices_exact(system, mode, impl)
            Cq = _fmpq([list(r) for r in system.C().astype(int).tolist()], system.C().shape[0], 2 * n)
            ds = exact_unobservable_dimension(Phi, Cq)
            dc = len(unobservable_subspace_exact(system, mode))
            st = Status.HOLDS if ds == dc else Status.FAILS
            return SampledObservability(al.mode, st, dc, ds, "exact dimensions over Q (gamma h = 2)", al)
        from glocal_verify.analysis.unobservable.subspace import certified_unobservable

        cu = certified_unobservable(system, mode)
        if free_v > cu.dim_upper:
            return SampledObservability(al.mode, Status.FAILS, None, free_v, f"gamma h = 2: every [0; v] with S_Mv v = 0 ({free_v} directions) is an eigenvector of Phi_q for -1 in ker C, more than dim N(A_q, C) <= {cu.dim_upper}", al)
    return SampledObservability(al.mode, Status.UNDECIDED, None, None, "possible aliasing (enclosures overlap): " + ", ".join(f"mu[{i}]~mu[{j}]" for i, j in al.overlaps[:5]), al)
