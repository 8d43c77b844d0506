"""Stealthy attacks on the sampled implementation, and the exact composite systems they drive.

**Attacks.** Every attack here is one held complex mode: the attacker injects
:math:`u_k = \\operatorname{Re}(a\\,u_0 z^{k - k_a})` on its actuators ``F`` for ``k >= k_a``
(``a`` the size, ``u_0`` a unit direction):

* a sampled **ZDA** (:func:`~glocal_verify.analysis.sampled.zda.sampled_zda_direction`) at the
  zero ``z = z_0`` with the state deviation :math:`\\operatorname{Re}(a \\tilde x_0)` added at
  ``k_a`` (as in the continuous simulator: the deviation the attacker's initial state needs);
* a **covert** attack (Proposition II.4 (i)): ``step`` (``z = 1``), ``sine`` (``z = e^{i 2 pi f h}``,
  ``u_0 = -i``: the sine) or ``exponential`` (``z = e^{lambda0 h}``), equal on every attacked
  actuator; the attacker runs a copy :math:`\\tilde x^c` of the normal-mode model from 0 and
  subtracts :math:`C \\tilde x^c` from the compromised global channels.

**Composites** (exact ``fmpq_mat``). The central observer's error ``e = x - \\hat x`` after a
switch to mode q obeys :math:`e_{k+1} = F e_k + (\\Phi_q - \\Phi_1) x_k + \\Gamma_F u_k + H S C
\\tilde x^c_k` (S selects the spoofed channels) and its residual is
:math:`r_k = C e_k - S C \\tilde x^c_k`. Since :math:`\\Phi_q - \\Phi_1` and ``C`` (under
privacy) vanish on the consensus directions, the plant and the copy enter through their
quotients :math:`p = \\pi x`, :math:`c = \\pi \\tilde x^c` (:func:`~glocal_verify.observers.sampled.consensus_quotient`),
so the composite state :math:`\\zeta = (p, c, \\epsilon)` evolves by a **stable** matrix
(the quotient of the sampled loop, its copy and the observer's error dynamics):

.. math::

    \\zeta_{k+1} = M_q \\zeta_k + N_u u_k + N_w w_k - N_n n_k,\\qquad
    r_k = R \\zeta_k + n_k,\\qquad
    M_q = \\begin{bmatrix} \\pi\\Phi_q\\sigma & 0 & 0 \\\\ 0 & \\pi\\Phi_1\\sigma & 0 \\\\
                         \\pi(\\Phi_q - \\Phi_1)\\sigma & \\pi H S C \\sigma & F \\end{bmatrix}.

Before the switch ``q = 1`` and the plant does not reach the error. A local UIO's error is
decoupled from the plant (:mod:`glocal_verify.observers.sampled`): its composite is its own
``F`` with input :math:`T \\Gamma^i_F`.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.analysis.sampled.loop import implementation_of, sampled_matrices_exact
from glocal_verify.analysis.sampled.zda import sampled_zda_direction
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.exact import columns as exact_columns
from glocal_verify.observers.sampled import SampledObserver, consensus_quotient
from glocal_verify.results import jsonable
from glocal_verify.spec.types import NORMAL_MODE, ImplementationSpec, Label

__all__ = [
    "SampledAttack",
    "sampled_attack_from_spec",
    "Composite",
    "central_composite",
    "local_composite",
    "block",
]


@dataclass(frozen=True, slots=True)
class SampledAttack:
    """One held complex mode of attack (module docstring).

    Attributes
    ----------
    kind : str
        ``"zda"`` or ``"covert"``.
    actuators : tuple of labels
    z : complex
        The mode: ``u_k = Re(a u0 z^(k - k_a))``.
    u0 : ndarray
        (|F|,) complex direction.
    x0 : ndarray
        (2N,) complex state deviation added at ``k_a`` (zeros for a covert attack).
    start : int
        k_a (samples).
    amplitude : float
        The spec's size a (every guarantee scales it).
    spoofed : tuple of str
        Central channels the covert attacker overwrites.
    source : str
        How the mode was chosen.
    """

    kind: str
    actuators: tuple[Label, ...]
    z: complex
    u0: np.ndarray
    x0: np.ndarray
    start: int
    amplitude: float
    spoofed: tuple[str, ...] = ()
    source: str = ""

    @property
    def copy(self) -> bool:
        """The attacker runs a copy of the model (covert)."""
        return self.kind == "covert"

    def describe(self) -> dict[str, Any]:
        """JSON-ready description."""
        return jsonable(
            {
                "kind": self.kind,
                "actuators": list(self.actuators),
                "z": self.z,
                "modulus": abs(self.z),
                "u0": [complex(x) for x in self.u0],
                "start_sample": self.start,
                "amplitude": self.amplitude,
                "spoofed": list(self.spoofed),
                "source": self.source,
            }
        )

    def inputs(self, K: int, amplitude: float | None = None) -> np.ndarray:
        """(K, |F|) real held inputs ``Re(a u0 z^(k - k_a))`` (0 before ``k_a``)."""
        a = self.amplitude if amplitude is None else amplitude
        k = np.arange(K) - self.start
        zk = np.where(k >= 0, self.z ** np.maximum(k, 0), 0.0)
        return np.real(a * zk[:, None] * self.u0[None, :])


def sampled_attack_from_spec(system: System, implementation: ImplementationSpec | None = None, *, amplitude: float | None = None) -> SampledAttack:
    """The spec's ``[attack]`` on the sampled implementation (module docstring).

    Raises
    ------
    NotApplicableError
        Without an attack, or when the sampled loop has no stealthy ZDA on these actuators.
    """
    impl = implementation_of(system, implementation)
    a = system.spec.attack
    if a is None:
        raise NotApplicableError("the spec has no [attack]")
    h = float(impl.period)
    k_a = int(round(a.start / h))
    amp = float(a.amplitude if amplitude is None else amplitude)
    F = tuple(a.actuators)
    if a.kind == "zda":
        d = sampled_zda_direction(system, impl, actuators=F)
        return SampledAttack("zda", F, d.z0, d.u0, d.x0, k_a, amp, (), d.source)
    m = len(F)
    sig = a.signal or "step"
    ones = np.ones(m, dtype=complex) / math.sqrt(m)
    u0: np.ndarray
    if sig == "step":
        z, u0 = 1.0 + 0j, ones
    elif sig == "sine":
        z, u0 = cmath.exp(2j * math.pi * a.frequency * h), -1j * ones
    else:
        lam = complex(a.lambda0 if a.lambda0 is not None else 0.5)
        z, u0 = cmath.exp(lam * h), ones
    mon = set(system.output_channels())
    spoofed = tuple(c for s in a.sensors for c in (f"x:{s}", f"v:{s}") if c in mon)
    return SampledAttack("covert", F, complex(z), u0, np.zeros(2 * system.n, dtype=complex), k_a, amp, spoofed, f"covert {sig}")


def block(rows: Sequence[Sequence[Any]], heights: Sequence[int] | None = None, widths: Sequence[int] | None = None) -> flint.fmpq_mat:
    """Assemble ``fmpq_mat`` blocks; ``None`` is a zero block (its size from ``heights``/``widths``
    or from the other blocks of its row and column)."""
    if heights is None:
        heights = [next(b.nrows() for b in r if b is not None) for r in rows]
    if widths is None:
        widths = [next(rows[i][j].ncols() for i in range(len(rows)) if rows[i][j] is not None) for j in range(len(rows[0]))]
    out = flint.fmpq_mat(sum(heights), sum(widths))
    r0 = 0
    for i, r in enumerate(rows):
        c0 = 0
        for j, b in enumerate(r):
            if b is not None:
                for a in range(b.nrows()):
                    for c in range(b.ncols()):
                        x = b[a, c]
                        if x != 0:
                            out[r0 + a, c0 + c] = x
            c0 += widths[j]
        r0 += heights[i]
    return out


@dataclass(frozen=True, slots=True)
class Composite:
    """A stable composite ``zeta_{k+1} = M zeta + Nu u + Nw w - Nn n``, ``r = R zeta + Dn n`` (exact).

    Attributes
    ----------
    M, Nu, Nw, Nn, R, Dn : fmpq_mat
    X0 : fmpq_mat
        Initial map of the attack-free box (``zeta_0 = X0 x_0``; the box of initial errors for
        the local observers when ``initial_error`` is used is handled by the thresholds).
    Xa : fmpq_mat
        Map of the attack's state deviation (2N) into ``zeta`` at ``k_a``.
    channels : tuple of str
    layout : tuple of (str, int)
        The blocks of ``zeta`` and their sizes.
    """

    M: Any
    Nu: Any
    Nw: Any
    Nn: Any
    R: Any
    Dn: Any
    X0: Any
    Xa: Any
    channels: tuple[str, ...]
    layout: tuple[tuple[str, int], ...]



def _zeros(m: int, n: int) -> flint.fmpq_mat:
    return flint.fmpq_mat(m, n)


def central_composite(
    system: System, central: SampledObserver, attack: SampledAttack | None, mode: str = NORMAL_MODE, implementation: ImplementationSpec | None = None
) -> Composite:
    """The central observer's composite in ``mode`` (the normal mode: before any switch).

    Raises
    ------
    NotApplicableError
        When a graph of the two modes is disconnected (the plant's quotient would keep a
        marginal mode), or the covert copy's consensus is measured (positions monitored).
    """
    impl = implementation_of(system, implementation)
    for m in {NORMAL_MODE, mode}:
        if len(system.components(m)) != 1:
            raise NotApplicableError(f"the guarantee's composite needs a connected graph in mode {m!r}")
    pi, sigma, _ = consensus_quotient(system, NORMAL_MODE)
    # plant quotient: by the consensus whatever is monitored (D_q kills it)
    n = system.n
    rep = 0
    px = flint.fmpq_mat(2 * n - 1, 2 * n)
    sx = flint.fmpq_mat(2 * n, 2 * n - 1)
    keep = [i for i in range(2 * n) if i != rep]
    for r, i in enumerate(keep):
        px[r, i] = 1
        sx[i, r] = 1
        if i < n:
            px[r, rep] = -1
    P1, Gam = sampled_matrices_exact(system, NORMAL_MODE, impl)
    Pq, _ = sampled_matrices_exact(system, mode, impl)
    pe = central.Px  # the observer's quotient pi_e (identity when positions are monitored)
    F = central.F
    H = central.Go
    C = central.C
    copy = attack is not None and attack.copy
    if copy and system.monitored_positions:
        raise NotApplicableError("a covert attacker's copy drifts along the consensus, which monitored positions see: no stable composite")
    act = system.idx(attack.actuators) if attack is not None else []
    GF = exact_columns(Gam, act) if act else _zeros(2 * n, 0)
    # spoof selection S (rows of C the attacker overwrites)
    S = flint.fmpq_mat(C.nrows(), C.nrows())
    if copy:
        for i, ch in enumerate(central.channels):
            if ch in attack.spoofed:  # type: ignore[union-attr]
                S[i, i] = 1
    n_p, n_e, p = 2 * n - 1, F.nrows(), C.nrows()
    Mp = px * Pq * sx
    D = pe * (Pq - P1) * sx
    if copy:
        layout: tuple[tuple[str, int], ...] = (("plant", n_p), ("copy", n_p), ("error", n_e))
        grid: list[list[Any]] = [[Mp, None, None], [None, px * P1 * sx, None], [D, pe * H * S * C * sx, F]]
        R = block([[None, -(S * C * sx), central.Ce]], [p], [n_p, n_p, n_e])
    else:
        layout = (("plant", n_p), ("error", n_e))
        grid = [[Mp, None], [D, F]]
        R = block([[None, central.Ce]], [p], [n_p, n_e])
    sizes: list[int] = [s_ for _, s_ in layout]
    Mfull = block(grid, sizes, sizes)
    n_act = len(act)
    Nu = block([[px * GF]] + ([[px * GF]] if copy else []) + [[pe * GF]], sizes, [n_act]) if n_act else flint.fmpq_mat(sum(sizes), 0)
    Nw = block([[px]] + ([[None]] if copy else []) + [[pe]], sizes, [2 * n])
    Nn = block([[None]] + ([[None]] if copy else []) + [[central.Kn]], sizes, [p])
    X0 = block([[px]] + ([[None]] if copy else []) + [[pe]], sizes, [2 * n])
    Xa = X0
    return Composite(Mfull, Nu, Nw, Nn, R, central.Dn, X0, Xa, central.channels, layout)


def local_composite(system: System, observer: SampledObserver, attack: SampledAttack | None) -> Composite:
    """A local UIO's composite: its error ``e~`` with the attack entering through ``T Gamma^i_F``."""
    act = system.idx(attack.actuators) if attack is not None else []
    Nu = exact_columns(observer.Gu, act) if act else flint.fmpq_mat(observer.F.nrows(), 0)
    return Composite(observer.F, Nu, observer.Gw, observer.Kn, observer.Ce, observer.Dn, observer.Px, observer.Px, observer.channels, (("error", observer.F.nrows()),))
