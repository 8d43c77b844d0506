"""Algorithm 1 on the sampled implementation: batches of runs with noise, disturbance and the
certified thresholds, to confirm the guarantees by simulation.

Each run is one column of a batch: the plant :math:`x_{k+1} = \\Phi_{\\sigma_k} x_k + \\Gamma(u_k + \\text{held disturbance})`,
every detector as it is implemented (:class:`~glocal_verify.observers.sampled.SampledObserver`:
``z_{k+1} = F_o z_k + G_o y_k``, ``r_k = R_y y_k - R_z z_k``, ``y_k = C x_k + n_k`` with the
observer's own noise), the local alarms of Algorithm 1 (line 3: some channel above its
threshold), the switch ``switch_delay`` samples after a run's first local alarm, and the
central alarm after it against the post-switch threshold of that run's switch sample
(:mod:`.switch_thresholds`). The residuals are computed from the implementation, not from
the error equations the bounds use, so the simulation checks those derivations too.

Uncertainty draws (``kind``):

``"random"``
    ``x_0`` uniform in the box, noise uniform in its bounds (plus the Gaussian part), a
    disturbance constant over each period, uniform in its bound;
``"vertex"``
    the box's vertices and noise and disturbance at their bounds with random signs;
``"adversarial"``
    for a target (observer, channel, sample ``k*``, sign): the initial state, that observer's
    noise and the disturbance that attain the worst case ``B`` of the certified bound at
    ``k*`` (:func:`adversarial_plan`: sign patterns of the rows, and a bang-bang disturbance
    inside each period that switches where the row's weight changes sign); other observers'
    noise is random.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from glocal_verify.analysis.sampled.loop import implementation_of, sampled_matrices
from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.certified_rows import exact_to_float
from glocal_verify.simulation.certified_thresholds import CertifiedThresholds
from glocal_verify.simulation.escape import EscapeRun
from glocal_verify.simulation.sampled_attack import SampledAttack
from glocal_verify.simulation.switch_thresholds import SwitchThresholds

__all__ = ["Target", "AdversarialPlan", "adversarial_plan", "plan_of_escape", "RunBatch", "simulate_sampled"]


@dataclass(frozen=True, slots=True)
class Target:
    """Where an adversarial run pushes a residual to its worst case: ``sign * r_{k, j}`` of ``observer``."""

    observer: str
    channel: int
    sample: int
    sign: float = 1.0


@dataclass(frozen=True, slots=True)
class AdversarialPlan:
    """The worst-case uncertainty for one target.

    Attributes
    ----------
    target : Target or None
        None for a run given explicitly (:func:`plan_of_escape`).
    x0 : ndarray
        (2N,) initial state (``initial_state``) or initial estimation error of the target
        observer (``initial_error``).
    noise : mapping of str to ndarray
        Per planned detector, (L, p) its noise for the first L samples (random after).
    w : ndarray
        (L, 2N) the held disturbance's sampled effect for the first L samples.
    """

    target: Target | None
    x0: np.ndarray
    noise: Mapping[str, np.ndarray]
    w: np.ndarray


def _bang_bang(a: np.ndarray, b: np.ndarray, h: float, dbar: float) -> tuple[np.ndarray, np.ndarray]:
    """``(w_p, w_v)`` of the disturbance ``dbar sgn(a t + b)`` (t = time to the period's end),
    which maximises ``a w_p + b w_v`` (module docstring)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(a != 0, -b / np.where(a != 0, a, 1.0), -1.0)
    cross = (t0 > 0) & (t0 < h)
    sb = np.sign(b)
    sc = np.sign(a * h / 2 + b)
    wv = np.where(cross, sb * (2 * t0 - h), sc * h)
    wp = np.where(cross, sb * (t0 * t0 - h * h / 2), sc * h * h / 2)
    return dbar * wp, dbar * wv


def adversarial_plan(thresholds: CertifiedThresholds, target: Target, system: System) -> AdversarialPlan:
    """The initial state, noise and disturbance attaining the certified worst case at ``target`` (module docstring)."""
    th = thresholds
    det = {o.name: o for o in th.detectors}[target.observer]
    k, j, sg = target.sample, target.channel, target.sign
    rows = th.observers[target.observer].rows
    if rows is None or rows.mid.shape[0] <= k:
        from glocal_verify.numerics.certified_rows import certified_rows

        rows = certified_rows(det.F, det.Ce, k + 1)
    ell = rows.mid[: k + 1, j, :]  # (k+1, n)
    model = th.model
    P = exact_to_float(det.Px if model.initial == "state" else det.Pe)[0]
    x0 = sg * model.box * np.sign(ell[k] @ P)
    Kn = exact_to_float(det.Kn)[0]
    Dn = exact_to_float(det.Dn)[0]
    nbar = model.noise(det.channels)
    rev = ell[:k][::-1]  # row k-1-i at position i
    noise = np.zeros((k + 1, len(det.channels)))
    noise[:k] = -sg * nbar[None, :] * np.sign(rev @ Kn)
    noise[k] = sg * nbar * np.sign(Dn[j])
    n = system.n
    w = np.zeros((k, 2 * n))
    if model.disturbance > 0 and k:
        g = sg * (rev @ exact_to_float(det.Gw)[0])
        wp, wv = _bang_bang(g[:, :n], g[:, n:], th.period, model.disturbance)
        w[:, :n], w[:, n:] = wp, wv
    return AdversarialPlan(target, x0, {target.observer: noise}, w)


def plan_of_escape(run: EscapeRun, period: float) -> AdversarialPlan:
    """An explicit run from :func:`~glocal_verify.simulation.escape.escape_run` (its held disturbance as ``w``)."""
    h = period
    w = np.hstack([h * h / 2 * run.d, h * run.d])
    return AdversarialPlan(None, run.x0, dict(run.noise), w)


class _Plans:
    """The planned runs of one chunk as dense arrays (per detector and sample)."""

    def __init__(self, plans: Sequence[AdversarialPlan], names: Sequence[str], n2: int) -> None:
        B = len(plans)
        self.noise: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for name in names:
            idx = np.array([i for i, p in enumerate(plans) if name in p.noise], dtype=int)
            if not len(idx):
                continue
            L = max(len(plans[i].noise[name]) for i in idx)
            p_ = plans[idx[0]].noise[name].shape[1]
            arr = np.full((L, p_, len(idx)), np.nan)
            for c, i in enumerate(idx):
                arr[: len(plans[i].noise[name]), :, c] = plans[i].noise[name]
            self.noise[name] = (idx, arr, np.array([len(plans[i].noise[name]) - 1 for i in idx]))
        L = max((len(p.w) for p in plans), default=0)
        self.w = np.zeros((L, n2, B))
        self.w_ok = np.zeros((L, B), dtype=bool)
        for i, p in enumerate(plans):
            self.w[: len(p.w), :, i] = p.w
            self.w_ok[: len(p.w), i] = True
        self.obs = np.array([p.target.observer if p.target else "" for p in plans], dtype=object)
        self.sample = np.array([p.target.sample if p.target else -1 for p in plans], dtype=int)
        self.channel = np.array([p.target.channel if p.target else 0 for p in plans], dtype=int)

    def apply_noise(self, noise: np.ndarray, name: str, k: int) -> None:
        got = self.noise.get(name)
        if got is None:
            return
        idx, arr, last = got
        if k < len(arr):
            live = k <= last
            noise[:, idx[live]] = arr[k][:, live]

    def apply_w(self, w: np.ndarray, k: int) -> None:
        if k < len(self.w):
            ok = self.w_ok[k]
            w[:, ok] = self.w[k][:, ok]


@dataclass(frozen=True, slots=True)
class RunBatch:
    """Outcome of a batch of sampled runs.

    Attributes
    ----------
    kind : str
    runs : int
    max_ratio : mapping of str to ndarray
        Per detector, per run: the largest ``|r_{k,j}| / theta_{k,j}`` before the run's switch
        (the central one after it too, against its post-switch threshold).
    peak : mapping of str to ndarray
        Per detector, (K, q): the largest ``|r_{k,j}|`` over the runs before their switch.
    first_alarm : mapping of str to ndarray
        Per detector, per run: first sample above the threshold (-1: none); the central one's
        counts before the switch only.
    switch : ndarray
        Per run: the switch sample (-1: no switch).
    central_alarm : ndarray
        Per run: the central observer's first sample above its post-switch threshold (-1: none).
    traces : mapping of str to ndarray
        Residuals of the first runs, (K, q, runs kept), for figures.
    targets : tuple of Target
        The adversarial targets, one per run (``kind == "adversarial"``).
    target_ratio : ndarray or None
        Adversarial runs: ``|r| / theta`` at each run's target (1 would be the threshold itself).
    """

    kind: str
    runs: int
    max_ratio: Mapping[str, np.ndarray]
    peak: Mapping[str, np.ndarray]
    first_alarm: Mapping[str, np.ndarray]
    switch: np.ndarray
    central_alarm: np.ndarray
    traces: Mapping[str, np.ndarray] = field(default_factory=dict)
    targets: tuple[Target, ...] = ()
    target_ratio: np.ndarray | None = None

    @property
    def crossings(self) -> dict[str, int]:
        """Per detector: runs whose residual went above its threshold (before the switch)."""
        return {k: int(np.sum(v >= 0)) for k, v in self.first_alarm.items()}


def simulate_sampled(
    system: System,
    thresholds: CertifiedThresholds,
    runs: int,
    *,
    kind: str = "random",
    seed: int = 0,
    attack: SampledAttack | None = None,
    size: float | None = None,
    mode: str | None = None,
    switch_thresholds: SwitchThresholds | None = None,
    targets: Sequence[Target] | None = None,
    plans: Sequence[AdversarialPlan] | None = None,
    keep_traces: int = 0,
    chunk: int | None = None,
) -> RunBatch:
    """Simulate ``runs`` runs of Algorithm 1 on the sampled implementation (module docstring).

    Parameters
    ----------
    system : System
    thresholds : CertifiedThresholds
        The detectors and their thresholds (its horizon is the runs').
    runs : int
    kind : str
        ``"random"``, ``"vertex"``, ``"adversarial"`` (needs ``targets``, one per run) or
        ``"given"`` (needs ``plans``, one per run).
    seed : int
    attack : SampledAttack, optional
        Attack-free without it.
    size : float, optional
        The attack's size (default its amplitude).
    mode : str, optional
        The safe mode a local alarm switches to (default: the spec's ``switching.mode``; no
        switch without one).
    switch_thresholds : SwitchThresholds, optional
        The central post-switch thresholds, for every switch sample a run may take.
    keep_traces : int
        Keep the residuals of this many runs.
    chunk : int, optional
        Runs per batch of columns (default 2000, 250 for adversarial runs, whose plans are
        held as dense arrays).
    """
    if kind not in ("random", "vertex", "adversarial", "given"):
        raise ModelError(f"unknown kind of runs {kind!r} (expected random, vertex, adversarial or given)")
    if kind == "adversarial" and (targets is None or len(targets) != runs):
        raise ModelError("adversarial runs need one target per run")
    if kind == "given" and (plans is None or len(plans) != runs):
        raise ModelError("given runs need one plan per run")
    th = thresholds
    chunk = chunk if chunk is not None else (250 if kind == "adversarial" else 2000)
    impl = implementation_of(system)
    h = th.period
    K = th.horizon
    n = system.n
    model = th.model
    Phi1, Gam = sampled_matrices(system, "normal", impl)
    q_mode = mode if mode is not None else (system.spec.switching.mode if system.spec.switching is not None else None)
    dPhi = (sampled_matrices(system, q_mode, impl)[0] - Phi1) if q_mode is not None else None
    dets = [o for o in th.detectors if o.name in th.observers]
    mats = {o.name: o.floats() for o in dets}
    local = [o.name for o in dets if o.kind == "local"]
    rng = np.random.default_rng(seed)
    U = attack.inputs(K, size) if attack is not None else None
    act = system.idx(attack.actuators) if attack is not None else []
    jump = np.real((attack.amplitude if size is None else size) * attack.x0) if attack is not None else None
    ka = attack.start if attack is not None else -1
    d = impl.switch_delay
    out_ratio = {o.name: np.zeros(runs) for o in dets}
    out_first = {o.name: np.full(runs, -1) for o in dets}
    out_peak = {o.name: np.zeros((K, len(o.channels))) for o in dets}
    out_switch = np.full(runs, -1)
    out_central = np.full(runs, -1)
    out_target = np.full(runs, np.nan) if kind == "adversarial" else None
    traces = {o.name: np.zeros((K, len(o.channels), keep_traces)) for o in dets} if keep_traces else {}
    thetas = {o.name: th.observers[o.name].theta for o in dets}
    sig = {o.name: model.sigma(o.channels) for o in dets}
    nb = {o.name: model.noise(o.channels) for o in dets}
    for c0 in range(0, runs, chunk):
        B = min(chunk, runs - c0)
        cols = slice(c0, c0 + B)
        if kind == "adversarial" and targets is not None:
            chunk_plans = [adversarial_plan(th, t, system) for t in targets[c0 : c0 + B]]
        elif kind == "given" and plans is not None:
            chunk_plans = list(plans[c0 : c0 + B])
        else:
            chunk_plans = []
        pl = _Plans(chunk_plans, [o.name for o in dets], 2 * n) if chunk_plans else None
        # initial states and observer states
        if kind in ("random", "given"):
            X = rng.uniform(-model.box, model.box, (2 * n, B)) if model.initial == "state" else rng.uniform(-1, 1, (2 * n, B))
        else:
            X = model.box * rng.choice([-1.0, 1.0], (2 * n, B)) if model.initial == "state" else rng.choice([-1.0, 1.0], (2 * n, B))
        E0: dict[str, np.ndarray | None] = {o.name: None for o in dets}
        if chunk_plans and model.initial == "state":
            X = np.stack([p.x0 for p in chunk_plans], axis=1)
        if model.initial == "error":
            for o in dets:
                E0[o.name] = model.box * (rng.uniform(-1, 1, (2 * n, B)) if kind == "random" else rng.choice([-1.0, 1.0], (2 * n, B)))
            for i, p in enumerate(chunk_plans):
                if p.target is not None:
                    E0[p.target.observer][:, i] = p.x0  # type: ignore[index]
        if jump is not None and ka == 0:
            X = X + jump[:, None]
        Z: dict[str, np.ndarray] = {}
        noise0: dict[str, np.ndarray] = {}
        for o in dets:
            f = mats[o.name]
            noise0[o.name] = _noise(rng, kind, nb[o.name], sig[o.name], B)
            if pl is not None:
                pl.apply_noise(noise0[o.name], o.name, 0)
            if model.initial == "state":
                Z[o.name] = np.zeros((o.order, B))
            else:
                rows_e = list(o.estimate_rows)
                est = X[rows_e] - E0[o.name][rows_e]  # type: ignore[index]
                # central: z = x^; a UIO: z = x^ - H y_0
                Z[o.name] = est if o.kind == "central" else est - exact_to_float(o.Pn)[0] @ (f["C"] @ X + noise0[o.name])
        switch = np.full(B, -1)
        first = {o.name: np.full(B, -1) for o in dets}
        calarm = np.full(B, -1)
        ratio = {o.name: np.zeros(B) for o in dets}
        for k in range(K):
            if jump is not None and k == ka and ka > 0:
                X = X + jump[:, None]
            switched = (switch >= 0) & (switch <= k)
            for o in dets:
                f = mats[o.name]
                nz = noise0[o.name] if k == 0 else _noise(rng, kind, nb[o.name], sig[o.name], B)
                if k and pl is not None:
                    pl.apply_noise(nz, o.name, k)
                y = f["C"] @ X + nz
                r = f["Ry"] @ y - f["Rz"] @ Z[o.name]
                Z[o.name] = f["Fo"] @ Z[o.name] + f["Go"] @ y
                thk = thetas[o.name][k][:, None]
                ar = np.abs(r)
                if o.kind == "central" and switch_thresholds is not None and np.any(switched):
                    thk = np.broadcast_to(thk, ar.shape).copy()
                    for col in np.flatnonzero(switched):
                        s_ = int(switch[col])
                        if s_ in switch_thresholds.theta:
                            thk[:, col] = switch_thresholds.theta[s_][k - s_]
                        else:
                            thk[:, col] = np.inf
                    over = np.any(ar > thk, axis=0)
                    new = switched & over & (calarm < 0)
                    calarm[new] = k
                live = ~switched
                rt = np.max(ar / np.where(thk > 0, thk, np.inf), axis=0)
                ratio[o.name] = np.maximum(ratio[o.name], np.where(live | (o.kind == "central"), rt, 0.0))
                over = np.any(ar > thk, axis=0) & live
                hit = over & (first[o.name] < 0)
                first[o.name][hit] = k
                if np.any(live):
                    out_peak[o.name][k] = np.maximum(out_peak[o.name][k], ar[:, live].max(axis=1))
                if pl is not None and out_target is not None:
                    sel = np.flatnonzero((pl.obs == o.name) & (pl.sample == k))
                    if len(sel):
                        tb = np.broadcast_to(thk, ar.shape)
                        out_target[c0 + sel] = ar[pl.channel[sel], sel] / tb[pl.channel[sel], sel]
                if keep_traces and c0 < keep_traces:
                    m = min(B, keep_traces - c0)
                    traces[o.name][k, :, c0 : c0 + m] = r[:, :m]
            # Algorithm 1, lines 3-5: the first local alarm schedules the switch
            if dPhi is not None and local:
                alarm = np.zeros(B, dtype=bool)
                for nm in local:
                    alarm |= first[nm] == k
                new = alarm & (switch < 0)
                switch[new] = k + d
            # the plant
            Xn = Phi1 @ X
            if dPhi is not None and np.any(switched):
                Xn[:, switched] += dPhi @ X[:, switched]
            if U is not None and k >= ka:
                Xn += (Gam[:, act] @ U[k])[:, None]
            Xn += _disturbance(rng, kind, model.disturbance, h, n, B, pl, k)
            X = Xn
        for o in dets:
            out_ratio[o.name][cols] = ratio[o.name]
            out_first[o.name][cols] = first[o.name]
        out_switch[cols] = switch
        out_central[cols] = calarm
    return RunBatch(kind, runs, out_ratio, out_peak, out_first, out_switch, out_central, traces, tuple(targets or ()), out_target)


def _noise(rng: np.random.Generator, kind: str, nbar: np.ndarray, sigma: np.ndarray, B: int) -> np.ndarray:
    p = len(nbar)
    if kind in ("random", "given"):
        out = rng.uniform(-1.0, 1.0, (p, B)) * nbar[:, None]
    else:
        out = rng.choice([-1.0, 1.0], (p, B)) * nbar[:, None]
    if np.any(sigma > 0):
        out = out + rng.standard_normal((p, B)) * sigma[:, None]
    return out


def _disturbance(rng: np.random.Generator, kind: str, dbar: float, h: float, n: int, B: int, plans: _Plans | None, k: int) -> np.ndarray:
    if dbar <= 0:
        return np.zeros((2 * n, 1))
    d = rng.uniform(-dbar, dbar, (n, B)) if kind in ("random", "given") else dbar * rng.choice([-1.0, 1.0], (n, B))
    w = np.vstack([h * h / 2 * d, h * d])
    if plans is not None:
        plans.apply_w(w, k)
    return w
