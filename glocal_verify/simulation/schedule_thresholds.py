"""Certified thresholds of every sampled detector over the whole switching schedule, and the
control centre's threshold after Algorithm 1's switch at any sample.

:mod:`.certified_thresholds` bounds every residual before any switch. A deployment runs the
defender's schedule (``[switching]``: modes at given times) and Algorithm 1 (a local alarm
switches to the safe mode). Both change the detectors' error equations:

* **A local UIO** in mode q runs its design for the mode's sampled cluster model
  (:func:`~glocal_verify.observers.sampled.design_sampled_uio` with ``mode=q``): ``F_q``, ``K_q``
  and the decoupling matrix ``H_q`` (a new boundary agent adds a column to ``E_d``). At a switch
  from p to q its state is reset, ``z <- z + (H_p - H_q) y_s``, which keeps the estimate
  ``x^ = z + H y`` and the residual continuous; its error ``e~ = T_q x - z`` jumps by
  ``-(H_p - H_q) n_s`` and then obeys ``e~_{k+1} = F_q e~_k + T_q w_k - K_q n_k`` (decoupled from
  the plant in every mode that has a design).
* **The central observer** keeps the normal-mode model; after a switch the discrepancy
  ``(Phi_q - Phi_1) x`` enters its error, so its error is a composite with the plant's quotient
  (:func:`~glocal_verify.simulation.sampled_attack.central_composite`).

Every detector is thus, segment by segment, a composite
:math:`\\zeta_{k+1} = M_q \\zeta_k + N_w w_k - N_n n_k`, :math:`r_k = R \\zeta_k + D_n n_k`,
with a jump :math:`\\zeta \\leftarrow \\zeta + J_n n_s` at the start of a segment (the reset). On a
segment starting at ``s`` (``m = k - s``, rows :math:`\\ell_m = R M_q^m`):

.. math::

    r_k = \\ell_m \\zeta^-_s + \\ell_{m-1} (M_q J_n - N_n) n_s + \\sum_{s < i < k} \\ell_{k-1-i} (N_w w_i - N_n n_i)
          + \\ell_{m-1} N_w w_s + D_n n_k \\quad (m \\ge 1),\\qquad r_s = \\ell_0 \\zeta^-_s + (R J_n + D_n) n_s .

The state before the segment depends only on the inputs before ``s``; with a componentwise
bound :math:`|\\zeta^-_s| \\le \\beta_s` the supremum of :math:`|r_{k,j}|` is at most
:math:`|\\ell_m| \\beta_s` plus the **exact** worst case of the segment's own noise and
disturbance (independent of what came before; the same sums as :mod:`.certified_thresholds`).
The first segment is :mod:`.certified_thresholds` itself (same numbers). The bound
:math:`\\beta` is carried from segment to segment: the initial state's part exactly at the first
switch (:math:`b \\sum_c |(M_1^{s} X_0)_{\\cdot c}|`), the noise and disturbance a segment adds
exactly per component (:math:`\\sum_i |M^i N| \\bar n` and the support function), and what
entered before a segment through :math:`\\|M^L\\|_\\infty \\le \\kappa \\theta^{\\lfloor L / m_0
\\rfloor}` (the power certificate: sound, and negligible once the segment is longer than the
detector's settling). Forgetting the correlation between the components of
:math:`\\zeta^-_s` makes the later segments' thresholds conservative (never below the exact
worst case), like the post-switch thresholds of :mod:`.switch_thresholds`.

**After the last switch** the schedule's last mode persists: its tail (the certified decay of
the rows, the certified totals of the sums) bounds every later sample, so the thresholds cover
the schedule however long it runs.

**Algorithm 1's switch** comes at a sample nobody knows in advance. The control centre's
threshold after it (:class:`AfterSwitchThreshold`) is indexed by the samples since the switch and
holds for a switch at *any* sample: the state before the switch is bounded componentwise by
:math:`\\beta^U`, the supremum over every sample of the schedule of the bound above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import flint
import numpy as np

from glocal_verify.analysis.sampled.loop import implementation_of
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.certified_rows import (
    PowerCertificate,
    abs_row_sums,
    certified_row_chunks,
    certified_rows,
    exact_to_float,
    power_certificate,
    upper,
)
from glocal_verify.numerics.rounding import gamma_bound
from glocal_verify.observers.sampled import SampledObserver, design_sampled_uio
from glocal_verify.results import jsonable
from glocal_verify.simulation.certified_thresholds import ROUNDING, CertifiedThresholds, UncertaintyModel, disturbance_rows, disturbance_support
from glocal_verify.simulation.sampled_attack import central_composite
from glocal_verify.spec.types import NORMAL_MODE, ImplementationSpec

__all__ = [
    "SegmentComposite",
    "DetectorSchedule",
    "AfterSwitchThreshold",
    "ScheduleThresholds",
    "schedule_samples",
    "detector_segments",
    "schedule_thresholds",
]


@dataclass(frozen=True, slots=True)
class SegmentComposite:
    """One detector in one segment: ``zeta+ = M zeta + Nw w - Nn n``, ``r = R zeta + Dn n``, and
    the jump ``zeta <- zeta + Jn n`` when the segment starts (exact matrices).

    Attributes
    ----------
    mode : str
    detector : SampledObserver
        What runs in the segment (its implementation and error equation).
    M, Nw, Nn, R, Dn : fmpq_mat
    Jn : fmpq_mat or None
        None: no jump.
    """

    mode: str
    detector: SampledObserver
    M: Any
    Nw: Any
    Nn: Any
    R: Any
    Dn: Any
    Jn: Any | None


@dataclass(frozen=True, slots=True)
class DetectorSchedule:
    """One detector's certified thresholds over the schedule.

    Attributes
    ----------
    name, kind : str
    channels : tuple of str
    theta : ndarray
        (K, q) thresholds at the samples ``k < K``; ``inf`` where nothing is promised (a mode
        without a decoupled design, and every later sample).
    tail : ndarray
        (q,) threshold for every sample ``k >= K`` (the last mode persists); ``inf`` when not
        covered.
    bound : ndarray
        (K, q) the certified upper bound of the attack-free residual (``theta`` is
        ``(1 + rho) bound + rho s``).
    segments : tuple of (int, str, bool)
        Each segment's first sample, mode and whether it is covered.
    detectors : tuple of (str, SampledObserver)
        Per mode of the schedule, the detector that runs in it.
    notes : tuple of str
    """

    name: str
    kind: str
    channels: tuple[str, ...]
    theta: np.ndarray
    tail: np.ndarray
    bound: np.ndarray
    segments: tuple[tuple[int, str, bool], ...]
    detectors: tuple[tuple[str, SampledObserver], ...]
    notes: tuple[str, ...]

    @property
    def covered(self) -> bool:
        """Every segment has a certified threshold."""
        return all(c for _, _, c in self.segments)

    def at(self, k: np.ndarray | int) -> np.ndarray:
        """Thresholds at sample indices ``k`` (the tail beyond ``K``)."""
        k = np.asarray(k)
        K = len(self.theta)
        return np.where((k < K)[..., None], self.theta[np.minimum(k, K - 1)], self.tail)  # type: ignore[no-any-return]

    def detector(self, mode: str) -> SampledObserver:
        """The detector that runs in ``mode``."""
        return next(d for m, d in self.detectors if m == mode)


@dataclass(frozen=True, slots=True)
class AfterSwitchThreshold:
    """The control centre's threshold after Algorithm 1's switch to ``mode``, for a switch at any sample.

    The switch samples are cut into blocks (doubling lengths 1, 1, 2, 4, ... in the first
    segment of the schedule, one block per later segment, the last one open): a block's
    thresholds hold for a switch at any sample of it, from the componentwise bound of the
    composite state over the block.

    Attributes
    ----------
    mode : str
    starts : tuple of int
        The first switch sample of each block (the first is 0).
    theta : tuple of ndarray
        Per block, (L, q) thresholds ``m = k - s`` samples after the switch sample ``s`` (m < L).
    tail : tuple of ndarray
        Per block, (q,) for every ``m >= L``.
    bound : tuple of ndarray
        Per block, (L, q) certified upper bounds of the attack-free residual.
    state_bound : tuple of ndarray
        Per block, the componentwise bound of the composite state at a switch in it.
    """

    mode: str
    starts: tuple[int, ...]
    theta: tuple[np.ndarray, ...]
    tail: tuple[np.ndarray, ...]
    bound: tuple[np.ndarray, ...]
    state_bound: tuple[np.ndarray, ...]

    def block(self, s: int) -> int:
        """The block of a switch at sample ``s``."""
        return max(i for i, a in enumerate(self.starts) if a <= s)

    def at(self, s: int, m: np.ndarray | int) -> np.ndarray:
        """Thresholds ``m`` samples after a switch at sample ``s``."""
        b = self.block(s)
        th, tl = self.theta[b], self.tail[b]
        m = np.asarray(m)
        L = len(th)
        return np.where((m < L)[..., None], th[np.minimum(m, L - 1)], tl)  # type: ignore[no-any-return]

    def bound_at(self, s: int, m: np.ndarray | int) -> np.ndarray:
        """The certified attack-free bounds ``m`` samples after a switch at ``s`` (``m < L``)."""
        return self.bound[self.block(s)][np.asarray(m)]  # type: ignore[no-any-return]


@dataclass(frozen=True, slots=True)
class ScheduleThresholds:
    """Certified thresholds of every sampled detector over the schedule.

    Attributes
    ----------
    period : float
    samples : int
        K: explicit thresholds for ``k < K`` (at least the spec's horizon and the last switch).
    segments : tuple of (int, str)
        First sample and mode of each segment of the schedule.
    detectors : mapping of str to DetectorSchedule
    after_switch : AfterSwitchThreshold or None
        The control centre's threshold after Algorithm 1's switch (None: no safe mode, no
        central observer, or not certified; :attr:`notes` says why).
    certified : CertifiedThresholds
        The thresholds before any switch (:mod:`.certified_thresholds`): the first segment.
    model : UncertaintyModel
    notes : tuple of str
    state_blocks : tuple of (int, ndarray) or None
        The control centre's composite state bounds per block of switch samples (what
        :meth:`after_switch_to` starts from).
    """

    period: float
    samples: int
    segments: tuple[tuple[int, str], ...]
    detectors: Mapping[str, DetectorSchedule]
    after_switch: AfterSwitchThreshold | None
    certified: CertifiedThresholds
    model: UncertaintyModel
    notes: tuple[str, ...]
    state_blocks: tuple[tuple[int, np.ndarray], ...] | None = None

    def after_switch_to(self, system: System, mode: str | None) -> AfterSwitchThreshold | None:
        """The control centre's thresholds after Algorithm 1's switch to ``mode`` (None when not certified)."""
        if mode is None:
            return None
        if self.after_switch is not None and self.after_switch.mode == mode:
            return self.after_switch
        central = next((d for d in self.certified.detectors if d.kind == "central" and d.name in self.detectors), None)
        if central is None or self.state_blocks is None or self.model.initial != "state" or self.model.spec.gaussian:
            return None
        try:
            return _after_switch(system, central, system.check_mode(mode), list(self.state_blocks), self.samples, self.model, self.period, implementation_of(system))
        except NotApplicableError:
            return None

    def to_json(self) -> dict[str, Any]:
        """Summary: per detector and segment its peak threshold, the tail, the notes."""
        out: dict[str, Any] = {"period": self.period, "samples": self.samples, "segments": [{"sample": s, "mode": m} for s, m in self.segments], "detectors": {}}
        for name, d in self.detectors.items():
            starts = [s for s, _, _ in d.segments] + [self.samples]
            out["detectors"][name] = {
                "segments": [
                    {"sample": s, "mode": m, "covered": c, "peak": dict(zip(d.channels, d.theta[s : max(e, s + 1)].max(axis=0).tolist())) if s < self.samples else None}
                    for (s, m, c), e in zip(d.segments, starts[1:])
                ],
                "tail": dict(zip(d.channels, d.tail.tolist())),
            }
        if self.after_switch is not None:
            a = self.after_switch
            out["after_switch"] = {"mode": a.mode, "blocks": [{"sample": s0, "peak": t.max(axis=0).tolist(), "tail": tl.tolist()} for s0, t, tl in zip(a.starts, a.theta, a.tail)]}
        out["notes"] = list(self.notes)
        return jsonable(out)  # type: ignore[no-any-return]


def schedule_samples(segments: Sequence[tuple[float, str]], period: float) -> tuple[tuple[int, str], ...]:
    """The schedule's segments as (first sample, mode): a switch at time t acts from the sample
    ``ceil(t / h)`` on (the first sample at or after it; a switch between samples takes effect at
    the next one)."""
    out: list[tuple[int, str]] = []
    for t, m in segments:
        s = int(math.ceil(float(t) / period - 1e-9))
        if out and out[-1][0] == s:
            out[-1] = (s, m)
        elif not out or out[-1][1] != m:
            out.append((s, m))
    return tuple(out)


# --------------------------------------------------------------------------------------------
# the composites of each detector per mode


def _changes_cluster(system: System, cluster: str, mode: str) -> bool:
    base, cm = system.cluster_model(cluster, NORMAL_MODE), system.cluster_model(cluster, mode)
    return not (np.array_equal(cm.A, base.A) and np.array_equal(cm.E, base.E))


def detector_segments(
    system: System, detector: SampledObserver, modes: Sequence[str], implementation: ImplementationSpec | None = None
) -> tuple[list[SegmentComposite | None], list[str]]:
    """Per segment mode: the detector's composite, or None from the first mode it has no
    certified model in on (a UIO without a design for the mode, a composite that needs a
    connected graph); with notes saying why."""
    impl = implementation_of(system, implementation)
    out: list[SegmentComposite | None] = []
    notes: list[str] = []
    prev: SampledObserver | None = None
    for q in modes:
        if out and out[-1] is None:
            out.append(None)
            continue
        try:
            if detector.kind == "central":
                c = central_composite(system, detector, None, q, impl)
                out.append(SegmentComposite(q, detector, c.M, c.Nw, c.Nn, c.R, c.Dn, None))
                continue
            lo = next(o for o in system.observers() if f"{o.cluster}@{o.center}" == detector.name)
            d = design_sampled_uio(system, lo, impl, mode=q) if q != NORMAL_MODE and _changes_cluster(system, lo.cluster, q) else detector
            jn = None
            if prev is not None and prev is not d:
                J = d.Pn - prev.Pn  # -(H_p - H_q): the reset z <- z + (H_p - H_q) y moves e~ = T x - z by -(H_p - H_q) n
                if any(J[i, j] != 0 for i in range(J.nrows()) for j in range(J.ncols())):
                    jn = J
            out.append(SegmentComposite(q, d, d.F, d.Gw, d.Kn, d.Ce, d.Dn, jn))
            prev = d
        except NotApplicableError as exc:
            notes.append(f"{detector.name}: no certified threshold from mode {q} on ({exc})")
            out.append(None)
    return out, notes


# --------------------------------------------------------------------------------------------
# componentwise reach of the composite state


def _decay(pc: PowerCertificate, L: int) -> float:
    """A certified bound of ``||M^L||_inf``: ``kappa theta^floor(L / m0)``."""
    if not pc.window or not math.isfinite(pc.kappa):
        return math.inf
    return float(upper(pc.kappa * pc.theta ** (L // pc.window), 4))


def _sup_after(cols: np.ndarray, L: int, pc: PowerCertificate) -> np.ndarray:
    """Componentwise bound of ``sup_{t >= L} |x_t|`` for ``x_t = M^t v``, from the computed
    ``cols[t] >= |x_t|`` for ``L <= t < L + m0``: a later ``t = L + j m0 + r`` has
    ``|x_t| <= ||M^m0||^j ||x_{L+r}||_inf <= theta max cols``."""
    if not pc.window or len(cols) < L + pc.window:
        return np.full(cols.shape[1], math.inf)
    win = cols[L : L + pc.window]
    return np.maximum(win.max(axis=0), upper(pc.theta * float(win.max(initial=0.0)), 2))  # type: ignore[no-any-return]


def _sum_after(cols: np.ndarray, L: int, pc: PowerCertificate) -> np.ndarray:
    """Componentwise bound of ``sum_{t >= L} cols[t]`` for columns of the powers of M, from the
    computed window ``[L, L + m0)`` (the later windows shrink by ``theta`` each)."""
    if not pc.window or len(cols) < L + pc.window:
        return np.full(cols.shape[1], math.inf)
    win = cols[L : L + pc.window]
    rest = pc.theta / (1.0 - pc.theta) * float(win.max(axis=1).sum())
    return upper(win.sum(axis=0) + rest, pc.window + 8)  # type: ignore[no-any-return]


def _abs_inf(X: Any, w: np.ndarray) -> float:
    """A bound of ``max_r sum_c |X_rc| w_c``."""
    Xf, Xe = exact_to_float(X)
    return float(upper(((np.abs(Xf) + Xe) @ w).max(initial=0.0), Xf.shape[1] + 2))


def _columns(M: Any, X: Any, steps: int, weigh: Any) -> np.ndarray:
    """``weigh(rows, err)`` of the certified columns ``M^i X`` for ``i < steps`` (as the rows of
    ``X^T (M^T)^i``), one chunk at a time: (steps, dim) componentwise bounds."""
    Mt = M.transpose()
    pct = power_certificate(Mt)
    out = np.zeros((steps, M.nrows()))
    if steps <= 0 or not X.ncols():
        return out
    for k0, mid, err in certified_row_chunks(Mt, X.transpose(), steps, pct):
        out[k0 : k0 + len(mid)] = weigh(mid, err)
    return out


def _noise_columns(M: Any, X: Any, w: np.ndarray, steps: int) -> np.ndarray:
    """Componentwise bounds of ``|M^i X| w`` for i < steps: (steps, dim)."""
    return _columns(M, X, steps, lambda mid, err: upper(np.einsum("icd,c->id", np.abs(mid), w) + (err @ w)[:, None], len(w) + 4))


def _disturbance_columns(M: Any, Nw: Any, steps: int, dbar: float, h: float) -> np.ndarray:
    """Componentwise bounds of the state one held disturbance step reaches after i steps: (steps, dim)."""
    if dbar <= 0:
        return np.zeros((max(steps, 0), M.nrows()))
    n = Nw.ncols() // 2
    lip = max(h * h / 2, h)

    def weigh(mid: np.ndarray, err: np.ndarray) -> np.ndarray:
        W = np.transpose(mid, (0, 2, 1))  # rows of M^i Nw: (c, dim, 2N)
        return upper(dbar * (disturbance_support(W[..., :n], W[..., n:], h).sum(axis=-1) * (1 + 16 * gamma_bound(8)) + lip * err.sum(axis=1)[:, None]), 2 * n + 8)

    return _columns(M, Nw, steps, weigh)


#: largest composite for which what a segment carries in is propagated through ``|M^t|`` (else ``||M^t||_inf``)
_CARRY_EXACT_MAX = 256


def _carried(M: Any, beta: np.ndarray, steps: int) -> np.ndarray:
    """Componentwise bounds of ``|M^t v|`` for every ``|v| <= beta``, t < steps: ``|M^t| beta`` (the
    columns of ``M^t``), or ``||M^t||_inf ||beta||_inf`` by the power certificate on large composites."""
    dim = M.nrows()
    if dim <= _CARRY_EXACT_MAX:
        eye = flint.fmpq_mat(dim, dim)
        for i in range(dim):
            eye[i, i] = 1
        return _noise_columns(M, eye, beta, steps)
    pc = power_certificate(M)
    binf = float(beta.max(initial=0.0))
    return np.array([[_decay(pc, t) * binf if t else binf] * dim for t in range(steps)])


def _cumulative(cols: np.ndarray) -> np.ndarray:
    """``c[s] = sum_{i<s} cols[i]`` for s = 0 .. len (certified sums)."""
    out = np.zeros((len(cols) + 1, cols.shape[1]))
    out[1:] = upper(np.cumsum(cols, axis=0), len(cols) + 2)
    return out


# --------------------------------------------------------------------------------------------
# one segment's rows


class _SegmentRows:
    """The rows of one segment's composite and everything of its bound that does not depend on
    the state it is entered with (module docstring)."""

    def __init__(self, comp: SegmentComposite, L: int, model: UncertaintyModel, h: float, nbar: np.ndarray) -> None:
        self.L = L
        self.scale = model.scale(h)
        rows = certified_rows(comp.M, comp.R, L)
        self.rows = rows
        q = rows.mid.shape[1]
        Nn1 = comp.Nn - comp.M * comp.Jn if comp.Jn is not None else comp.Nn
        scaled = np.diag(nbar) if len(nbar) else np.zeros((0, 0))
        nz = abs_row_sums(rows, exact_to_float(comp.Nn)[0] @ scaled, L)
        nz1 = abs_row_sums(rows, exact_to_float(Nn1)[0] @ scaled, L) if comp.Jn is not None else nz
        cs = np.zeros((L, q))
        cs[1:] = upper(np.cumsum(nz[: L - 1], axis=0), L + 2)  # cs[m] = sum_{t<m} a_t
        noise = np.zeros((L, q))
        if L > 1:
            noise[2:] = cs[1 : L - 1]  # sum_{t<=m-2} a_t = cs[m-1]
            noise[1:] = upper(noise[1:] + nz1[: L - 1], 2)  # + a'_{m-1} (the segment's first noise, through the reset)
        direct = upper(np.abs(exact_to_float(comp.Dn)[0]) @ nbar, q + 2)
        direct0 = upper(np.abs(exact_to_float(comp.R * comp.Jn + comp.Dn)[0]) @ nbar, q + 2) if comp.Jn is not None else direct
        dist = np.zeros((L, q))
        per = np.zeros((L, q))
        if model.disturbance > 0 and comp.Nw.ncols():
            per = disturbance_rows(rows, comp.Nw, model.disturbance, h, L)
            dist[1:] = upper(np.cumsum(per[: L - 1], axis=0), L + 2)
        common = noise + dist + direct[None, :]
        common[0] = direct0
        self.common = upper(common, 4)
        # m >= L (the mode persists): sum_{t<=m-2} a_t + a'_{m-1} <= sum_{t<L} a_t + sum_{t>=L} a_t + max(a'_{L-1}, sup_{t>=L} a'_t)
        self.tsup, tsum = rows.tail_norms()
        gw_inf = _abs_inf(comp.Nw, np.ones(comp.Nw.ncols())) * max(h * h / 2, h) * model.disturbance
        self.common_tail = upper(
            cs[L - 1] + nz[L - 1] + tsum * _abs_inf(comp.Nn, nbar) + np.maximum(nz1[L - 1], self.tsup * _abs_inf(Nn1, nbar)) + direct + dist[L - 1] + per[L - 1] + tsum * gw_inf,
            16,
        )

    def with_state(self, beta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta, bound, tail theta) for a segment entered with ``|zeta^-| <= beta``."""
        L, rows = self.L, self.rows
        binf = float(beta.max(initial=0.0))
        pre = np.abs(rows.mid[:L]) @ beta + rows.err[:L] * binf
        bound = upper(pre + self.common, len(beta) + 8)
        tail = upper(self.tsup * binf + self.common_tail, 4)
        return (1 + ROUNDING) * bound + ROUNDING * self.scale, bound, (1 + ROUNDING) * tail + ROUNDING * self.scale


