"""Limits a simulation checks before it allocates or steps: samples, bytes and internal steps.

The estimates come from the spec alone (horizon, step, sizes, the largest eigenvalue of each
Laplacian), so a run that would exhaust memory or take hours is refused at once with one line
giving the estimate; :func:`allow_large` lifts the limits for the runs inside it (the CLI's
``--allow-large``).

:func:`refuse` is the one refusal of the package: every run refused for its size (a
simulation, certified thresholds, a command over its time and memory limits in
:func:`glocal_verify.conditions.cost.check_limits`, a sweep) raises :class:`SizeLimitError`
there, unless large runs are allowed.
"""

from __future__ import annotations

import contextlib
import math
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from glocal_verify import config
from glocal_verify.errors import ArgumentError, ModelError
from glocal_verify.model import System
from glocal_verify.spec.arguments import real_arg
from glocal_verify.spec.types import SystemSpec

__all__ = [
    "RHO_MAX",
    "SizeLimitError",
    "refuse",
    "THRESHOLD_ARRAYS",
    "SizeEstimate",
    "estimate_size",
    "estimate_threshold_size",
    "threshold_samples",
    "samples_over",
    "detector_work",
    "check_size",
    "SIMULATION_KNOBS",
    "THRESHOLD_KNOBS",
    "check_stiffness",
    "allow_large",
    "horizon_and_step",
]

#: largest rho = h_int * nu of one internal step of the modal propagator (the Taylor terms of the
#: observer input then stay below e^2 times the state norm: at most a few ulps of cancellation)
RHO_MAX = 2.0


#: set by :func:`allow_large` for the simulations run inside its ``with`` block
_ALLOW_LARGE: ContextVar[bool] = ContextVar("glocal_verify_allow_large", default=False)


class SizeLimitError(ModelError):
    """A run whose estimate exceeds a size limit (:func:`refuse`): one line with the estimate.

    Attributes
    ----------
    estimate : object or None
        The estimate refused (a :class:`SizeEstimate`, a ``CostEstimate`` of :mod:`glocal_verify.conditions.cost`).
    limits : object or None
        The limits it exceeds (``Limits`` of :mod:`glocal_verify.conditions.cost`), when they are a value.
    """

    def __init__(self, message: str, estimate: Any = None, limits: Any = None) -> None:
        super().__init__(message)
        self.estimate = estimate
        self.limits = limits


def refuse(message: str, *, allow: bool | None = None, estimate: Any = None, limits: Any = None) -> None:
    """Refuse a run found above a size limit, unless large runs are allowed: the one refusal path.

    Parameters
    ----------
    message : str
        The one line: what, the estimate, the limits and the ways out.
    allow : bool, optional
        Allow it anyway (``--allow-large``); default: whether :func:`allow_large` is in force.
    estimate, limits : object, optional
        Kept on the error.

    Raises
    ------
    SizeLimitError
        Unless allowed.
    """
    if _ALLOW_LARGE.get() if allow is None else allow:
        return
    raise SizeLimitError(message, estimate, limits)


# --------------------------------------------------------------------------------------------
# size limits


@dataclass(frozen=True, slots=True)
class SizeEstimate:
    """Samples :math:`\\lfloor T/h \\rfloor + 1` and bytes a simulation would store (:func:`estimate_size`)."""

    samples: float
    bytes: float

    def describe(self) -> str:
        """One line, e.g. ``1e+18 samples, about 3.2e+08 GiB`` (the samples alone when no bytes are counted)."""
        if self.bytes <= 0:
            return f"{self.samples:.3g} samples"
        return f"{self.samples:.3g} samples, about {self.bytes / 1024**3:.3g} GiB"


