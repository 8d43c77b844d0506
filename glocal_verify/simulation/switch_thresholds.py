"""Certified thresholds of the central observer after a switch at a known sample.

Algorithm 1 switches only after a local alarm, and a certified local threshold is never crossed
without an attack, so an attack-free run never switches: the central observer's pre-switch
threshold (:mod:`.certified_thresholds`) is all a false-alarm guarantee needs. After a switch
at sample ``s`` the control centre asks another question: is its residual still explained by
*some* attack-free run with that switch? The discrepancy :math:`(\\Phi_q - \\Phi_1) x` of
eq. ``obs_cent_error`` enters the error, so the threshold depends on ``s``. With the composite
:math:`\\zeta = (\\pi x, \\epsilon)` of :func:`~glocal_verify.simulation.sampled_attack.central_composite`
(stable in both modes), the rows :math:`\\ell'_m = R M_q^m` after the switch and the states
before it,

.. math::

    r_k = \\ell'_{k-s} M_1^s X_0 x_0
          + \\ell'_{k-s} \\sum_{i<s} M_1^{s-1-i} (N_w w_i - N_n n_i)
          + \\sum_{i=s}^{k-1} \\ell'_{k-1-i} (N_w w_i - N_n n_i) + n_k ,

and its certified bound is: the initial term exactly (per ``s``: ``b sum_c |(l' M_1^s X_0)_c|``),
the pre-switch noise and disturbance through a componentwise bound of the state they can
reach at ``s`` (``|l'| beta_s``: sound, conservative because it forgets the correlations of the
components), and the post-switch terms exactly (as in :mod:`.certified_thresholds`). Every
row, column and orbit carries the a-posteriori error of
:mod:`glocal_verify.numerics.certified_rows`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from glocal_verify.numerics.certified_rows import RowSequence, abs_row_sums, certified_rows, exact_to_float, upper, weighted
from glocal_verify.numerics.rounding import gamma_bound
from glocal_verify.simulation.certified_thresholds import ROUNDING, UncertaintyModel, disturbance_support
from glocal_verify.simulation.sampled_attack import Composite

__all__ = ["SwitchThresholds", "post_switch_thresholds"]


@dataclass(frozen=True, slots=True)
class SwitchThresholds:
    """The central observer's thresholds and attack-free bounds after a switch at each sample.

    Attributes
    ----------
    switch_samples : tuple of int
    theta : mapping of int to ndarray
        Per switch sample s: (K - s, q) thresholds at the samples ``k = s .. K - 1``.
    bound : mapping of int to ndarray
        Per s: the certified upper bound of the attack-free residual (``theta`` is
        ``(1 + rho) bound + rho scale``).
    rows : RowSequence
        The post-switch rows ``R M_q^m``.
    """

    switch_samples: tuple[int, ...]
    theta: Mapping[int, np.ndarray]
    bound: Mapping[int, np.ndarray]
    rows: RowSequence

    def at(self, s: int, k: np.ndarray) -> np.ndarray:
        """Thresholds of the switch at ``s`` at samples ``k >= s`` (k < K)."""
        return self.theta[s][np.asarray(k) - s]


def _support_rows(G: np.ndarray, n: int, h: float) -> np.ndarray:
    """Per row of G (..., 2N): ``sum_a int_0^h |G_a t + G_{N+a}| dt``."""
    return disturbance_support(G[..., :n], G[..., n:], h).sum(axis=-1)  # type: ignore[no-any-return]


def post_switch_thresholds(
    pre: Composite, post: Composite, model: UncertaintyModel, period: float, K: int, switch_samples: Sequence[int]
) -> SwitchThresholds:
    """Certified thresholds of the central observer after a switch at each of ``switch_samples`` (module docstring).

    Parameters
    ----------
    pre, post : Composite
        The central composite in the normal mode and in the safe mode (same layout, no attack
        needed: only ``M``, ``Nw``, ``Nn``, ``R``, ``Dn`` and ``X0`` are used).
    model : UncertaintyModel
    period : float
    K : int
        Samples of the horizon.
    switch_samples : sequence of int
        Each ``0 < s < K``.
    """
    S = sorted({int(s) for s in switch_samples if 0 < s < K})
    h = period
    rows = certified_rows(post.M, post.R, K)
    s_max = max(S) if S else 0
    # columns M_1^s X0 (as rows of the transpose), M_1^i Nn and M_1^i Nw
    M1t = _transpose(pre.M)
    colsX = certified_rows(M1t, _transpose(pre.X0), s_max + 1)
    colsN = certified_rows(M1t, _transpose(pre.Nn), s_max + 1)
    colsW = certified_rows(M1t, _transpose(pre.Nw), s_max + 1)
    channels = post.channels
    q = len(channels)
    nbar = model.noise(channels)
    Dn, _ = exact_to_float(post.Dn)
    direct = upper(np.abs(Dn) @ nbar, q + 2) if q else np.zeros(0)
    Nn, _ = exact_to_float(post.Nn)
    Nw, Nwe = exact_to_float(post.Nw)
    n2 = Nw.shape[1] // 2
    # post-switch noise and disturbance, cumulative over m = k - s (independent of s)
    nz = abs_row_sums(rows, Nn * nbar[None, :], K)
    post_noise = np.zeros((K, q))
    post_noise[1:] = upper(np.cumsum(nz[: K - 1], axis=0), K + 2)
    post_dist = np.zeros((K, q))
    if model.disturbance > 0:
        G = rows.mid[:K] @ Nw
        lip = max(h * h / 2, h)
        colmax = float((np.abs(Nw) + Nwe).max(axis=0).sum())
        dev = gamma_bound(Nw.shape[0] + 1) * (np.abs(rows.mid[:K]) @ np.abs(Nw)).sum(axis=2) + rows.err[:K] * colmax
        per = upper(model.disturbance * (_support_rows(G, n2, h) * (1 + 16 * gamma_bound(8)) + lip * dev), 2 * n2 + 8)
        post_dist[1:] = upper(np.cumsum(per[: K - 1], axis=0), K + 2)
    # componentwise bounds of the state the pre-switch noise and disturbance can reach at s
    beta = np.zeros((s_max + 1, pre.M.nrows()))
    if S:
        nmid = np.abs(colsN.mid[: s_max + 1])  # (s, p, dim): |(M_1^i Nn)^T|
        ncol = upper(np.einsum("ipd,p->id", nmid, nbar) + weighted(colsN.err[: s_max + 1], nbar)[:, None], 8)
        beta[1:] = upper(np.cumsum(ncol[:s_max], axis=0), s_max + 2)
        if model.disturbance > 0:
            W = np.transpose(colsW.mid[: s_max + 1], (0, 2, 1))  # (s, dim, 2N)
            wcol = _support_rows(W, n2, h) * (1 + 16 * gamma_bound(8)) + max(h * h / 2, h) * colsW.err[: s_max + 1].sum(axis=1)[:, None]
            beta[1:] += upper(np.cumsum(model.disturbance * wcol[:s_max], axis=0), s_max + 2)
    scale = model.scale(h)
    theta: dict[int, np.ndarray] = {}
    bound: dict[int, np.ndarray] = {}
    lmid, lerr = rows.mid, rows.err
    for s in S:
        L = K - s
        P = colsX.mid[s].T  # (dim, 2N): M_1^s X0
        Perr = colsX.err[s]  # per column c: ||delta P[:, c]||_1
        Y = lmid[:L] @ P  # (L, q, 2N)
        init = np.abs(Y).sum(axis=2)
        Pinf = float(upper(np.abs(P).sum(axis=1).max(initial=0.0), P.shape[1] + 2))
        init_err = gamma_bound(P.shape[0] + 1) * (np.abs(lmid[:L]) @ np.abs(P)).sum(axis=2) + lerr[:L] * Pinf + np.abs(lmid[:L]).max(axis=2) * float(Perr.sum())
        init = upper(model.box * (init + init_err), P.shape[0] + P.shape[1] + 8)
        pre_terms = np.abs(lmid[:L]) @ beta[s] + lerr[:L] * float(beta[s].max(initial=0.0))
        pre_terms = upper(pre_terms, P.shape[0] + 4)
        b = upper(init + pre_terms + post_noise[:L] + post_dist[:L] + direct[None, :], 8)
        bound[s] = b
        theta[s] = (1 + ROUNDING) * b + ROUNDING * scale
    return SwitchThresholds(tuple(S), theta, bound, rows)


def _transpose(M: object) -> object:
    return M.transpose()  # type: ignore[attr-defined]
