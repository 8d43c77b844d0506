"""The one-link theorem's fast filter: which link changes can meet Theorem III.3 on a simple spectrum of L_1.

The proof is in :mod:`glocal_verify.design.safe_modes` ("Theorem III.3 for one link"): with
L_1 = U diag(mu) U^T certified simple and z = U^T (e_i - e_j), a one-link mode meets (i)-(iii)
iff an endpoint is monitored, z_k != 0 for k >= 2 and, for a removal, w R_eff < 1. This module
computes the certified error of z (:func:`eigenvector_error`) and screens candidates with it
(:func:`one_link_screen`); the screen states no verdict: the rule functions admit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from glocal_verify.model import System
from glocal_verify.numerics.rounding import EPS

__all__ = ["eigenvector_error", "one_link_screen"]


def eigenvector_error(system: System) -> np.ndarray | None:
    """Certified bounds e_k >= |(u_k(i) - u_k(j)) - (u_k^*(i) - u_k^*(j))| for every pair (module docstring).

    Parameters
    ----------
    system : System

    Returns
    -------
    ndarray or None
        None when the eigenvalues of L_1 are not certified distinct (the one-link theorem then
        does not apply).
    """
    sp = system.spectrum()
    if any(len(c) > 1 for c in sp.clusters):
        return None
    n = sp.size
    w = np.asarray(sp.values)
    rho = sp.error_radius
    gaps = np.diff(w)
    left = np.concatenate([[math.inf], gaps])
    right = np.concatenate([gaps, [math.inf]])
    delta = np.minimum(left, right) - rho
    k = sp.row_nonzeros
    fro = sp.frobenius
    r = np.asarray(sp.residuals) + (k + 2) * EPS * math.sqrt(n) * (fro + np.abs(w)) + sp.input_error
    r = r * (1.0 + 4.0 * n * EPS)
    s = np.where(delta > 0, np.minimum(1.0, r / np.where(delta > 0, delta, 1.0)), 1.0)
    return 2.0 * s + math.sqrt(2.0) * sp.orthogonality_error + 4.0 * EPS


def one_link_screen(system: System, cands: Sequence[Any], err: np.ndarray | None, chunk: int = 2048) -> np.ndarray:
    """Boolean mask: the one-link theorem's fast filter (module docstring), in chunks of ``chunk`` rows.

    A filter, not a verdict: a candidate it lets through is admitted only when the rule
    functions of Theorem III.3 hold for it (``_OneLinkRules`` of :mod:`glocal_verify.design.safe_modes`). It lets through what its
    certified bounds cannot reject: |z_k| above its error bound for k >= 2, an endpoint
    monitored, and for a removal w R_eff < 1 up to a relative slack.
    """
    if err is None or len(cands) == 0:
        return np.zeros(len(cands), dtype=bool)
    U = np.asarray(system.spectrum().vectors)
    w = np.asarray(system.spectrum().values)
    M = set(system.monitored)
    I = np.array([system.index[c.u] for c in cands], dtype=int)
    J = np.array([system.index[c.v] for c in cands], dtype=int)
    ok = np.array([(c.u in M) or (c.v in M) for c in cands], dtype=bool)
    rem = np.array([c.remove for c in cands], dtype=bool)
    wts = np.array([float(c.weight) for c in cands])
    U1, e1, w1 = U[:, 1:], err[None, 1:], w[None, 1:]
    for a in range(0, len(cands), chunk):
        sl = slice(a, a + chunk)
        Z = U1[I[sl]] - U1[J[sl]]
        good = np.all(np.abs(Z) > e1, axis=1)
        r = rem[sl]
        if r.any():
            reff = np.sum(Z[r] ** 2 / w1, axis=1)
            g = good[r]
            g &= 1.0 - wts[sl][r] * reff > -1e-6  # a filter: the rule decides the bridge case
            good[r] = g
        ok[sl] &= good
    return ok