# --------------------------------------------------------------------------------------------
# the schedule


def _initial_columns(det: SampledObserver, model: UncertaintyModel, nbar: np.ndarray, system: System, impl: ImplementationSpec) -> list[tuple[Any, np.ndarray]]:
    """The initial state's columns into the first segment's composite and their bounds."""
    if det.kind == "central":
        X0 = central_composite(system, det, None, NORMAL_MODE, impl).X0
        return [(X0, np.full(X0.ncols(), model.box))]
    if model.initial == "state":
        return [(det.Px, np.full(det.Px.ncols(), model.box))]
    return [(det.Pe, np.full(det.Pe.ncols(), model.box)), (det.Pn, nbar)]


def _doubling_blocks(end: int) -> list[int]:
    """Starts 0, 1, 2, 4, 8, ... below ``end``."""
    out = [0]
    b = 1
    while b < end:
        out.append(b)
        b *= 2
    return out


def _schedule_of(
    system: System,
    det: SampledObserver,
    segs: tuple[tuple[int, str], ...],
    K: int,
    base: CertifiedThresholds,
    model: UncertaintyModel,
    h: float,
    impl: ImplementationSpec,
) -> tuple[DetectorSchedule, list[tuple[int, np.ndarray]] | None]:
    """One detector over the schedule, and (for Algorithm 1's switch) the componentwise bounds of
    its composite state over blocks of switch samples (None when not covered)."""
    name = det.name
    pre = base.observers[name]
    q = len(det.channels)
    nbar = model.noise(det.channels)
    comps, notes = detector_segments(system, det, [m for _, m in segs], impl)
    theta = np.full((K, q), np.inf)
    bound = np.full((K, q), np.inf)
    tail = pre.tail if len(segs) == 1 else np.full(q, np.inf)
    starts = [s for s, _ in segs] + [K]
    s1 = starts[1]
    theta[:s1] = pre.theta[:s1]
    bound[:s1] = (pre.parts["initial"] + pre.parts["noise"] + pre.parts["disturbance"])[:s1]  # the certified bound (pre.bound is the float worst case)
    first = comps[0]
    gaussian = model.spec.gaussian and len(segs) > 1
    if gaussian:
        notes.append(f"{name}: the Gaussian part of the noise is bounded before the first switch only: no certified threshold after it")
    if first is None or gaussian:
        segments = tuple((s, m, j == 0) for j, (s, m) in enumerate(segs))
        return DetectorSchedule(name, det.kind, det.channels, theta, tail, bound, segments, ((segs[0][1], det),), tuple(notes)), None
    # the first segment: the initial state's columns exactly, the noise and disturbance summed
    end0 = s1 if len(segs) > 1 else K
    pc0 = power_certificate(first.M)
    more = pc0.window if len(segs) == 1 else 0  # one window past the horizon: the open block's bound
    init = np.zeros((end0 + 1 + more, first.M.nrows()))
    for X, w in _initial_columns(det, model, nbar, system, impl):
        init += _noise_columns(first.M, X, w, end0 + 1 + more)
    n_cols = _noise_columns(first.M, first.Nn, nbar, end0 + more)
    w_cols = _disturbance_columns(first.M, first.Nw, end0 + more, model.disturbance, h)
    reach = _cumulative(n_cols[:end0]) + _cumulative(w_cols[:end0])
    beta = upper(init[end0] + reach[end0], 4)
    blocks: list[tuple[int, np.ndarray]] | None = []
    bs = _doubling_blocks(end0)
    for a, e in zip(bs, bs[1:] + [end0]):
        blocks.append((a, upper(init[a:e].max(axis=0) + reach[e - 1], 4)))  # type: ignore[union-attr]
    if len(segs) == 1 and blocks:
        # the mode persists: the last block is open, so it holds the states after the horizon too
        a, b_ = blocks[-1]
        beyond = _sup_after(init, end0, pc0) + reach[end0] + _sum_after(n_cols, end0, pc0) + _sum_after(w_cols, end0, pc0)
        blocks[-1] = (a, upper(np.maximum(b_, beyond), 4))
    for j in range(1, len(segs)):
        comp = comps[j]
        if comp is None:
            blocks = None
            break
        s, e = starts[j], starts[j + 1]
        last = j == len(segs) - 1
        L = max(e - s, 1)
        th, bd, tl = _SegmentRows(comp, L, model, h, nbar).with_state(beta)
        theta[s:e] = th[: e - s]
        bound[s:e] = bd[: e - s]
        if last:
            tail = tl
        jump = np.abs(exact_to_float(comp.Jn)[0]) @ nbar if comp.Jn is not None else np.zeros(comp.M.nrows())
        entered = upper(beta + jump, 2)
        # what came before, through |M^t|; the segment's noise (its first one through the reset) and disturbance
        pcj = power_certificate(comp.M)
        more = pcj.window if last else 0
        carried = _carried(comp.M, entered, L + 1 + more)
        n_cols = _noise_columns(comp.M, comp.Nn, nbar, L + more)
        if comp.Jn is not None:
            n_cols = np.maximum(n_cols, _noise_columns(comp.M, comp.Nn - comp.M * comp.Jn, nbar, L + more))
        w_cols = _disturbance_columns(comp.M, comp.Nw, L + more, model.disturbance, h)
        reach = _cumulative(n_cols[:L]) + _cumulative(w_cols[:L])
        beta = upper(carried[L] + reach[L], 4)
        if blocks is not None:
            bs = _doubling_blocks(L)
            for a0, b0 in zip(bs, bs[1:] + [L]):
                blocks.append((s + a0, upper(carried[a0:b0].max(axis=0) + reach[b0 - 1], 4)))
            if last:
                a, b_ = blocks[-1]
                beyond = _sup_after(carried, L, pcj) + reach[L] + _sum_after(n_cols, L, pcj) + _sum_after(w_cols, L, pcj)
                blocks[-1] = (a, upper(np.maximum(b_, beyond), 4))
    covered = [True] + [c is not None for c in comps[1:]]
    segments = tuple((s, m, c) for (s, m), c in zip(segs, covered))
    ds = DetectorSchedule(name, det.kind, det.channels, theta, tail, bound, segments, tuple((c.mode, c.detector) for c in comps if c is not None), tuple(notes))
    if blocks is not None and not all(np.all(np.isfinite(b)) for _, b in blocks):
        blocks = None
    return ds, blocks


