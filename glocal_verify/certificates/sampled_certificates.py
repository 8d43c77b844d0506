"""Certificates of the sampled implementation's verdicts (``[implementation]``, period h; the
checker's ``glocal_check.sampled`` states the mathematics): ``sampled.stability`` (Jury's test:
gamma h < 2 and c I - L_q > 0, c = 2 gamma / (alpha h), or a Rayleigh quotient at least c),
``sampled.no-aliasing`` and ``sampled.observability`` (the exact facts of the discretisation),
``sampled.zda`` (the ZDA at z0 = -1 of a sampled controller on an attacked agent whose velocity
is not monitored)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify.certificates.encode import q, vector
from glocal_verify.certificates.global_certificates import NoCertificate
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = ["sampled_certificate"]


def _jury(system: System, mode: str, c: Fraction, holds: bool) -> dict[str, Any]:
    Lq = system.laplacian_exact(mode)
    mu, U = np.linalg.eigh(np.array([[float(x) for x in row] for row in Lq]))
    if holds:
        gap = float(c) - float(mu[-1])
        if not gap > 0:  # pragma: no cover - a verdict bug
            raise NoCertificate("the largest eigenvalue of L_q is not below 2 gamma / (alpha h) in floating point")
        return {"kind": "jury", "shift": q(Fraction(repr(gap / 2)))}
    x = [Fraction(float(v)) for v in U[:, -1]]
    Lx = [sum((a * b for a, b in zip(row, x)), Fraction(0)) for row in Lq]
    if sum(a * b for a, b in zip(x, Lx)) < c * sum(v * v for v in x):
        raise NoCertificate("the rounded top eigenvector's Rayleigh quotient is below 2 gamma / (alpha h)")
    return {"kind": "rayleigh", "x": vector(system, x)}


def sampled_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """The certificate of a ``sampled.*`` verdict, or :class:`NoCertificate`."""
    impl = system.spec.implementation
    assert impl is not None
    h, gamma = impl.period, system.gamma_q
    if r.id in ("sampled.no-aliasing", "sampled.observability"):
        if r.id == "sampled.observability" and r.status.value == "fails":
            raise NoCertificate("sampled.observability fails at an aliasing period: the dimensions are not written as a certificate yet")
        return {"kind": "structure"}
    if r.id == "sampled.stability":
        if impl.controller == "continuous" or gamma * h >= 2:
            return {"kind": "structure"}
        return _jury(system, r.scope["mode"], 2 * gamma / (system.alpha_q * h), r.status.value == "holds")
    if r.id == "sampled.zda" and r.status.value == "holds" and impl.controller == "sampled":
        free = [f for f in system.attacked if f not in set(system.monitored_velocities)]
        if free:  # at z0 = -1 the positions stay, the velocity answers its own held input only
            f = free[0]
            return {"kind": "sampled-zda", "z0": "-1", "x_position": {}, "x_velocity": {str(f): q(-h / (2 - gamma * h))}, "u0": {str(f): "1"}}
    raise NoCertificate(f"{r.id} {r.status.value} has no certificate yet (docs/certificates.md)")