def estimate_size(n_agents: int, horizon: float, step: float, *, channels: int | None = None, record_states: bool = True, dim: int | None = None, batch: int = 1) -> SizeEstimate:
    """Estimate, before allocating, what a simulation stores: 8 bytes times (samples x
    (2 x 2N stored states, counted twice for the modal back-transformation, + residual channels
    + 3) + 3 x dim x batch for the propagated state and two working copies).

    Parameters
    ----------
    n_agents : int
        N (2N plant states).
    horizon, step : float
        T and h.
    channels : int, optional
        Residual components per sample (default 2N).
    record_states : bool
        Whether the plant states are stored.
    dim : int, optional
        Augmented state dimension (default 4N).
    batch : int
        Initial states propagated together.
    """
    n2 = 2 * n_agents
    ratio = horizon / step
    samples = float(math.floor(ratio + 1e-9) + 1) if math.isfinite(ratio) else math.inf
    per = (2 * n2 if record_states else 0) + (n2 if channels is None else channels) + 3
    d = 2 * n2 if dim is None else dim
    return SizeEstimate(samples, 8.0 * (samples * per + 3.0 * d * batch))


#: float64 arrays of shape (K, q, d + 2) the certified thresholds of one detector with q channels
#: and a d-dimensional error keep at once (its rows, their enclosures, the noise, disturbance
#: and Gaussian sums); measured 4.7 on paper19's sampled deployment
THRESHOLD_ARRAYS = 5


def samples_over(horizon: float, step: float) -> int:
    """Samples ``floor(T / h) + 1`` of T seconds every h seconds, capped at 2^62 (an absurd
    ratio of a spec stays an int that every limit refuses).

    Parameters
    ----------
    horizon, step : float
    """
    ratio = horizon / step if step > 0 else math.inf
    return int(min(math.floor(ratio + 1e-9), 2**62)) + 1 if math.isfinite(ratio) else 2**62


def threshold_samples(horizon: float, period: float) -> int:
    """Samples K = floor(T / h) + 1 of a deployment's certified thresholds over T seconds.

    Parameters
    ----------
    horizon, period : float
        T > 0 and h > 0, finite (checked: :class:`~glocal_verify.errors.ArgumentError`).
    """
    T = real_arg("horizon", horizon, 0.0)
    h = real_arg("period", period, 0.0)
    if not (T > 0.0 and h > 0.0):
        raise ArgumentError(f"horizon and period: expected positive seconds, got {T:g} and {h:g}")
    return samples_over(T, h)


def detector_work(spec: SystemSpec) -> int:
    """:math:`\\sum_o q_o (d_o + 2)` of the sampled deployment's detectors, read from the spec
    alone (the (q, d) of :func:`estimate_threshold_size` before any detector is built): the
    central observer's channels times 2N + 2, and for a local observer twice its measured
    agents (the spec's lists, else the centre and its neighbours inside the cluster) times
    2 n_i + 2.

    Parameters
    ----------
    spec : SystemSpec
    """
    neighbours: dict[object, set[object]] = {}
    for e in spec.edges:
        neighbours.setdefault(e.u, set()).add(e.v)
        neighbours.setdefault(e.v, set()).add(e.u)
    total = (len(spec.monitor.positions) + len(spec.monitor.velocities)) * (2 * len(spec.nodes) + 2)
    for c in spec.clusters:
        members = set(c.nodes)
        for o in c.observers:
            if o.positions is None and o.velocities is None:
                q = 2 * (1 + len(neighbours.get(o.center, set()) & members))
            else:
                q = len(o.positions or ()) + len(o.velocities or ())
            total += q * (2 * len(c.nodes) + 2)
    return total


def estimate_threshold_size(samples: int, shapes: list[tuple[int, int]]) -> SizeEstimate:
    """What the certified thresholds of detectors of ``shapes`` (channels q, error dimension d)
    store over ``samples`` samples: :data:`THRESHOLD_ARRAYS` x 8 K sum q (d + 2) bytes.

    Parameters
    ----------
    samples : int
        K.
    shapes : list of (int, int)
        (q, d) of every detector.
    """
    per = sum(q * (d + 2) for q, d in shapes)
    return SizeEstimate(float(samples), 8.0 * THRESHOLD_ARRAYS * float(samples) * per)