def _after_switch(system: System, det: SampledObserver, mode: str, blocks: list[tuple[int, np.ndarray]], K: int, model: UncertaintyModel, h: float, impl: ImplementationSpec) -> AfterSwitchThreshold:
    """The control centre's threshold after a switch to ``mode`` in each block of switch samples (module docstring)."""
    c = central_composite(system, det, None, mode, impl)
    rows = _SegmentRows(SegmentComposite(mode, det, c.M, c.Nw, c.Nn, c.R, c.Dn, None), K, model, h, model.noise(det.channels))
    got = [rows.with_state(beta) for _, beta in blocks]
    return AfterSwitchThreshold(mode, tuple(s for s, _ in blocks), tuple(g[0] for g in got), tuple(g[2] for g in got), tuple(g[1] for g in got), tuple(b for _, b in blocks))


def schedule_thresholds(
    system: System,
    certified: CertifiedThresholds,
    segments: Sequence[tuple[float, str]],
    *,
    safe_mode: str | None = None,
    implementation: ImplementationSpec | None = None,
) -> ScheduleThresholds:
    """Certified thresholds of every detector of ``certified`` over the schedule ``segments``
    ((time, mode), the first at 0), and the control centre's threshold after Algorithm 1's
    switch to ``safe_mode`` (module docstring).

    Parameters
    ----------
    system : System
    certified : CertifiedThresholds
        The thresholds before any switch; its horizon must reach past the last switch.
    segments : sequence of (float, str)
    safe_mode : str, optional
        Algorithm 1's safe mode (no after-switch threshold without one).
    implementation : ImplementationSpec, optional

    Raises
    ------
    NotApplicableError
        When the schedule's last switch lies beyond the certified thresholds' horizon.
    """
    impl = implementation_of(system, implementation)
    h = certified.period
    K = certified.horizon
    model = certified.model
    segs = schedule_samples(segments, h)
    if segs[-1][0] >= K:
        raise NotApplicableError(f"the schedule's last switch (sample {segs[-1][0]}) lies beyond the thresholds' horizon ({K} samples)")
    notes = list(certified.notes)
    out: dict[str, DetectorSchedule] = {}
    central_blocks: list[tuple[int, np.ndarray]] | None = None
    for det in certified.detectors:
        if det.name not in certified.observers:
            continue
        ds, blocks = _schedule_of(system, det, segs, K, certified, model, h, impl)
        out[det.name] = ds
        notes += list(ds.notes)
        if det.kind == "central":
            central_blocks = blocks
    after = None
    central = next((d for d in certified.detectors if d.kind == "central" and d.name in out), None)
    if safe_mode is not None and central is not None:
        if model.initial != "state":
            notes.append("central: the threshold after Algorithm 1's switch needs a box of initial states (uncertainty.initial_state)")
        elif model.spec.gaussian:
            notes.append("central: the Gaussian part of the noise is bounded before any switch only: no certified threshold after Algorithm 1's switch")
        elif central_blocks is None:
            notes.append("central: no certified bound of the state at Algorithm 1's switch: no threshold after it")
        else:
            try:
                after = _after_switch(system, central, system.check_mode(safe_mode), central_blocks, K, model, h, impl)
            except NotApplicableError as exc:
                notes.append(f"central: no threshold after Algorithm 1's switch to {safe_mode} ({exc})")
    kept = tuple(central_blocks) if central_blocks is not None else None
    return ScheduleThresholds(h, K, segs, out, after, certified, model, tuple(dict.fromkeys(notes)), kept)
