"""Detection guarantees: which detector catches an attack of a given size, and by when, for
every admissible initial state, noise and disturbance.

Everything is linear: a run's residual is its attack-free part (bounded by the certified
:math:`\\bar B`, :mod:`.certified_thresholds`) plus ``a`` times the attack's part
:math:`\\rho_k` (the residual of the attack alone from a zero state, size 1). A detector's
residual therefore certainly crosses its threshold :math:`\\theta \\ge \\bar B` at sample k,
channel j, when

.. math:: a\\,(|\\rho_{k,j}| - \\mathrm{err}_{k,j}) > \\theta_{k,j} + \\bar B_{k,j}

(we use :math:`2\\theta`), whatever the admissible run: a certified **detection time**. The
smallest size guaranteed to be caught within T is
:math:`\\min_{k \\le k_a + T/h,\\,j} 2\\theta_{k,j} / (|\\rho_{k,j}| - \\mathrm{err}_{k,j})`.

**The attack's part.** For a composite :math:`\\zeta_{k+1} = M \\zeta_k + N u_k` (stable M) driven
from :math:`\\zeta_a` at :math:`k_a` by :math:`u = \\operatorname{Re}(u_0 z^{k-k_a})`, the exact
response is :math:`\\zeta = \\operatorname{Re}(X z^{j} + M^{j} (\\zeta_a - X))`, ``j = k - k_a``, with
:math:`X = (z I - M)^{-1} N u_0`, solved in complex ball arithmetic (``acb_mat.solve``), and the
transient read off the certified rows :math:`R M^j`
(:func:`~glocal_verify.numerics.certified_rows.certified_rows`): every :math:`\\rho_k` carries a
rigorous error.

**The chain of Algorithm 1.** A local alarm (lines 3-5) triggers the switch ``switch_delay``
samples later. The first alarm is run-dependent, but it cannot come before the attack (an
attack-free run never crosses) and it comes no later than the earliest guaranteed local
alarm ``k_L``: the switch sample lies in ``[k_a + d, k_L + d]``. For **every** switch sample
of that window, the central observer's post-switch residual is
:math:`\\operatorname{Re}(c_2 z^{k - k_a} + \\ell'_{k-s} v_s)` (:math:`v_s` the composite state at
the switch, from the pre-switch response) and its threshold the certified post-switch
threshold of :mod:`.switch_thresholds`; the guaranteed global detection time is the worst
over the window.

**Escape (a proven failure).** The run with zero initial state, noise and disturbance is
admissible; its residuals are exactly :math:`a \\rho`. When it provably never crosses (no local
alarm, or a certified local alarm whose switch leaves the central residual below its
threshold up to the horizon), detection within the horizon is proven impossible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import flint
import numpy as np

from glocal_verify import config
from glocal_verify.analysis.sampled.loop import implementation_of
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.certified_rows import RowSequence, certified_orbit, certified_rows, exact_to_float, power_certificate, upper
from glocal_verify.numerics.rounding import gamma_bound
from glocal_verify.results import Status, jsonable
from glocal_verify.simulation.certified_thresholds import CertifiedThresholds, certified_thresholds
from glocal_verify.simulation.sampled_attack import Composite, SampledAttack, central_composite, local_composite, sampled_attack_from_spec
from glocal_verify.simulation.switch_thresholds import SwitchThresholds, post_switch_thresholds
from glocal_verify.spec.arguments import real_arg
from glocal_verify.spec.types import NORMAL_MODE, ImplementationSpec, UncertaintySpec

__all__ = [
    "AttackResponse",
    "attack_response",
    "StageGuarantee",
    "DetectionGuarantee",
    "detection_guarantee",
]

#: bits of the complex ball arithmetic of the particular solutions
_PREC = 128


@dataclass(frozen=True, slots=True)
class AttackResponse:
    """The attack's part of one detector's residual, size 1, with certified errors.

    Attributes
    ----------
    observer : str
    channels : tuple of str
    start : int
        k_a.
    rho : ndarray
        (K, q): zero before ``k_a``.
    err : ndarray
        (K, q): ``|rho(exact) - rho| <= err``.
    """

    observer: str
    channels: tuple[str, ...]
    start: int
    rho: np.ndarray
    err: np.ndarray


def _particular(M: Any, N: Any, u0: np.ndarray, z: complex) -> tuple[np.ndarray, np.ndarray]:
    """``X = (z I - M)^{-1} N u0`` in complex ball arithmetic: midpoints and entrywise radii."""
    n = M.nrows()
    old = flint.ctx.prec
    flint.ctx.prec = _PREC
    try:
        A = flint.acb_mat(flint.arb_mat(M))
        zb = flint.acb(float(z.real), float(z.imag))
        S = -A
        for i in range(n):
            S[i, i] = S[i, i] + zb
        Nb = flint.acb_mat(flint.arb_mat(N))
        u = flint.acb_mat(len(u0), 1, [flint.acb(float(c.real), float(c.imag)) for c in u0])
        rhs = Nb * u if len(u0) else flint.acb_mat(n, 1)
        try:
            X = S.solve(rhs)
        except ZeroDivisionError:
            raise NotApplicableError(f"the attack's mode z = {z:g} is too close to an eigenvalue of the composite (resonance)") from None
        mid = np.empty(n, dtype=complex)
        rad = np.empty(n)
        for i in range(n):
            x = X[i, 0]
            mid[i] = complex(float(x.real.mid()), float(x.imag.mid()))
            rad[i] = float(x.real.rad()) + float(x.imag.rad()) + 2.0**-52 * abs(mid[i])
    finally:
        flint.ctx.prec = old
    return mid, rad * (1 + 2.0**-50)


def _powers(z: complex, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``z^j`` for ``j < count`` by repeated products, with a bound on their rounding."""
    out = np.empty(count, dtype=complex)
    acc = 1.0 + 0j
    for j in range(count):
        out[j] = acc
        acc *= z
    err = np.abs(out) * gamma_bound(4) * (np.arange(count) + 1)
    return out, err