#: what a refused run may change, by what it is (:func:`check_size`)
SIMULATION_KNOBS = "shorten simulation.horizon, enlarge simulation.step"
THRESHOLD_KNOBS = "shorten simulation.horizon, lengthen implementation.period"


def check_size(est: SizeEstimate, *, allow: bool | None = None, what: str = "simulation", knobs: str = SIMULATION_KNOBS) -> None:
    """Raise :class:`SizeLimitError` (one line with the estimate, :func:`refuse`) above
    ``simulation_max_samples`` (:mod:`glocal_verify.config`) samples or ``simulation_max_bytes`` (:mod:`glocal_verify.config`) bytes, unless ``allow`` (default: inside
    :func:`allow_large`).

    Parameters
    ----------
    est : SizeEstimate
    allow : bool, optional
    what : str
        What is refused, for the message (``"simulation"``, ``"certified thresholds"``).
    knobs : str
        The spec fields that make it smaller, for the message.
    """
    if est.samples > config.get("simulation_max_samples") or est.bytes > config.get("simulation_max_bytes"):
        refuse(
            f"{what} too large: {est.describe()} (limits {config.get('simulation_max_samples'):.0e} samples, {config.get('simulation_max_bytes') / 1024**3:g} GiB); "
            f"{knobs} or allow large runs (--allow-large)",
            allow=allow, estimate=est,
        )


def check_stiffness(system: System, horizon: float, step: float, *, allow: bool | None = None) -> int:
    """Estimate the internal steps of a run before any work; refuse a run that would take too long.

    The propagators split each output step h into ``ceil(nu h / RHO_MAX)`` sub-steps with
    ``nu >= max over modes and eigenvalues mu of sqrt(1 + (alpha mu)^2 + gamma^2)`` (a bound on
    the norm of the modal blocks), so the whole run costs about ``(horizon / h) * that`` steps.

    Parameters
    ----------
    system : System
    horizon, step : float
    allow : bool, optional
        Skip the refusal (default: inside :func:`allow_large`).

    Returns
    -------
    int
        The estimated number of internal steps.

    Raises
    ------
    SizeLimitError
        Above ``simulation_max_internal_steps`` (:mod:`glocal_verify.config`), one line with the estimate (:func:`refuse`).
    """
    nu = 0.0
    for q in system.modes:
        sp = system.spectrum(q)
        mu = float(np.max(np.abs(sp.values))) if sp.size else 0.0
        nu = max(nu, math.sqrt(1.0 + (system.alpha * mu) ** 2 + system.gamma**2))
    samples = max(1.0, float(horizon) / float(step))
    steps = samples * max(1.0, math.ceil(nu * float(step) / RHO_MAX))
    if steps > config.get("simulation_max_internal_steps"):
        refuse(
            f"simulation too stiff: about {steps:.3g} internal steps (||A|| ~ {nu:.3g} against step {step:g}; "
            f"limit {config.get('simulation_max_internal_steps'):.0e}); shorten the horizon, lower the gains or allow large runs (--allow-large)",
            allow=allow,
        )
    return int(min(steps, 2**62))


@contextlib.contextmanager
def allow_large() -> Iterator[None]:
    """Lift the size limits of :func:`simulate` for the simulations run inside the block."""
    token = _ALLOW_LARGE.set(True)
    try:
        yield
    finally:
        _ALLOW_LARGE.reset(token)


def horizon_and_step(system: System, horizon: float | None, step: float | None) -> tuple[float, float]:
    """The horizon T and output step h of a run: the arguments, else the spec's ``[simulation]``.

    Parameters
    ----------
    system : System
    horizon, step : float, optional

    Returns
    -------
    (T, h)

    Raises
    ------
    ModelError
        Unless both are positive and finite.
    """
    T = float(system.spec.simulation.horizon if horizon is None else horizon)
    h = float(system.spec.simulation.step if step is None else step)
    if not (h > 0 and T > 0 and math.isfinite(T) and math.isfinite(h)):
        raise ModelError(f"horizon {T} and step {h} must be positive and finite")
    return T, h
