"""The largest attack that some admissible run hides from every detector up to a time T.

The certified smallest size of :mod:`.guarantees` is sufficient: it guarantees an alarm at one
sample, whatever the run. Escaping detection up to ``T`` needs one run that stays below every
threshold at *every* sample ``k <= k_a + T/h`` of *every* detector (Algorithm 1 never switches
then). All residuals are linear in the run, so the largest size ``a`` with such a run is a
linear program:

.. math::

    \\max a \\quad\\text{s.t.}\\quad
    -\\theta_{k,j} (1 - \\epsilon) \\le \\ell_k P x_0 - \\sum_{i<k} \\ell_{k-1-i} K_n n_i
      + \\sum_{i<k} \\ell_{k-1-i} G_w \\Gamma d_i + D_n n_k + a \\rho_{k,j} \\le \\theta_{k,j} (1 - \\epsilon)

over every detector, channel and sample, with ``x_0`` in the box, each detector's noise in its
bounds and a disturbance constant over each period (``|d_i| <= dbar``: admissible, so the run
found is one the guarantee must cover). The program (HiGHS through ``scipy.optimize.linprog``)
is not certified; the run it returns is **confirmed by simulating it**
(:func:`~glocal_verify.simulation.sampled_runs.simulate_sampled`), and only then reported as an
escape. ``a_escape <= a*`` always: the gap is the conservatism of the sufficient certificate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
import scipy.optimize
import scipy.sparse

from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.certified_rows import exact_to_float
from glocal_verify.simulation.certified_thresholds import CertifiedThresholds
from glocal_verify.simulation.guarantees import DetectionGuarantee

__all__ = ["EscapeRun", "escape_run"]


@dataclass(frozen=True, slots=True)
class EscapeRun:
    """An admissible run that hides the attack from every detector up to ``T`` (unconfirmed until simulated).

    Attributes
    ----------
    size : float
        The largest size the program found (``a_escape``).
    horizon : float
        T (s after the attack's start).
    x0 : ndarray
        (2N,) initial state.
    noise : mapping of str to ndarray
        Per detector, (k_T + 1, p) noise.
    d : ndarray
        (k_T, N) held disturbance per period.
    status : str
        The solver's message.
    """

    size: float
    horizon: float
    x0: np.ndarray
    noise: Mapping[str, np.ndarray]
    d: np.ndarray
    status: str


def escape_run(system: System, thresholds: CertifiedThresholds, guarantee: DetectionGuarantee, horizon: float, *, margin: float = 1e-6) -> EscapeRun:
    """The linear program of the module docstring (attack start ``k_a = 0`` required).

    Parameters
    ----------
    system : System
    thresholds : CertifiedThresholds
    guarantee : DetectionGuarantee
        Its attack responses (size 1) are the ``rho``.
    horizon : float
        T (s).
    margin : float
        Relative room ``epsilon`` kept below each threshold.

    Raises
    ------
    NotApplicableError
        When the attack does not start at 0, or the initial errors (not states) are boxed.
    """
    th = thresholds
    if int(guarantee.attack.get("start_sample", 0)) != 0:
        raise NotApplicableError("the escape program assumes the attack starts at t = 0")
    if th.model.initial != "state":
        raise NotApplicableError("the escape program needs a box of initial states")
    h = th.period
    kT = int(round(horizon / h))
    n = system.n
    names = [nm for nm in th.observers if nm in guarantee.responses]
    dets = {o.name: o for o in th.detectors}
    nv = {nm: (kT + 1) * len(dets[nm].channels) for nm in names}
    # variable layout: [a, x0 (2N), d (kT N), noise of each detector]
    off = {"a": 0, "x0": 1, "d": 1 + 2 * n}
    pos = 1 + 2 * n + kT * n
    for nm in names:
        off[nm] = pos
        pos += nv[nm]
    rows, lo, hi = [], [], []
    Gd = np.vstack([h * h / 2 * np.eye(n), h * np.eye(n)])
    for nm in names:
        o = dets[nm]
        rs = th.observers[nm].rows
        assert rs is not None
        ell = rs.mid[: kT + 1]  # (kT+1, q, no)
        q = ell.shape[1]
        P = exact_to_float(o.Px)[0]
        Kn = exact_to_float(o.Kn)[0]
        Dn = exact_to_float(o.Dn)[0]
        Gw = exact_to_float(o.Gw)[0] @ Gd
        LP = ell @ P  # (kT+1, q, 2N)
        LK = ell @ Kn  # (kT+1, q, p)
        LW = ell @ Gw  # (kT+1, q, N)
        p = Kn.shape[1]
        rho = guarantee.responses[nm].rho[: kT + 1]
        theta = th.observers[nm].theta[: kT + 1] * (1 - margin)
        R = (kT + 1) * q
        Ad = np.zeros((R, kT * n))
        An = np.zeros((R, (kT + 1) * p))
        for k in range(kT + 1):
            r0 = k * q
            for i in range(k):
                An[r0 : r0 + q, i * p : (i + 1) * p] = -LK[k - 1 - i]
                Ad[r0 : r0 + q, i * n : (i + 1) * n] = LW[k - 1 - i]
            An[r0 : r0 + q, k * p : (k + 1) * p] = Dn
        blocks = [scipy.sparse.csr_matrix(rho.reshape(R, 1)), scipy.sparse.csr_matrix(LP.reshape(R, 2 * n)), scipy.sparse.csr_matrix(Ad)]
        for other in names:
            blocks.append(scipy.sparse.csr_matrix(An) if other == nm else scipy.sparse.csr_matrix((R, nv[other])))
        rows.append(scipy.sparse.hstack(blocks).tocsr())
        lo.append(-theta.reshape(R))
        hi.append(theta.reshape(R))
    A = scipy.sparse.vstack(rows).tocsr()
    lo_, hi_ = np.concatenate(lo), np.concatenate(hi)
    A_ub = scipy.sparse.vstack([A, -A]).tocsr()
    b_ub = np.concatenate([hi_, -lo_])
    bounds = [(0, None)] + [(-th.model.box, th.model.box)] * (2 * n) + [(-th.model.disturbance, th.model.disturbance)] * (kT * n)
    for nm in names:
        nb = th.model.noise(dets[nm].channels)
        bounds += [(-float(b), float(b)) for _ in range(kT + 1) for b in nb]
    c = np.zeros(pos)
    c[0] = -1.0
    res = scipy.optimize.linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")
    if res.x is None:
        raise NotApplicableError(f"the escape program has no solution ({res.message})")
    x = res.x
    noise = {nm: x[off[nm] : off[nm] + nv[nm]].reshape(kT + 1, -1) for nm in names}
    return EscapeRun(float(x[0]), float(horizon), x[1 : 1 + 2 * n].copy(), noise, x[off["d"] : off["d"] + kT * n].reshape(kT, n), str(res.message))