def attack_response(comp: Composite, attack: SampledAttack, K: int, name: str, rows: RowSequence | None = None) -> AttackResponse:
    """The attack's part of a composite's residual (module docstring), size 1."""
    ka = attack.start
    q = len(comp.channels)
    rho = np.zeros((K, q))
    err = np.zeros((K, q))
    L = K - ka
    if L <= 0:
        return AttackResponse(name, comp.channels, ka, rho, err)
    rows = rows if rows is not None else certified_rows(comp.M, comp.R, L)
    X, Xe = _particular(comp.M, comp.Nu, attack.u0, attack.z)
    R, Re_ = exact_to_float(comp.R)
    c = R @ X
    cerr = upper((np.abs(R) + Re_) @ Xe + gamma_bound(R.shape[1] + 2) * (np.abs(R) @ np.abs(X)) + Re_ @ np.abs(X), R.shape[1] + 4)
    Xa, _ = exact_to_float(comp.Xa)
    za = Xa @ attack.x0
    zaerr = gamma_bound(Xa.shape[1] + 2) * (np.abs(Xa) @ np.abs(attack.x0)) * 2
    v = za - X
    verr = float(upper((Xe + zaerr).max(initial=0.0) + gamma_bound(2) * np.abs(v).max(initial=0.0), 4))
    zj, zjerr = _powers(attack.z, L)
    mid = rows.mid[:L]
    tr = mid @ v  # (L, q)
    vinf = float(np.abs(v).max(initial=0.0))
    rho[ka:] = np.real(c[None, :] * zj[:, None] + tr)
    e = (
        cerr[None, :] * np.abs(zj)[:, None]
        + np.abs(c)[None, :] * zjerr[:, None]
        + rows.err[:L] * vinf
        + np.abs(mid).sum(axis=2) * verr
        + 2 * gamma_bound(mid.shape[2] + 2) * (np.abs(mid) @ np.abs(v))
    )
    err[ka:] = upper(e, mid.shape[2] + 8)
    return AttackResponse(name, comp.channels, ka, rho, err)


