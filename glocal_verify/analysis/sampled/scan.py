"""Pathological sampling periods: where sampling aliases modes, loses observability or stability.

**Continuous loop, sampled detectors** (``controller = "continuous"``). An underdamped mode
of ``L_q`` (``4 alpha mu > gamma^2``) has the eigenvalues :math:`-\\gamma/2 \\pm i\\omega`,
:math:`\\omega = \\sqrt{\\alpha\\mu - \\gamma^2/4}`; every underdamped mode has the same real part, so
sampling at h maps two of them to one point exactly when their frequencies differ by a
multiple of :math:`2\\pi/h`:

* ``scalar-block``: :math:`2\\omega h = 2\\pi k`, i.e. :math:`h = k\\pi/\\omega`. Then
  :math:`e^{\\lambda_+ h} = e^{\\lambda_- h}` and the block :math:`\\Phi(\\mu) = (-1)^k e^{-\\gamma h/2} I`:
  the velocity samples of the mode's oscillation fall on its zero crossings. Every
  ``[w; 0]`` and ``[0; w]`` (w in the eigenspace) is an eigenvector of :math:`\\Phi_q`, and
  the unobservable subspace grows by
  :math:`2\\operatorname{rank}(S_M W) - \\operatorname{rank}(S_{M_x} W) - \\operatorname{rank}(S_{M_v} W)`
  (``rank(S_{Mv} W)`` under privacy, ``M_x`` empty);
* ``aliasing``: :math:`(\\omega_a \\mp \\omega_b) h = 2\\pi k` for two modes a != b. The two
  eigenspaces merge, and the unobservable subspace grows by
  :math:`\\operatorname{rank}(C E_a) + \\operatorname{rank}(C E_b) - \\operatorname{rank}(C [E_a, E_b])`
  (for the pair and for its conjugate), which is proven positive when the two ranks' certified
  lower bounds exceed the number of outputs.

Each period is reported with its certificate (the identity, an enclosure of h from the
certified enclosures of ``mu``), the conditions that fail there (``sampled.no-aliasing``
always; ``sampled.observability`` when the loss is proven; the switching conditions of the
sampled loop for safe modes) and the proven loss. These periods are irrational for rational
weights (:mod:`.loop`: Lindemann-Weierstrass), so a spec's rational period comes only
near one: its verdicts then hold with a margin that tends to 0 there.

**Sampled controller** (``controller = "sampled"``): no two blocks alias except at
``gamma h = 2`` (every block has the eigenvalue -1 there); the loop is stable iff ``gamma h < 2``
and ``h < 2 gamma / (alpha mu_max)`` (Jury); and the zero at -1 of
:mod:`.zda` gives every attacker owning an actuator whose velocity is not monitored a
stealthy, persistent ZDA for every period (reported as ``persistent``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.analysis.sampled.loop import arb_precision
from glocal_verify.analysis.sampled.zda import nyquist_zero
from glocal_verify.model import System
from glocal_verify.numerics.rounding import EPS
from glocal_verify.results import jsonable

__all__ = ["PathologicalPeriod", "PeriodScan", "scan_periods"]

#: most periods listed (the scan counts them all)
MAX_LISTED = 500


@dataclass(frozen=True, slots=True)
class PathologicalPeriod:
    """One pathological sampling period.

    Attributes
    ----------
    period : float
        Midpoint of the certified enclosure.
    enclosure : (float, float)
        The exact pathological period lies in this interval.
    kind : str
        ``"scalar-block"``, ``"aliasing"``, ``"gamma-h-2"`` or ``"stability-limit"``.
    mode : str
    mu : tuple of float
        The Laplacian eigenvalue(s) involved.
    winding : int or None
        k of the identity.
    fails : tuple of str
        Condition ids that fail at this period (proven).
    observability_loss : int
        Proven lower bound on the growth of the unobservable subspace (0: none proven).
    certificate : str
        The identity that makes the period pathological.
    """

    period: float
    enclosure: tuple[float, float]
    kind: str
    mode: str
    mu: tuple[float, ...]
    winding: int | None
    fails: tuple[str, ...]
    observability_loss: int
    certificate: str

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "period": self.period,
                "enclosure": list(self.enclosure),
                "kind": self.kind,
                "mode": self.mode,
                "mu": list(self.mu),
                "winding": self.winding,
                "fails": list(self.fails),
                "observability_loss": self.observability_loss,
                "certificate": self.certificate,
            }
        )


@dataclass(frozen=True, slots=True)
class PeriodScan:
    """The pathological periods in ``[h_min, h_max]``.

    Attributes
    ----------
    controller : str
    h_min, h_max : float
    periods : tuple of PathologicalPeriod
        Sorted by period (at most :data:`MAX_LISTED`).
    count : int
        How many there are in total.
    persistent : tuple of str
        Facts that hold for every period of the range (the zero at -1, instability beyond a limit).
    """

    controller: str
    h_min: float
    h_max: float
    periods: tuple[PathologicalPeriod, ...]
    count: int
    persistent: tuple[str, ...]

    def near(self, h: float) -> PathologicalPeriod | None:
        """The listed period nearest ``h``."""
        return min(self.periods, key=lambda p: abs(p.period - h)) if self.periods else None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "controller": self.controller,
                "range": [self.h_min, self.h_max],
                "count": self.count,
                "periods": [p.to_json() for p in self.periods],
                "persistent": list(self.persistent),
            }
        )


def _rank_bounds(M: np.ndarray, err: float) -> tuple[int, int]:
    """Certified (lower, upper) bounds on rank(M) for a matrix known within ``err`` (2-norm):
    singular values above ``err`` count for the lower bound; the upper bound is the size."""
    if M.size == 0:
        return 0, 0
    s = np.linalg.svd(M, compute_uv=False)
    lo = int(np.sum(s > err * (1 + 1e-12) + 4 * EPS * max(1.0, s.max(initial=0.0))))
    return lo, int(min(M.shape))


def _omega_ball(mu: float, rho: float, a: Fraction, g: Fraction) -> Any:
    x = flint.arb(mu, rho) * flint.arb(flint.fmpq(a.numerator, a.denominator)) - flint.arb(flint.fmpq(g.numerator, g.denominator)) ** 2 / 4
    return x.sqrt() if x > 0 else None


def scan_periods(system: System, h_min: float, h_max: float, *, controller: str | None = None, modes: Sequence[str] | None = None) -> PeriodScan:
    """Every pathological period in ``[h_min, h_max]`` (module docstring).

    Parameters
    ----------
    system : System
    h_min, h_max : float
        The range scanned (0 < h_min < h_max).
    controller : str, optional
        Default the spec's ``implementation.controller`` (``"sampled"`` without one).
    modes : sequence of str, optional
        Default every mode.
    """
    if not 0 < h_min < h_max:
        raise ValueError(f"need 0 < h_min < h_max, got {h_min}, {h_max}")
    impl = system.spec.implementation
    ctrl = controller or (impl.controller if impl is not None else "sampled")
    modes = tuple(system.modes if modes is None else modes)
    a, g = system.alpha_q, system.gamma_q
    out: list[PathologicalPeriod] = []
    persistent: list[str] = []
    count = 0
    mx = system.idx(system.monitored_positions)
    mv = system.idx(system.monitored_velocities)
    p_out = len(mx) + len(mv)
    if ctrl == "sampled":
        h2 = float(Fraction(2) / g)
        for q in modes:
            sp = system.spectrum(q)
            mu_max = float(sp.values[-1]) + float(sp.error_radius)
            lim = float(2 * g / a) / mu_max if mu_max > 0 else math.inf
            if h_min <= h2 <= h_max:
                count += 1
                from glocal_verify.analysis.unobservable.subspace import certified_unobservable

                loss = max(0, system.n - len(mv) - certified_unobservable(system, q).dim_upper)
                out.append(PathologicalPeriod(h2, (h2, h2), "gamma-h-2", q, (), None, ("sampled.no-aliasing", "sampled.stability") + (("sampled.observability",) if loss else ()), loss,
                                              "gamma h = 2: every block has the eigenvalue -1 (z + 1 divides every (z-1)(z-1+gamma h) + alpha mu h^2 (z+1)/2)"))
            if lim < h2 and h_min <= lim <= h_max:
                count += 1
                lo = float(2 * g / a) / (float(sp.values[-1]) + float(sp.error_radius))
                hi = float(2 * g / a) / max(float(sp.values[-1]) - float(sp.error_radius), 1e-300)
                out.append(PathologicalPeriod(lim, (lo, hi), "stability-limit", q, (float(sp.values[-1]),), None, ("sampled.stability",), 0,
                                              "h = 2 gamma / (alpha mu_max): a block's eigenvalue reaches -1 (Jury); unstable for every longer period"))
                persistent.append(f"mode {q}: the sampled loop is unstable for h >= {lim:.6g} (h < 2 gamma / (alpha mu_max) is necessary)")
        if system.spec.attack is not None:
            nyq = nyquist_zero(system, system.spec.attack.actuators)
            if nyq:
                persistent.append(f"every period: a stealthy ZDA at z = -1 on the actuators {list(nyq)} (velocities not monitored globally)")
    else:
        for q in modes:
            sp = system.spectrum(q)
            U = sp.vectors
            rho = float(sp.error_radius)
            reps = [c for c in sp.clusters if float(sp.values[c[0]]) * float(a) > float(g) ** 2 / 4 + 4 * rho * float(a)]
            with arb_precision():
                om = [(c, _omega_ball(float(np.mean(sp.values[list(c)])), rho + float(np.ptp(sp.values[list(c)])), a, g)) for c in reps]
                om = [(c, w) for c, w in om if w is not None]
                pi = flint.arb.pi()
                rank = {}
                for c, _ in om:
                    W = U[:, list(c)]
                    s = sp.subspace_sine(c)
                    rank[c] = (_rank_bounds(W[mx], s), _rank_bounds(W[mv], s), _rank_bounds(np.vstack([W[mx], W[mv]]), s))
                for c, w in om:
                    wl = float(w.mid())
                    for k in range(max(1, math.ceil(h_min * wl / math.pi)), math.floor(h_max * wl / math.pi) + 1):
                        hb = k * pi / w
                        if not (hb.upper() >= h_min and hb.lower() <= h_max):
                            continue
                        count += 1
                        if len(out) >= MAX_LISTED:
                            continue
                        (rx, _), (rv, _), (rm_lo, _) = rank[c]
                        rx_hi = 0 if not mx else min(len(mx), len(c))
                        rv_hi = 0 if not mv else min(len(mv), len(c))
                        loss = max(0, 2 * rm_lo - rx_hi - rv_hi)
                        fails = ("sampled.no-aliasing",) + (("sampled.observability",) if loss else ())
                        out.append(PathologicalPeriod(float(hb.mid()), (float(hb.lower()), float(hb.upper())), "scalar-block", q, (float(sp.values[c[0]]),), k, fails, loss,
                                                      f"2 omega h = 2 pi k with omega = sqrt(alpha mu - gamma^2/4), k = {k}: Phi(mu) = (-1)^k e^(-gamma h/2) I"))
                for i, (ca, wa) in enumerate(om):
                    for cb, wb in om[i + 1 :]:
                        for sign, dw in ((-1, wa - wb), (1, wa + wb)):
                            dwf = abs(float(dw.mid()))
                            if dwf <= 0 or dw.contains(0):
                                continue
                            for k in range(max(1, math.ceil(h_min * dwf / (2 * math.pi))), math.floor(h_max * dwf / (2 * math.pi)) + 1):
                                hb = 2 * k * pi / abs(dw)
                                if not (hb.upper() >= h_min and hb.lower() <= h_max):
                                    continue
                                count += 1
                                if len(out) >= MAX_LISTED:
                                    continue
                                (_, _), (_, _), (ra, _) = rank[ca]
                                (_, _), (_, _), (rb, _) = rank[cb]
                                loss = 2 * max(0, ra + rb - min(p_out, len(ca) + len(cb)))
                                fails = ("sampled.no-aliasing",) + (("sampled.observability",) if loss else ())
                                op = "-" if sign < 0 else "+"
                                out.append(PathologicalPeriod(float(hb.mid()), (float(hb.lower()), float(hb.upper())), "aliasing", q, (float(sp.values[ca[0]]), float(sp.values[cb[0]])), k, fails, loss,
                                                              f"(omega_a {op} omega_b) h = 2 pi k, k = {k}: e^(lambda_a h) = e^(lambda_b h) merges two eigenspaces"))
    out.sort(key=lambda p: (p.period, p.mode))
    return PeriodScan(ctrl, float(h_min), float(h_max), tuple(out), count, tuple(persistent))
