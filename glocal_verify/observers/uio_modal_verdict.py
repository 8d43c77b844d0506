"""local.uio on large clusters: the verdict of one observer and mode from the modal design.

The dense check (:mod:`glocal_verify.observers.uio_verdict`) costs an
observable split, an ordered Schur form, a Hurwitz certificate from a nonsymmetric
eigen-decomposition with its SVD, all of size 2 n. Here the same questions are answered from
one ``eigh`` of the interior block L_II (:func:`glocal_verify.analysis.local.cluster_modal.interior_modes`,
shared by every observer and every mode with the same cluster block):

* the rank condition rank(C E) = rank(E) as before (exact 0/1 matrices, certified ranks);
* detectability by the split of the small moved block (the boundary's double integrators and
  the slow overdamped modes) cross-checked with the structured PBH test
  :func:`~glocal_verify.observers.uio_existence.cluster_detectability`;
* the design of :func:`~glocal_verify.observers.uio_modal.design_uio_modal` (the default poles,
  the same eigenvalues of F as the dense design);
* ``holds`` only with the certificate of :func:`~glocal_verify.observers.uio_modal.modal_certificate`:
  F_exact = (I - h C) A_exact - K1 C has no eigenvalue with Re >= 0, proved by a residual
  bound in the modal basis, a lower bound of its smallest singular value and a resolvent
  bound of the block triangular modal form (rounding of A^i from the exact rationals
  included). When that bound does not separate, the result is ``undecided`` with a note.

The witness has the keys of the dense check; ``certificate.by`` names the modal certificate.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from glocal_verify import config
from glocal_verify.analysis.local.cluster_modal import interior_modes, state_rounding_bound
from glocal_verify.analysis.local.cluster_pencil import intra_neighbours, zero_forcing_closure
from glocal_verify.analysis.local.pencil import witness_number
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import ClusterModel, LocalObserver, System
from glocal_verify.numerics.pencil_exact import rank_bounds
from glocal_verify.numerics.threads import single_threaded
from glocal_verify.numerics.tolerance import Decision, Tolerance
from glocal_verify.observers.uio_existence import cluster_detectability, decoupling
from glocal_verify.observers.uio_modal import design_uio_modal
from glocal_verify.results import Status, Verdict

__all__ = ["UIO_METHODS", "modal_applicable", "uio_one_modal"]

#: values of the checker option ``local_uio_method``
UIO_METHODS = ("auto", "modal", "dense")


def modal_applicable(cm: ClusterModel, obs: LocalObserver, exact: bool, method: str) -> bool:
    """Whether the modal path is tried: numeric mode, default poles, and ``method`` ``modal``
    or ``auto`` with at least ``modal_min_agents`` (:mod:`glocal_verify.config`) agents.

    Parameters
    ----------
    cm : ClusterModel
    obs : LocalObserver
    exact : bool
    method : str
        One of :data:`UIO_METHODS`.
    """
    if exact or obs.poles is not None or method == "dense":
        return False
    return method == "modal" or len(cm.nodes) >= config.get("modal_min_agents")


@single_threaded
def uio_one_modal(system: System, cm: ClusterModel, obs: LocalObserver, C: np.ndarray, mode: str, tol: Tolerance) -> Verdict | None:
    """The per-mode verdict of local.uio by the modal method (status, margin, witness).

    None when the method does not apply (the rank condition does not hold, so the cheap
    dense path reports it; or the interior block is singular); the caller then uses the dense
    method.

    Parameters
    ----------
    system : System
    cm : ClusterModel
        The cluster in ``mode``.
    obs : LocalObserver
    C : ndarray
        C_loc of the observer.
    mode : str
    tol : Tolerance
    """
    dec = decoupling(cm.E, C, tol)
    h = dec.h
    if dec.status is not Status.HOLDS or h is None:
        return None
    # the certificate needs h = E (C E)^T exact: C E with orthonormal columns, certified ranks
    CE = C @ cm.E
    bE, bCE = rank_bounds(cm.E), rank_bounds(CE)
    if not (bE.decided and bCE.decided and bE.lower == bCE.lower) or (CE.shape[1] and not np.array_equal(CE.T @ CE, np.eye(CE.shape[1]))):
        return None
    idx = {a: k for k, a in enumerate(cm.nodes)}
    n = len(cm.nodes)
    pos = [idx[a] for a in obs.positions]
    vel = [idx[a] for a in obs.velocities]
    modes = interior_modes(system, cm.name, mode)
    dA = state_rounding_bound(system, cm.name, mode)
    try:
        md = design_uio_modal(cm.A_sparse, modes, pos, vel, alpha=system.alpha, gamma=system.gamma, tol=tol, input_error=dA)
    except NotApplicableError:
        return None
    w: dict[str, Any] = {}
    bnd = [idx[a] for a in cm.boundary]
    certified = md.detectable is Status.HOLDS and md.certificate is not None and md.certificate.certified
    det = md.detectable
    p0: np.ndarray | None = None
    if certified and len(zero_forcing_closure(intra_neighbours(cm.L), set(pos), set(bnd))) < n:
        # zero forcing does not prove it and the certified Hurwitz F does: the structured
        # test's n-sized SVD would only repeat (at O(n^3)) what the certificate proves
        w["detectability"] = {"structured": "not run", "by": "proved by the certified Hurwitz F", "generic": det.value, "generic_by": "modal split of the moved block"}
        sd = det
    else:
        got = cluster_detectability(cm.L, bnd, pos, tol)
        sd, p0, how = got.status, got.positions, got.by
        w["detectability"] = {"structured": sd.value, "by": how, "generic": det.value, "generic_by": "modal split of the moved block"}
    if sd is not det and sd is not Status.UNDECIDED:
        if det is Status.UNDECIDED:
            det = sd
            w["detectability"]["note"] = "the modal split was undecided; the structured test decides"
        else:
            det = Status.UNDECIDED
            w["detectability"]["note"] = "the structured and the modal detectability tests disagree"
    w["unobservable_eigenvalues"] = [witness_number(m, 9) for m in md.unobservable]
    if det is not Status.HOLDS or md.certificate is None:
        mode_ = md.unstable_mode
        if mode_ is None and sd is Status.FAILS and p0 is not None:
            mode_ = (0j, np.concatenate([p0, np.zeros_like(p0)]).astype(complex))
        if mode_ is not None:
            lam, vec = mode_
            vec = vec / vec[int(np.argmax(np.abs(vec)))]
            w["unstable_unobservable_mode"] = {
                "eigenvalue": witness_number(lam, 9),
                "positions": {a: (complex(c).real if complex(c).imag == 0 else complex(c)) for a, c in zip(cm.nodes, vec[:n]) if c != 0},
                "velocities": {a: (complex(c).real if complex(c).imag == 0 else complex(c)) for a, c in zip(cm.nodes, vec[n:]) if c != 0},
            }
        if det is Status.HOLDS:
            w["design_error"] = "the modal split did not decide the moved block; no modal design"
            return Verdict(Status.UNDECIDED, margin=0.0, witness=w)
        margin = -float(mode_[0].real) if mode_ is not None else 0.0
        return Verdict(det, margin=margin, witness=w)
    cert = md.certificate
    eig = md.eigenvalues
    K1 = md.K1
    # residual checks of the design: F = A1 - K1 C, K = K1 + F h, on sparse matrices (A^i has
    # O(nnz L) nonzeros, h and C select rows, K1 has p columns: O(n p) work, no 2n x 2n array)
    As, hs, Cs, Es = (scipy.sparse.csr_matrix(M) for M in (cm.A_sparse, h, C, cm.E))
    K1s = scipy.sparse.csr_matrix(K1)
    A1 = As - hs @ (Cs @ As)
    F = A1 - K1s @ Cs
    K = K1s + F @ hs
    nE = float(scipy.sparse.linalg.norm(Es)) if Es.nnz else 0.0
    dec_res = float(scipy.sparse.linalg.norm(hs @ (Cs @ Es) - Es) / nE) if nE > 0 else 0.0
    R = A1 - (F - (F @ hs) @ Cs) - K @ Cs
    err_res = float(scipy.sparse.linalg.norm(R) if R.nnz else 0.0) / max(float(scipy.sparse.linalg.norm(As)) + float(scipy.sparse.linalg.norm(F)), 1e-300)
    ratio = 1.0 / (cert.perturbation * cert.resolvent) if cert.perturbation * cert.resolvent > 0 else math.inf
    hurwitz = Status.HOLDS if cert.certified else Status.UNDECIDED
    margin = float(-np.max(eig.real)) if len(eig) else math.inf
    w.update(
        {
            "method": "modal",
            "observable_dim": int(2 * n - len(md.unobservable)),
            "poles": [witness_number(p, 9) for p in md.poles],
            "eigenvalues_F": [witness_number(p, 9) for p in sorted(eig, key=lambda z: (z.real, z.imag))],
            "hurwitz_margin": margin,
            "hurwitz_certificate": {"status": hurwitz.value, "ratio": ratio},
            "decoupling_residual": dec_res,
            "error_residual": err_res,
        }
    )
    if md.notes:
        w["notes"] = list(md.notes)
    cw: dict[str, Any] = {
        "certified": bool(cert.certified),
        "error_bound": cert.perturbation,
        "by": "rank bounds and the modal Hurwitz certificate of (I - hC)A - K1 C (one eigh of L_II: residual, sigma_min and resolvent bounds)",
        "spectral_abscissa_upper": cert.abscissa_upper,
        "resolvent_bound": cert.resolvent,
        "basis_sigma_min_lower": cert.sigma_min,
    }
    if not cert.certified:
        cw["note"] = f"F = (I - hC)A - K1 C is not certified Hurwitz by the modal bound: {cert.note}; the dense certificate (local_uio_method = 'dense') or --exact decides"
    w["certificate"] = cw
    checks = {"decoupling": tol.decide(dec_res, 1.0), "error_free_of_state": tol.decide(err_res, 1.0)}
    if all(v is Decision.ZERO for v in checks.values()) and cert.certified:
        return Verdict(Status.HOLDS, margin=margin, witness=w)
    failed = [k for k, v in checks.items() if v is not Decision.ZERO] + ([] if cert.certified else ["hurwitz"])
    w["verification_failed"] = failed
    return Verdict(Status.UNDECIDED, margin=margin, witness=w)