@dataclass(frozen=True, slots=True)
class StageGuarantee:
    """One detector's certified alarm for the attack of the given size.

    Attributes
    ----------
    observer : str
    guaranteed : int or None
        First sample at which every admissible run raises this detector's alarm.
    within : float or None
        ``(guaranteed - k_a) h``: seconds after the attack starts.
    channel : str or None
        The channel that certifies it.
    min_size : float or None
        Smallest size whose alarm is guaranteed within the size horizon (None: none is).
    zero_run : int or None
        First certified crossing of the run with zero initial state, noise and disturbance
        (None when it provably never crosses, -1 when it cannot be decided).
    """

    observer: str
    guaranteed: int | None
    within: float | None
    channel: str | None
    min_size: float | None
    zero_run: int | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable({"observer": self.observer, "guaranteed_sample": self.guaranteed, "within": self.within, "channel": self.channel, "min_size": self.min_size, "zero_run_alarm": self.zero_run})


def _stage(name: str, channels: Sequence[str], resp: AttackResponse, theta: np.ndarray, a: float, h: float, size_samples: int) -> StageGuarantee:
    K = min(len(theta), len(resp.rho))
    ka = resp.start
    lo = np.maximum(np.abs(resp.rho[:K]) - resp.err[:K], 0.0)
    hi = np.abs(resp.rho[:K]) + resp.err[:K]
    th = theta[:K]
    ok = a * lo > 2.0 * th * (1 + 4 * gamma_bound(2))
    ok[:ka] = False
    guaranteed = channel = None
    if np.any(ok):
        k = int(np.argmax(np.any(ok, axis=1)))
        guaranteed, channel = k, channels[int(np.argmax(ok[k]))]
    # the zero run: residual = a rho exactly
    cross = a * lo > th
    maybe = a * hi > th
    zero: int | None
    if not np.any(maybe):
        zero = None
    else:
        first_maybe = int(np.argmax(np.any(maybe, axis=1)))
        zero = first_maybe if np.any(cross[first_maybe]) else -1
    end = min(K, ka + size_samples + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(lo[ka:end] > 0, 2.0 * th[ka:end] / lo[ka:end], np.inf)
    ms = float(upper(need.min(), 8)) if need.size and np.isfinite(need.min()) else None
    return StageGuarantee(name, guaranteed, (guaranteed - ka) * h if guaranteed is not None else None, channel, ms, zero)


@dataclass(frozen=True, slots=True)
class DetectionGuarantee:
    """A certified answer for one attack of one size, over the whole uncertainty set.

    Attributes
    ----------
    status : Status
        HOLDS: every admissible run raises the control centre's alarm within the horizon
        (after a local alarm and the switch, or directly); FAILS: the admissible run with zero
        initial state, noise and disturbance provably does not; UNDECIDED: neither is proven.
    attack : mapping
        The attack (kind, actuators, mode z, direction, start).
    size : float
        The size a analysed (the attack's amplitude).
    mode : str or None
        The safe mode switched to.
    detected_by : str or None
        The detector with the earliest guaranteed alarm (a local observer, or ``"central"``).
    within : float or None
        Seconds from the attack's start to that guaranteed alarm.
    switch_window : (float, float) or None
        Earliest and latest switch times (s).
    global_within : float or None
        Worst case over the switch window of the seconds from the switch to the control
        centre's guaranteed alarm.
    global_detection : float or None
        Worst case of the seconds from the attack's start to the control centre's alarm.
    min_size : float or None
        Smallest size with a guaranteed local (or central) alarm within ``size_horizon``.
    size_horizon : float
    local : tuple of StageGuarantee
    central_before_switch : StageGuarantee or None
    per_switch : tuple of (int, int or None)
        For each switch sample of the window, the central observer's guaranteed alarm sample.
    horizon, period : float
    notes : tuple of str
    """

    status: Status
    attack: Mapping[str, Any]
    size: float
    mode: str | None
    detected_by: str | None
    within: float | None
    switch_window: tuple[float, float] | None
    global_within: float | None
    global_detection: float | None
    min_size: float | None
    size_horizon: float
    local: tuple[StageGuarantee, ...]
    central_before_switch: StageGuarantee | None
    per_switch: tuple[tuple[int, int | None], ...]
    horizon: float
    period: float
    notes: tuple[str, ...] = ()
    responses: Mapping[str, AttackResponse] = field(default_factory=dict, repr=False)
    switch_thresholds: SwitchThresholds | None = field(default=None, repr=False)

    @property
    def caught_locally(self) -> bool:
        """Some local observer's alarm is guaranteed within the horizon."""
        return any(s.guaranteed is not None for s in self.local)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "status": self.status.value,
                "attack": dict(self.attack),
                "size": self.size,
                "mode": self.mode,
                "detected_by": self.detected_by,
                "within": self.within,
                "switch_window": list(self.switch_window) if self.switch_window else None,
                "global_within": self.global_within,
                "global_detection": self.global_detection,
                "min_size": self.min_size,
                "size_horizon": self.size_horizon,
                "local": [s.to_json() for s in self.local],
                "central_before_switch": self.central_before_switch.to_json() if self.central_before_switch else None,
                "switches_analysed": len(self.per_switch),
                "horizon": self.horizon,
                "period": self.period,
                "notes": list(self.notes),
            }
        )


