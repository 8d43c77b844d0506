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

from glocal_verify.certificates.encode import cholesky_upper, q, schur_claim, vector
from glocal_verify.certificates.global_certificates import NoCertificate
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = ["detector_certificate", "sampled_certificate"]


def _jury(system: System, mode: str, c: Fraction, holds: bool) -> dict[str, Any]:
    Lq = system.laplacian_exact(mode)
    mu, U = np.linalg.eigh(np.array([[float(x) for x in row] for row in Lq]))
    if holds:
        gap = float(c) - float(mu[-1])
        if not gap > 0:  # pragma: no cover - a verdict bug
            raise NoCertificate("the largest eigenvalue of L_q is not below 2 gamma / (alpha h) in floating point")
        shift = Fraction(repr(gap / 2))
        return {"kind": "jury", "shift": q(shift), "R": cholesky_upper((float(c) - float(shift)) * np.eye(len(mu)) - np.array([[float(x) for x in row] for row in Lq]))}
    x = [Fraction(float(v)) for v in U[:, -1]]
    Lx = [sum((a * b for a, b in zip(row, x)), Fraction(0)) for row in Lq]
    if sum(a * b for a, b in zip(x, Lx)) < c * sum(v * v for v in x):
        raise NoCertificate("the rounded top eigenvector's Rayleigh quotient is below 2 gamma / (alpha h)")
    return {"kind": "rayleigh", "x": vector(system, x)}


def _uio(system: System, r: ConditionResult) -> dict[str, Any]:
    """``sampled-uio``: K1 = (T A_d - F) C^T of the designed observer (C selects distinct
    channels, so C C^T = I) and a Stein matrix of F; ``structure`` when the rank fails."""
    from glocal_verify.observers.sampled import DecouplingError, design_sampled_uio, sampled_cluster_model, to_float

    obs = next(o for o in system.observers(r.scope["cluster"]) if o.center == r.scope["observer"])
    if r.status.value == "fails":
        try:
            sampled_cluster_model(system, obs)
        except DecouplingError:
            return {"kind": "structure"}
        raise NoCertificate("sampled.local-uio fails without its rank condition failing: not certified yet")
    model = sampled_cluster_model(system, obs)
    F = design_sampled_uio(system, obs).F
    try:
        stein = schur_claim(np.asarray(to_float(F), dtype=float))
    except ValueError as exc:
        raise NoCertificate(str(exc)) from None
    return {"kind": "sampled-uio", "K1": _exact_rows((model.Abar - F) * model.C.transpose()), "stein": stein}


def detector_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``detector-stable`` (``detection.thresholds`` holds): the detector's gain and a Stein
    matrix of its exact error dynamics (central: on the consensus quotient, with its
    representatives)."""
    from glocal_verify.observers.sampled import consensus_quotient, design_sampled_central, design_sampled_uio, sampled_cluster_model, to_float

    name = str(r.scope["observer"])
    if r.status.value != "holds" or system.spec.implementation is None or system.spec.implementation.controller != "sampled":
        raise NoCertificate("only detection.thresholds holds of a sampled controller has a certificate")
    if name == "central":
        obs = design_sampled_central(system)
        _, _, reps = consensus_quotient(system)
        cert: dict[str, Any] = {"kind": "detector-stable", "reps": [str(system.labels[i]) for i in reps], "gain": _exact_rows(obs.Kn)}
    else:
        lo = next(o for o in system.observers() if f"{o.cluster}@{o.center}" == name)
        obs = design_sampled_uio(system, lo)
        model = sampled_cluster_model(system, lo)
        cert = {"kind": "detector-stable", "K1": _exact_rows((model.Abar - obs.F) * model.C.transpose())}
    try:
        cert["stein"] = schur_claim(np.asarray(to_float(obs.F), dtype=float))
    except ValueError as exc:
        raise NoCertificate(str(exc)) from None
    return cert


def _exact_rows(M: Any) -> list[list[str]]:
    return [[q(Fraction(int(x.p), int(x.q))) for x in row] for row in M.tolist()]


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
    if r.id == "sampled.local-uio" and impl.controller == "sampled":
        return _uio(system, r)
    if r.id == "sampled.zda" and r.status.value == "holds" and impl.controller == "sampled":
        free = [f for f in system.attacked if f not in set(system.monitored_velocities)]
        if free:  # at z0 = -1 the positions stay, the velocity answers its own held input only
            f = free[0]
            return {"kind": "sampled-zda", "z0": "-1", "x_position": {}, "x_velocity": {str(f): q(-h / (2 - gamma * h))}, "u0": {str(f): "1"}}
    raise NoCertificate(f"{r.id} {r.status.value} has no certificate yet (docs/certificates.md)")
