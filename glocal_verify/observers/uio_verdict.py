"""Existence, design and certified verification of the local unknown-input observers: the rule of ``local.uio``.

For every cluster observer and every mode, the UIO of Chen, Patton & Zhang (1996) for the
cluster model (A^i, E^i, C_loc) must exist (rank(C E) = rank(E) and (C, A_1) detectable), be
designed (:func:`~glocal_verify.observers.uio.design_uio`, or the modal design of
:mod:`glocal_verify.observers.uio_modal_verdict` on large clusters) and be verified: the
decoupling and error residuals vanish at ``rtol`` and F is Hurwitz, certified for the exact
cluster model in numeric runs (``_uio_certificate``). Exact runs decide existence over Q
(:func:`~glocal_verify.observers.uio_existence.uio_existence_exact`); the design stays
numeric. One design per distinct cluster block is made and shared (``cache``).

The rule lives in this layer, above :mod:`glocal_verify.analysis`, because it designs the
observer it certifies.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
from typing import Any

import numpy as np

from glocal_verify.analysis.local.cluster_modal import state_rounding_bound
from glocal_verify.analysis.local.cases import (
    LocalCase,
    certificate_verdict,
    exact_A_float,
    exact_int,
    pencil_matrices_exact,
)
from glocal_verify.analysis.local.pencil import witness_number
from glocal_verify.derived import Kind
from glocal_verify.model import ClusterModel, LocalObserver, System
from glocal_verify.numerics.hurwitz import hurwitz_enclosure
from glocal_verify.numerics.pencil_exact import rank_bounds, rounding_error
from glocal_verify.numerics.rounding import EPS, gamma_bound
from glocal_verify.numerics.threads import single_threaded
from glocal_verify.numerics.tolerance import (
    DEFAULT_TOLERANCE,
    Decision,
    Tolerance,
)
from glocal_verify.observers.uio import design_uio
from glocal_verify.observers.uio_existence import (
    UIOExistence,
    cluster_detectability,
    uio_existence,
    uio_existence_exact,
)
from glocal_verify.observers.uio_modal_verdict import modal_applicable, uio_one_modal
from glocal_verify.results import Status, Verdict
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["uio_verdict"]

#: derived results this module keeps on the system (glocal_verify.derived)
_CLUSTER_BLOCK_DIGEST_KIND: Kind[str] = Kind("cluster-block-digest", __name__, "str")


def _structured_detectability(cm: ClusterModel, obs: LocalObserver, existence: UIOExistence, tol: Tolerance, w: dict[str, Any]) -> UIOExistence:
    """Cross-check the generic detectability of (C, A_1) with the structured test of
    :func:`glocal_verify.observers.uio_existence.cluster_detectability` (valid under (ii)); an undecided generic
    split is settled by it, a disagreement makes the verdict undecided."""
    if existence.rank_condition is not Status.HOLDS:
        return existence
    idx = {a: k for k, a in enumerate(cm.nodes)}
    got = cluster_detectability(cm.L, [idx[a] for a in cm.boundary], [idx[a] for a in obs.positions], tol)
    sd, p0, how = got.status, got.positions, got.by
    w["detectability"] = {"structured": sd.value, "by": how, "generic": existence.detectable.value}
    if sd is existence.detectable or sd is Status.UNDECIDED:
        return existence
    if existence.detectable is Status.UNDECIDED:
        mode = existence.unstable_mode
        if sd is Status.FAILS and p0 is not None:
            mode = (0j, np.concatenate([p0, np.zeros_like(p0)]).astype(complex))
        w["detectability"]["note"] = "the generic observable split was undecided; the structured test decides"
        return dataclasses.replace(existence, status=sd, detectable=sd, unstable_mode=mode)
    w["detectability"]["note"] = "the structured and the generic detectability tests disagree"
    return dataclasses.replace(existence, status=Status.UNDECIDED, detectable=Status.UNDECIDED)


def _uio_key(system: System, cm: ClusterModel, C: np.ndarray, obs: LocalObserver, tol: Tolerance, exact: bool, method: str = "auto") -> str:
    """Digest of everything the per-mode UIO verdict depends on (matrices by value, method).

    A^i = [[0, I], [-alpha L, -gamma I]] is a function of L[P_i, P_i], alpha and gamma, all
    in the key, so it is not hashed again; the digest of L is kept per cluster and mode on
    ``system.analysis`` (hashing the 2n x 2n A^i of every case cost seconds at n = 1333).
    """
    h = hashlib.sha256(method.encode())
    digest = _CLUSTER_BLOCK_DIGEST_KIND.get(system, (cm.name, cm.mode), lambda: hashlib.sha256(np.ascontiguousarray(cm.L).tobytes()).hexdigest())
    h.update(repr((cm.L.shape, digest)).encode())
    for M in (cm.E, C):
        h.update(repr(M.shape).encode())
        h.update(np.ascontiguousarray(M).tobytes())
    h.update(repr((cm.nodes, cm.boundary, obs.positions, obs.velocities, obs.poles, system.gamma, system.alpha, tol.rtol, tol.band, exact)).encode())
    if exact:
        h.update(repr((system.cluster_laplacian_exact(cm.name, cm.mode), system.alpha_q, system.gamma_q)).encode())
    else:
        # a numeric certificate proves its verdict for every exact A^i within the rounding
        # bound it used of fl(A^i): two modes with the same floats share it only when the
        # bound is the same (then it covers both exact blocks)
        h.update(repr(state_rounding_bound(system, cm.name, cm.mode)).encode())
    return h.hexdigest()


def _uio_one(
    system: System,
    case: LocalCase,
    mode: str,
    tol: Tolerance,
    exact: bool,
    cache: dict[str, Verdict] | None = None,
    method: str = "auto",
) -> Verdict:
    """The verdict of local.uio for one case in one mode (modal when it applies, else dense),
    a numeric non-holds certified through the rank condition or made undecided; shared
    through ``cache`` by every case and mode with the same key (:func:`_uio_key`)."""
    cm = system.cluster_model(case.model.name, mode)
    obs = case.observer
    C = cm.C(obs.positions, obs.velocities)
    key = _uio_key(system, cm, C, obs, tol, exact, method) if cache is not None else ""
    if cache is not None and key in cache:
        hit = cache[key]
        return dataclasses.replace(hit, witness=copy.deepcopy(dict(hit.witness)))
    got = uio_one_modal(system, cm, obs, C, mode, tol) if modal_applicable(cm, obs, exact, method) else None
    out = got if got is not None else _uio_one_uncached(system, case, cm, C, mode, tol, exact)
    if not exact and out.status is not Status.HOLDS:
        out = _uio_certify_negative(cm, C, out)
    if cache is not None:
        cache[key] = dataclasses.replace(out, witness=copy.deepcopy(dict(out.witness)))
    return out


def _uio_certificate(system: System, case: LocalCase, cm: ClusterModel, C: np.ndarray, mode: str, K1: np.ndarray) -> dict[str, Any]:
    """Certify that a UIO exists for the exact cluster model in ``mode`` from a numeric design.

    The UIO exists iff rank(C E) = rank(E) and (C, (I - h C) A) is detectable, h = E (C E)^+.
    C_loc and E^i are exact 0/1 matrices; when C E has orthonormal columns, (C E)^+ = (C E)^T
    and h = E (C E)^T is exact in floating point. The rank condition is certified by
    :func:`~glocal_verify.numerics.pencil_exact.rank_bounds`; detectability by the designed gain
    K1 itself: F_exact = (I - h C) A_exact - K1 C Hurwitz (a certificate that the unobservable
    modes are stable), with ||fl(F) - F_exact||_2 bounded by the rounding of A^i (rational
    differences), the rounding of the products (gamma_n bounds) and of the subtraction, and the
    eigenvalues enclosed by :func:`~glocal_verify.numerics.hurwitz.hurwitz_enclosure`.
    """
    E = cm.E
    n = E.shape[0]
    CE = C @ E
    out: dict[str, Any] = {"certified": False, "error_bound": None, "by": "rank bounds and Hurwitz enclosure of (I - hC)A - K1 C"}
    exact01 = bool(np.all(C == np.round(C)) and np.all(E == np.round(E)))
    bE, bCE = rank_bounds(E), rank_bounds(CE)
    if not (exact01 and bE.decided and bCE.decided and bE.lower == bCE.lower):
        out["note"] = f"rank condition not certified (rank E in [{bE.lower}, {bE.upper}], rank CE in [{bCE.lower}, {bCE.upper}])"
        return out
    if CE.shape[1] and not np.array_equal(CE.T @ CE, np.eye(CE.shape[1])):
        out["note"] = "C_loc E^i has no orthonormal columns: h = E (C E)^+ is not exact in floating point"
        return out
    h = E @ CE.T if CE.shape[1] else np.zeros((n, C.shape[0]))
    P = np.eye(n) - h @ C
    sub = LocalCase(cm, case.observer, case.kind, case.suspected, mode)
    A_ex, A, support = exact_A_float(system, sub)
    g = gamma_bound(2 * n)  # n eps / (1 - n eps)
    A1 = P @ A
    K1C = K1 @ C
    Fm = A1 - K1C
    dA = rounding_error(A, A_ex, support=support)
    delta = float(np.linalg.norm(P, 2)) * dA * (1 + 4 * EPS) + g * float(np.linalg.norm(np.abs(P) @ np.abs(A))) + g * float(np.linalg.norm(np.abs(K1) @ np.abs(C)))
    delta = (delta + EPS * float(np.linalg.norm(Fm))) * (1.0 + 8 * EPS)
    enc = hurwitz_enclosure(Fm, delta)
    out["error_bound"] = enc.radius
    out["spectral_abscissa_upper"] = enc.max_real_upper
    if enc.certified is True:
        out["certified"] = True
    else:
        out["note"] = (
            f"F = (I - hC)A - K1 C is not certified Hurwitz: max Re + enclosure radius = {enc.max_real_upper:.3g} "
            f"(radius {enc.radius:.3g}, ||fl F - F_exact|| <= {delta:.3g})"
        )
    return out


def _uio_certify_negative(cm: ClusterModel, C: np.ndarray, verdict: Verdict) -> Verdict:
    """A numeric ``fails`` of local.uio is certified only through the rank condition (exact 0/1
    matrices, :func:`~glocal_verify.numerics.pencil_exact.rank_bounds`); an unstable unobservable
    mode is a rank-loss claim that floating point cannot prove: undecided."""
    st, mg, w = verdict.status, verdict.margin, dict(verdict.witness)
    bE, bCE = rank_bounds(cm.E), rank_bounds(C @ cm.E)
    cert: dict[str, Any] = {"certified": False, "error_bound": max(bE.error_bound, bCE.error_bound)}
    if bE.decided and bCE.decided and bCE.lower < bE.lower:
        cert.update(certified=True, by="certified rank bounds: rank(C E) < rank(E)")
        w["certificate"] = cert
        return Verdict(Status.FAILS, margin=mg, witness=w)
    if st is Status.FAILS:
        cert["note"] = "the rank condition holds; an unstable unobservable mode (a rank loss of the PBH pencil) has no floating-point proof"
    else:
        cert["note"] = "existence or the numeric design could not be decided"
    w.setdefault("certificate", cert)
    return Verdict(Status.UNDECIDED, margin=mg, witness=w)


@single_threaded
def _uio_one_uncached(system: System, case: LocalCase, cm: ClusterModel, C: np.ndarray, mode: str, tol: Tolerance, exact: bool) -> Verdict:
    obs = case.observer
    w: dict[str, Any] = {}
    exact_status: Status | None = None
    if exact:
        sub = LocalCase(cm, obs, case.kind, case.suspected, mode)
        A, _, Cq = pencil_matrices_exact(system, sub)
        ee = uio_existence_exact(A, exact_int(cm.E), Cq)
        w["rank_condition"] = ee.rank_condition.value
        if ee.unobservable_dim >= 0:
            w["unobservable_dim"] = ee.unobservable_dim
            w["unobservable_charpoly"] = [str(c) for c in ee.unobservable_charpoly]
        if ee.status is Status.FAILS:
            if ee.rank_condition is Status.FAILS:
                w["unmeasured_boundary"] = [a for a in cm.boundary if a not in obs.velocities]
            else:
                roots = np.roots([float(c) for c in reversed(ee.unobservable_charpoly)])
                w["unstable_unobservable_modes"] = [witness_number(r, 9) for r in roots if r.real >= -1e-9]
        exact_status = ee.status
    existence = _structured_detectability(cm, obs, uio_existence(cm.A, cm.E, C, tol), tol, w)
    if exact_status is Status.FAILS or existence.status is not Status.HOLDS:
        if existence.rank_condition is Status.FAILS:
            w["unmeasured_boundary"] = [a for a in cm.boundary if a not in obs.velocities]
        if existence.unstable_mode is not None:
            lam, vec = existence.unstable_mode
            n = len(cm.nodes)
            vec = vec / vec[int(np.argmax(np.abs(vec)))]
            # full double precision; only exact zeros are left out
            w["unstable_unobservable_mode"] = {
                "eigenvalue": witness_number(lam, 9),
                "positions": {a: (complex(c).real if complex(c).imag == 0 else complex(c)) for a, c in zip(cm.nodes, vec[:n]) if c != 0},
                "velocities": {a: (complex(c).real if complex(c).imag == 0 else complex(c)) for a, c in zip(cm.nodes, vec[n:]) if c != 0},
            }
        w["unobservable_eigenvalues"] = [witness_number(m, 9) for m in existence.unobservable_eigenvalues]
        st = existence.status if exact_status is None else exact_status
        if st is Status.HOLDS:  # exact existence, numeric split undecided: design below
            pass
        else:
            margin = float(existence.margin) if math.isfinite(existence.margin) else 0.0
            return Verdict(st, margin=margin, witness=w)
    poles = None if obs.poles is None else [float(p) for p in obs.poles]
    try:
        _, d = design_uio(cm.A, cm.E, C, poles=poles, gamma=system.gamma, tol=tol, existence=existence if existence.status is Status.HOLDS else None)
    except Exception as exc:  # noqa: BLE001 - a design failure is a verdict, with its reason
        w["design_error"] = str(exc)
        return Verdict(Status.HOLDS if exact else Status.UNDECIDED, margin=float(existence.margin), witness=w)
    checks = {
        "decoupling": tol.decide(d["decoupling_residual"], 1.0),
        "error_free_of_state": tol.decide(d["error_residual"], 1.0),
    }
    hurwitz_ok = d["hurwitz"] is Status.HOLDS
    w.update(
        {
            "observable_dim": int(existence.split.Qo.shape[1]) if existence.split else 0,
            "unobservable_eigenvalues": [witness_number(m, 9) for m in existence.unobservable_eigenvalues],
            "poles": [witness_number(p, 9) for p in d["poles"]],
            "eigenvalues_F": [witness_number(p, 9) for p in sorted(d["eigenvalues"], key=lambda z: (z.real, z.imag))],
            "hurwitz_margin": d["hurwitz_margin"],
            "hurwitz_certificate": {"status": d["hurwitz"].value, "ratio": d["hurwitz_ratio"]},
            "decoupling_residual": d["decoupling_residual"],
            "error_residual": d["error_residual"],
        }
    )
    if d["notes"]:
        w["notes"] = list(d["notes"])
    design_ok = checks["decoupling"] is Decision.ZERO and checks["error_free_of_state"] is Decision.ZERO and hurwitz_ok
    if design_ok:
        if not exact:
            w["certificate"] = _uio_certificate(system, case, cm, C, mode, d["K1"])
            if not w["certificate"]["certified"]:
                return Verdict(Status.UNDECIDED, margin=float(d["hurwitz_margin"]), witness=w)
        return Verdict(Status.HOLDS, margin=float(d["hurwitz_margin"]), witness=w)
    w["verification_failed"] = [k for k, v in checks.items() if v is not Decision.ZERO] + ([] if hurwitz_ok else ["hurwitz"])
    # the observer exists (decided above); the numeric design did not verify
    return Verdict(Status.HOLDS if exact else Status.UNDECIDED, margin=float(d["hurwitz_margin"]), witness=w)


def uio_verdict(
    system: System,
    case: LocalCase,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact: bool = False,
    *,
    cache: dict[str, Verdict] | None = None,
    method: str = "auto",
) -> Verdict:
    """The rule of local.uio for one case over every mode (the checker of
    :mod:`glocal_verify.conditions.local` wraps it; the audit and the placement call it too).

    Holds when a UIO exists and is designed and verified in every mode (F_q Hurwitz, certified
    for the exact cluster model in numeric runs), fails when it fails in some mode, undecided
    otherwise. Per mode: :func:`~glocal_verify.observers.uio_modal_verdict.uio_one_modal` on
    large clusters, else the dense existence test, design and certificate; a numeric failure
    is certified only through the rank condition.

    Parameters
    ----------
    system : System
    case : LocalCase
    tol : Tolerance
    exact : bool
        Decide existence over Q (the design stays numeric).
    cache : dict, optional
        Per-mode results keyed by a digest of everything they depend on (cluster matrices
        A^i, E^i, L[P_i, P_i] and C_loc by value, observer, gains, tolerance, exactness):
        the suspected sets of one observer, and the modes that leave the cluster block
        unchanged (a safe mode usually changes one cluster), share one design.
    method : str
        ``auto`` (default: the modal design and certificate of
        :mod:`glocal_verify.observers.uio_modal_verdict` for numeric checks of clusters of at least
        ``modal_min_agents`` (:mod:`glocal_verify.config`) agents with default
        poles, the dense one otherwise), ``modal`` (whenever it applies) or ``dense``.
    """
    per_mode: dict[str, Any] = {}
    statuses = []
    margins = []
    for mode in system.modes:
        one = _uio_one(system, case, mode, tol, exact, cache, method)
        st, mg, w = one.status, one.margin, dict(one.witness)
        if "eigenvalues_F" in w:
            bnd = set(system.cluster_model(case.model.name, mode).boundary) if mode != case.mode else set(case.model.boundary)
            inv = [a for a in case.suspected if a in bnd]
            if inv:
                w["attack_invisible"] = inv
        per_mode[mode] = {"status": st.value, **w}
        statuses.append(st)
        margins.append(math.inf if mg is None else float(mg))
    if any(s is Status.FAILS for s in statuses):
        status = Status.FAILS
    elif any(s is Status.UNDECIDED for s in statuses):
        status = Status.UNDECIDED
    else:
        status = Status.HOLDS
    witness: dict[str, Any] = {"normal": per_mode[NORMAL_MODE]}
    if len(system.modes) > 1:
        witness["modes"] = {m: v for m, v in per_mode.items() if m != NORMAL_MODE}
        bad = [m for m, s in zip(system.modes, statuses) if s is not Status.HOLDS]
        if bad:
            witness["failing_modes"] = bad
    margin = min(margins) if margins else math.inf
    if not exact:
        certs = [(m, v["certificate"]) for m, v in per_mode.items() if isinstance(v.get("certificate"), dict)]
        bounds = [c["error_bound"] for _, c in certs if c.get("error_bound") is not None]
        notes = [f"{m}: {c['note']}" for m, c in certs if c.get("note")]
        witness["certificate"] = {"error_bound": max(bounds) if bounds else None, "note": "; ".join(notes) if status is Status.UNDECIDED else ""}
    return certificate_verdict(status, margin, witness, exact=exact)
