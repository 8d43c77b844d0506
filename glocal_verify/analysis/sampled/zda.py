"""Zero-dynamics attacks of the sampled loop: the discrete pencil of :math:`(\\Phi_1, \\Gamma_F, C)`.

A sampled attacker holds its injection over each period, so a discrete zero-dynamics attack
is :math:`u_k = u_0 z_0^k` with :math:`\\tilde x_k = \\tilde x_0 z_0^k`, where

.. math::

    \\begin{bmatrix} z_0 I - \\Phi_1 & -\\Gamma_F \\\\ C & 0 \\end{bmatrix}
    \\begin{bmatrix} \\tilde x_0 \\\\ u_0 \\end{bmatrix} = 0,\\qquad u_0 \\ne 0

(Definition II.2 for the sampled system). ``|z_0| > 1`` grows, ``|z_0| = 1`` persists,
``|z_0| < 1`` decays. Sampling creates zeros:

**The sampling zero at -1 (sampled controller).** Per Laplacian mode the response of the
held input is :math:`(z I - \\Phi(\\mu))^{-1} \\Gamma = [\\tfrac{h^2}{2}(z + 1);\\ h (z - 1)] / d_\\mu(z)`
with :math:`d_\\mu(-1) = 2 (2 - \\gamma h)` independent of ``mu``: at ``z = -1`` the positions
at the samples do not move and every velocity moves by ``-h / (2 - gamma h)`` times its own
input. So ``u_k = (-1)^k u_0`` with ``u_0`` on the attacked agents whose velocities are not
monitored globally is a stealthy (bounded, persistent) attack for every period: it exists iff
``F`` is not contained in ``M_v`` (:func:`nyquist_zero`, exact).

The numeric path analyses the dense pencil (:func:`~glocal_verify.numerics.pencil.analyze_pencil`,
certified at the tolerance, for systems up to :data:`DENSE_ZDA_MAX_AGENTS` agents); the exact
path uses the geometric analysis over Q for the sampled controller
(:func:`~glocal_verify.numerics.pencil_exact.analyze_pencil_exact`). The continuous loop's
pencil is transcendental: it has no exact path.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from glocal_verify.analysis.sampled.loop import implementation_of, sampled_matrices, sampled_matrices_exact
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.pencil import analyze_pencil, direction_at, input_directions
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.results import Status, growth_of_sign
from glocal_verify.spec.types import NORMAL_MODE, ImplementationSpec, Label

__all__ = [
    "DENSE_ZDA_MAX_AGENTS",
    "SampledZero",
    "SampledZda",
    "nyquist_zero",
    "sampled_zda",
    "SampledZdaDirection",
    "sampled_zda_direction",
]

#: largest network whose dense discrete pencil is analysed
DENSE_ZDA_MAX_AGENTS = 400


@dataclass(frozen=True, slots=True)
class SampledZero:
    """A zero of the sampled pencil.

    Attributes
    ----------
    value : complex
    modulus : float
    growth : str
        ``"unbounded"`` (|z| > 1), ``"persistent"`` (|z| = 1 within 1e-12) or ``"decaying"``.
    attack : bool or None
        The kernel holds a direction with ``u != 0``: True; only ``u = 0`` (an unobservable mode
        of (Phi_1, C), no attack): False; None when floating point could not tell
        (:func:`~glocal_verify.numerics.pencil.input_directions`).
    """

    value: complex
    modulus: float
    growth: str
    attack: bool | None


@dataclass(frozen=True, slots=True)
class SampledZda:
    """The stealthy zero-dynamics attacks of the sampled loop.

    Attributes
    ----------
    status : Status
        HOLDS: a stealthy ZDA exists (the pencil is not left-invertible, or a zero carries an
        input direction); FAILS: none; UNDECIDED: the certified analysis did not decide.
    left_invertible : bool or None
    zeros : tuple of SampledZero
    nyquist : tuple of labels or None
        Sampled controller: the attacked agents whose velocities are not monitored (the zero
        at -1 exists iff this is non-empty); None for the continuous loop.
    method : str
        ``"numeric"`` or ``"exact"``.
    note : str
    """

    status: Status
    left_invertible: bool | None
    zeros: tuple[SampledZero, ...]
    nyquist: tuple[Label, ...] | None
    method: str
    note: str = ""

    @property
    def largest_modulus(self) -> float:
        """``inf`` when not left-invertible, else the largest modulus of an attack zero (0 if none)."""
        if self.left_invertible is False:
            return math.inf
        return max((z.modulus for z in self.zeros if z.attack), default=0.0)


def _growth(mod: float) -> str:
    """The growth class of a sampled zero of modulus ``mod``: |z| = 1 within 1e-12 is persistent."""
    return growth_of_sign(0 if abs(mod - 1.0) <= 1e-12 else 1 if mod > 1.0 else -1)


def nyquist_zero(system: System, actuators: Sequence[Label]) -> tuple[Label, ...]:
    """The attacked agents whose velocity is not monitored globally: with a sampled controller,
    the held input ``(-1)^k u_0`` on them is a stealthy ZDA at ``z = -1`` (module docstring)."""
    mv = set(system.monitored_velocities)
    return tuple(a for a in actuators if a not in mv)


def sampled_zda(
    system: System,
    implementation: ImplementationSpec | None = None,
    actuators: Sequence[Label] | None = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
    *,
    exact: bool = False,
) -> SampledZda:
    """The zeros of the sampled pencil in the normal mode (module docstring).

    Parameters
    ----------
    system : System
    implementation : ImplementationSpec, optional
    actuators : sequence of labels, optional
        Default: the spec's attacked actuators.
    tol : Tolerance
    exact : bool
        The geometric analysis over Q (sampled controller only).
    """
    impl = implementation_of(system, implementation)
    F = tuple(system.attacked if actuators is None else actuators)
    if not F:
        raise NotApplicableError("no attacked actuators")
    idx = system.idx(F)
    nyq = nyquist_zero(system, F) if impl.controller == "sampled" else None
    if exact and impl.controller == "sampled":
        from glocal_verify.numerics.exact import to_fraction
        from glocal_verify.numerics.pencil_exact import analyze_pencil_exact

        Phi, Gam = sampled_matrices_exact(system, NORMAL_MODE, impl)
        A = [[to_fraction(Phi[i, j]) for j in range(Phi.ncols())] for i in range(Phi.nrows())]
        B = [[to_fraction(Gam[i, j]) for j in idx] for i in range(Gam.nrows())]
        C = [[int(x) for x in row] for row in system.C()]
        ea = analyze_pencil_exact(A, B, C, directions=True)
        zs = tuple(SampledZero(complex(z.value), abs(complex(z.value)), _growth(abs(complex(z.value))), bool(z.input_direction)) for z in ea.zeros)
        st = Status.HOLDS if (not ea.left_invertible or any(z.attack for z in zs)) else Status.FAILS
        return SampledZda(st, ea.left_invertible, zs, nyq, "exact")
    if system.n > DENSE_ZDA_MAX_AGENTS:
        note = f"not analysed: {system.n} agents > {DENSE_ZDA_MAX_AGENTS} (dense discrete pencil)"
        if nyq:
            return SampledZda(Status.HOLDS, None, (), nyq, "numeric", note + "; the zero at -1 exists (exact, structural)")
        return SampledZda(Status.UNDECIDED, None, (), nyq, "numeric", note)
    Ad, Bd = _delta_form(system, impl, idx)
    pa = analyze_pencil(Ad, Bd, system.C(), None, tol)
    h = float(impl.period)
    zv = [1.0 + h * complex(z.value) for z in pa.zeros]
    # an attack zero needs an input direction, decided by the kernels' dimensions (a computed
    # direction's input part is never exactly zero: the consensus mode at z = 1 was reported as
    # an attack with every velocity monitored)
    inputs = input_directions(Ad, Bd, system.C(), None, [z.value for z in pa.zeros], tol)
    kinds = {Decision.NONZERO: True, Decision.ZERO: False, Decision.UNDECIDED: None}
    zs = tuple(SampledZero(v, abs(v), _growth(abs(v)), kinds[d]) for v, d in zip(zv, inputs))
    notes = list(pa.notes) + [f"zero {z.value:.6g}: whether it carries an input direction is undecided" for z in zs if z.attack is None]
    if nyq:
        st = Status.HOLDS  # proven structurally, whatever the floating-point analysis says
    elif not pa.decided:
        st = Status.UNDECIDED
    elif pa.left_invertible is False or any(z.attack for z in zs):
        st = Status.HOLDS
    else:
        st = Status.FAILS if all(z.attack is False for z in zs) else Status.UNDECIDED
    return SampledZda(st, pa.left_invertible if pa.decided else None, zs, nyq, "numeric", "; ".join(notes))


def _delta_form(system: System, impl: ImplementationSpec, idx: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """``((Phi_1 - I) / h, Gamma_F / h)``: the delta-operator form of the sampled pencil.

    ``[z I - Phi, -Gamma_F; C, 0]`` and ``[delta I - (Phi - I)/h, -Gamma_F/h; C, 0]`` with
    ``z = 1 + h delta`` have the same kernels (the first block row divided by h), but the
    second is scaled like the continuous pencil as ``h -> 0`` instead of crowding every zero
    near 1.
    """
    Phi, Gam = sampled_matrices(system, NORMAL_MODE, impl)
    h = float(impl.period)
    return (Phi - np.eye(Phi.shape[0])) / h, Gam[:, list(idx)] / h


@dataclass(frozen=True, slots=True)
class SampledZdaDirection:
    """A sampled ZDA to simulate: ``u_k = u0 z0^k`` and the state deviation ``x~0 z0^k``.

    Attributes
    ----------
    z0 : complex
    x0 : ndarray
        ``x~0`` (2N, complex), normalised with ``u0``: ``||[x~0; u0]|| = 1``.
    u0 : ndarray
        (|F|,) complex.
    actuators : tuple of labels
    source : str
        How ``z0`` was chosen.
    residual : float
        ``||P(z0) [x~0; u0]||`` (floating point).
    """

    z0: complex
    x0: np.ndarray
    u0: np.ndarray
    actuators: tuple[Label, ...]
    source: str
    residual: float


def sampled_zda_direction(
    system: System,
    implementation: ImplementationSpec | None = None,
    *,
    lambda0: complex | None = None,
    z0: complex | None = None,
    actuators: Sequence[Label] | None = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
) -> SampledZdaDirection:
    """A sampled ZDA direction for the spec's attacker.

    ``z0`` when given; else ``exp(lambda0 h)`` (``lambda0`` default the spec's
    ``attack.lambda0``, else 1/2) when the pencil loses rank there (always when it is not
    left-invertible), else the attack zero nearest it.

    Raises
    ------
    NotApplicableError
        When no stealthy direction exists.
    """
    impl = implementation_of(system, implementation)
    F = tuple(system.attacked if actuators is None else actuators)
    idx = system.idx(F)
    Ad, Bd = _delta_form(system, impl, idx)
    C = system.C()
    h = float(impl.period)

    def at(zz: complex) -> tuple[np.ndarray, np.ndarray] | None:
        return direction_at(Ad, Bd, C, None, (zz - 1.0) / h, tol)

    if z0 is None:
        lam = lambda0
        if lam is None:
            a = system.spec.attack
            lam = a.lambda0 if (a is not None and a.lambda0 is not None) else 0.5
        target = cmath.exp(complex(lam) * h)
        got = at(target)
        source = f"z0 = exp(lambda0 h) with lambda0 = {complex(lam):g}"
        if got is None or np.linalg.norm(got[1]) == 0:
            za = sampled_zda(system, impl, F, tol)
            cands = [z for z in za.zeros if z.attack]
            if not cands:
                raise NotApplicableError("the sampled loop has no stealthy zero-dynamics attack for these actuators")
            best = min(cands, key=lambda z: abs(z.value - target))
            target = best.value
            got = at(target)
            source = f"the sampled zero nearest exp(lambda0 h) (lambda0 = {complex(lam):g})"
        z = target
    else:
        z = complex(z0)
        got = at(z)
        source = "given z0"
    if got is None or np.linalg.norm(got[1]) == 0:
        raise NotApplicableError(f"no stealthy direction with an input at z0 = {z:g}")
    x, u = got
    s = float(np.linalg.norm(np.concatenate([x, u])))
    x, u = np.asarray(x, dtype=complex) / s, np.asarray(u, dtype=complex) / s
    Phi, Gam = sampled_matrices(system, NORMAL_MODE, impl)
    B = Gam[:, idx]
    P: Any = np.block([[z * np.eye(len(x)) - Phi, -B], [C, np.zeros((C.shape[0], B.shape[1]))]])
    res = float(np.linalg.norm(P @ np.concatenate([x, u])))
    return SampledZdaDirection(complex(z), x, u, F, source, res)