def _post_switch(
    attack: SampledAttack, pre: Composite, post: Composite, st: SwitchThresholds, K: int, S: Sequence[int]
) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per switch sample s: (rho, err) of the central residual for k = s .. K - 1 (size 1)."""
    ka = attack.start
    X1, X1e = _particular(pre.M, pre.Nu, attack.u0, attack.z)
    X2, X2e = _particular(post.M, post.Nu, attack.u0, attack.z)
    Xa, _ = exact_to_float(pre.Xa)
    za = Xa @ attack.x0
    zaerr = gamma_bound(Xa.shape[1] + 2) * (np.abs(Xa) @ np.abs(attack.x0)) * 2
    s_max = max(S)
    pc = power_certificate(pre.M)
    orb, oerr = certified_orbit(pre.M, za - X1, s_max - ka + 1, pc)
    pc_kappa = pc.kappa
    zj, zjerr = _powers(attack.z, K - ka + 1)
    R, _ = exact_to_float(post.R)
    c2 = R @ X2
    c2err = upper(np.abs(R) @ X2e + gamma_bound(R.shape[1] + 2) * (np.abs(R) @ np.abs(X2)), R.shape[1] + 4)
    rows = st.rows
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    V = np.stack([(X1 - X2) * zj[s - ka] + orb[s - ka] for s in S], axis=1)  # (dim, S)
    verr = np.array(
        [
            float((X1e + X2e).max() * abs(zj[s - ka]) + (np.abs(X1 - X2).max()) * zjerr[s - ka] + oerr[s - ka] + pc_kappa * (X1e.max() + zaerr.max()))
            for s in S
        ]
    )
    Lmax = K - min(S)
    Y = rows.mid[:Lmax] @ V  # (L, q, S)
    absmid = np.abs(rows.mid[:Lmax])
    l1 = absmid.sum(axis=2)
    for i, s in enumerate(S):
        L = K - s
        j = np.arange(L) + (s - ka)
        val = np.real(c2[None, :] * zj[j][:, None] + Y[:L, :, i])
        vinf = float(np.abs(V[:, i]).max())
        e = (
            c2err[None, :] * np.abs(zj[j])[:, None]
            + np.abs(c2)[None, :] * zjerr[j][:, None]
            + rows.err[:L] * vinf
            + l1[:L] * verr[i]
            + 2 * gamma_bound(V.shape[0] + 2) * (absmid[:L] @ np.abs(V[:, i]))
        )
        out[s] = (val, upper(e, V.shape[0] + 8))
    return out


def detection_guarantee(
    system: System,
    *,
    size: float | None = None,
    mode: str | None = None,
    horizon: float | None = None,
    size_horizon: float | None = None,
    attack: SampledAttack | None = None,
    implementation: ImplementationSpec | None = None,
    uncertainty: UncertaintySpec | None = None,
    thresholds: CertifiedThresholds | None = None,
    after_switch: Any = None,
    before: int | None = None,
) -> DetectionGuarantee:
    """The certified detection guarantee of an attack (module docstring).

    Parameters
    ----------
    system : System
        With ``[implementation]`` (sampled controller) and an ``[attack]`` (unless ``attack``).
    size : float, optional
        The attack's size a (default its amplitude).
    mode : str, optional
        The safe mode Algorithm 1 switches to (default the spec's ``switching.mode``).
    horizon : float, optional
        Seconds analysed (default the spec's simulation horizon).
    size_horizon : float, optional
        T of the smallest guaranteed size (default the horizon).
    attack : SampledAttack, optional
        Default :func:`~glocal_verify.simulation.sampled_attack.sampled_attack_from_spec`.
    implementation, uncertainty : optional
    thresholds : CertifiedThresholds, optional
        Reused when already computed for the same system, implementation, uncertainty and horizon.
    after_switch : AfterSwitchThreshold, optional
        The control centre's thresholds after Algorithm 1's switch as deployed
        (:class:`~glocal_verify.simulation.schedule_thresholds.AfterSwitchThreshold`: one per block
        of switch samples); default the tighter thresholds of each switch sample
        (:func:`~glocal_verify.simulation.switch_thresholds.post_switch_thresholds`). The
        guarantee is then about the thresholds the deployment ships.
    before : int, optional
        The first sample of the defender's next scheduled switch: alarms before the Algorithm-1
        switch are guaranteed only before it (the attack's response assumes the normal mode).

    Raises
    ------
    NotApplicableError
        Without a sampled implementation or an attack, or on more than
        ``guarantee_max_agents`` (:mod:`glocal_verify.config`) agents.
    """
    impl = implementation_of(system, implementation)
    if size is not None:
        real_arg("size", size, 0.0)
    if horizon is not None:
        real_arg("horizon", horizon, 0.0)
    if size_horizon is not None:
        real_arg("size_horizon", size_horizon, 0.0)
    if system.n > (most := config.get("guarantee_max_agents")):
        raise NotApplicableError(f"{system.n} agents > {most}: the dense composites are not built")
    th = thresholds if thresholds is not None else certified_thresholds(system, implementation=impl, uncertainty=uncertainty, horizon=horizon)
    atk = attack if attack is not None else sampled_attack_from_spec(system, impl)
    a = float(atk.amplitude if size is None else size)
    h = th.period
    K = th.horizon
    T = (K - 1) * h
    Ts = T if size_horizon is None else float(size_horizon)
    ssz = int(math.floor(Ts / h + 1e-9))
    ka = atk.start
    notes = list(th.notes)
    dets = {o.name: o for o in th.detectors}
    responses: dict[str, AttackResponse] = {}
    local: list[StageGuarantee] = []
    for name, t in th.observers.items():
        o = dets[name]
        if o.kind != "local":
            continue
        r = attack_response(local_composite(system, o, atk), atk, K, name)
        responses[name] = r
        local.append(_stage(name, o.channels, r, t.theta[:before], a, h, ssz))
    central_before = None
    pre = None
    if "central" in th.observers:
        try:
            pre = central_composite(system, dets["central"], atk, NORMAL_MODE, impl)
            r0 = attack_response(pre, atk, K, "central")
            responses["central"] = r0
            central_before = _stage("central", dets["central"].channels, r0, th.observers["central"].theta[:before], a, h, ssz)
        except NotApplicableError as exc:
            notes.append(f"central: {exc}")
    stages = [s for s in local + ([central_before] if central_before else []) if s.guaranteed is not None]
    first = min(stages, key=lambda s: s.guaranteed) if stages else None  # type: ignore[arg-type, return-value]
    sizes = [s.min_size for s in local + ([central_before] if central_before else []) if s.min_size is not None]
    min_size = min(sizes) if sizes else None
    q = mode if mode is not None else (system.spec.switching.mode if system.spec.switching is not None else None)
    d = impl.switch_delay
    status = Status.UNDECIDED
    st: SwitchThresholds | None = None
    window = None
    gw = gd = None
    per: list[tuple[int, int | None]] = []
    # central alarm before any switch (a non-stealthy attack)
    central_first = central_before is not None and central_before.guaranteed is not None and (
        first is None or central_before.guaranteed <= min((s.guaranteed for s in local if s.guaranteed is not None), default=K)
    )
    zero_local = [s.zero_run for s in local]
    if central_first:
        status = Status.HOLDS
        gd = central_before.within  # type: ignore[union-attr]
    elif q is None:
        notes.append("no safe mode to switch to (give mode or switching.mode): the control centre's detection is not analysed")
    elif pre is not None and th.model.initial == "state":
        q = system.check_mode(q)
        post = central_composite(system, dets["central"], atk, q, impl)
        guaranteed_local = [s.guaranteed for s in local if s.guaranteed is not None]
        known_zero = [z for z in zero_local if z is not None and z >= 0]
        hi_alarm = min(guaranteed_local) if guaranteed_local else (min(known_zero) if known_zero else None)
        if hi_alarm is not None and before is not None and hi_alarm + d >= before:
            notes.append(f"the latest Algorithm-1 switch (sample {hi_alarm + d}) may come after the scheduled switch at sample {before}: the control centre's alarm is not analysed")
        elif hi_alarm is not None:
            S = list(range(ka + d, min(hi_alarm + d, K - 1) + 1))
            zero_switch = (min(known_zero) + d) if (known_zero and all(z is not None and z != -1 for z in zero_local if z is not None)) else None
            if zero_switch is not None and zero_switch < K and zero_switch not in S:
                S.append(zero_switch)
            S = sorted(s for s in set(S) if 0 < s < K)
            if S:
                st = post_switch_thresholds(pre, post, th.model, h, K, S)
                post_resp = _post_switch(atk, pre, post, st, K, S)
                worst = -1
                for s in S:
                    val, err = post_resp[s]
                    lo = np.maximum(np.abs(val) - err, 0.0)
                    if after_switch is not None:
                        m = np.arange(K - s)
                        ok = a * lo > (after_switch.at(s, m) + after_switch.bound_at(s, m)) * (1 + 4 * gamma_bound(2))
                    else:
                        ok = a * lo > (st.theta[s] + st.bound[s]) * (1 + 4 * gamma_bound(2))
                    k = (s + int(np.argmax(np.any(ok, axis=1)))) if np.any(ok) else None
                    if s <= (hi_alarm + d):
                        per.append((s, k))
                        worst = max(worst, (k - s) if k is not None else 10**12)
                if guaranteed_local:
                    window = (S[0] * h, min(hi_alarm + d, K - 1) * h)
                    if per and all(k is not None for _, k in per):
                        gw = worst * h
                        gd = max(k - ka for _, k in per if k is not None) * h  # type: ignore[operator]
                        status = Status.HOLDS
                # the zero run: its switch and whether the centre ever crosses
                if status is not Status.HOLDS and zero_switch is not None and zero_switch in post_resp:
                    val, err = post_resp[zero_switch]
                    thz = after_switch.at(zero_switch, np.arange(K - zero_switch)) if after_switch is not None else st.theta[zero_switch]
                    if not np.any(a * (np.abs(val) + err) > thz):
                        status = Status.FAILS
                        notes.append(f"the run with zero initial state, noise and disturbance switches at t = {zero_switch * h:g} s and the control centre's residual stays below its threshold up to the horizon")
    elif pre is not None:
        notes.append("the control centre's post-switch threshold needs a bounded initial state (uncertainty.initial_state)")
    if status is Status.UNDECIDED and all(z is None for z in zero_local) and (central_before is None or central_before.zero_run is None):
        status = Status.FAILS
        notes.append("the run with zero initial state, noise and disturbance raises no alarm up to the horizon")
    detected_by = first.observer if first is not None else None
    within = first.within if first is not None else None
    return DetectionGuarantee(
        status, atk.describe(), a, q, detected_by, within, window, gw, gd, min_size, Ts, tuple(local), central_before, tuple(per), T, h, tuple(notes), responses, st
    )
