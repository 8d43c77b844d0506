"""Unknown-input observers of a cluster (Chen, Patton & Zhang 1996; eqs. ``obs_decent``-``uio_conds_3``).

For the cluster model of eq. ``cluster_dyn2``,

.. math::

    \\dot x = A x + E d + B u_a, \\qquad y = C x,

where d (the neighbour clusters' states as seen through the cut edges) is unknown, the
observer

.. math::

    \\dot z = F z + K y, \\qquad \\hat x = z + h y

with

.. math::

    h = E (C E)^{+},\\quad T = I - h C,\\quad A_1 = T A,\\quad F = A_1 - K_1 C,\\quad
    K = K_1 + F h

has the error e = x - x_hat obeying eq. ``obs_decent_error``,

.. math:: \\dot e = F e + T B u_a, \\qquad r = y - C \\hat x = C e,

free of d because T E = 0 and T A - F T - K C = 0. (The paper's K_sigma is F h and its
K-bar is K_1; the observer input gain is their sum.) It exists iff rank(C E) = rank(E)
(Proposition III.2 (ii), which makes (h C - I) E = 0 solvable) and (C, A_1) is detectable.
K_1 is found by pole placement on the observable part of (A_1, C); the unobservable modes
of (A_1, C) are eigenvalues of F for every K_1 and must be stable.

Default poles (:func:`default_poles`): with sigma = gamma / 2, the observable eigenvalues mu
of A_1 with Re mu <= -0.9 sigma stay, the others move to -|Re mu| - sigma + i Im mu; only the
moved ones are placed (ordered Schur form), which keeps the gain small on large clusters. If
the resulting F is not certified Hurwitz (:func:`~glocal_verify.numerics.hurwitz.hurwitz_certificate`) and the gain is large
(||K1||_2 > 10 max(||A1||_2, 1)), the design is redone moving only the modes with
Re > -theta sigma for theta in ``slow_ladder`` (:mod:`glocal_verify.config`) (0.3, 0.1, 0.02):
on large clusters measured at a few agents the slow, stable modes are weakly observable, and
moving them took gains of 1e3-1e10 and eigenvalue condition numbers that no certificate can
accept; keeping them costs margin (reported), not correctness. User poles (``poles`` of ``[[clusters.observers]]``) are
used first; if there are fewer than n_o, the rest are default-spaced poles left of the
leftmost user pole; extra poles are ignored (and said so in :attr:`UnknownInputObserver.notes`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from glocal_verify import config
from glocal_verify.analysis.local.cluster_modal import interior_modes, state_rounding_bound
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import LocalObserver, System
from glocal_verify.numerics.hurwitz import HurwitzCertificate, hurwitz_eigenvalues, hurwitz_reduced, matrix_operator, norm2
from glocal_verify.numerics.threads import single_threaded
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.observers.uio_existence import (
    UIOExistence,
    _place_dual,
    _place_slow,
    decoupling,
    _Reduction,
    _slow_schur,
    uio_existence,
)
from glocal_verify.observers.uio_modal import design_uio_modal
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "UnknownInputObserver",
    "design_uio",
    "local_uio",
]

# --------------------------------------------------------------------------------------------
# design


@dataclass(frozen=True, slots=True)
class UnknownInputObserver:
    """A designed unknown-input observer of one cluster, ready to simulate.

    State equation (eq. ``obs_decent``) with y = C x_cluster the local measurement::

        dz/dt = F z + K y,     x_hat = z + h y,     r = y - C x_hat

    and, for the true cluster state, the error e = x - x_hat obeys
    de/dt = F e + T B u_a (eq. ``obs_decent_error``), whatever the neighbour clusters do.

    Attributes
    ----------
    cluster, center, mode : str, label, str
        Which observer and for which mode's A^i it was designed.
    nodes : tuple of labels
        Cluster agents; the cluster state is [positions of nodes; velocities of nodes].
    positions, velocities : tuple of labels
        Measured channels, in the order of the rows of ``C`` (positions first).
    A, E, C : ndarray
        Cluster matrices A^i, E^i and C_loc used in the design.
    h, T, A1, K1, F, K : ndarray
        Design matrices: h = E (C E)^+, T = I - h C, A1 = T A, F = A1 - K1 C, K = K1 + F h.
    poles : ndarray
        Requested poles of the observable part.
    eigenvalues : ndarray
        Eigenvalues of F actually obtained (placed poles and fixed unobservable modes).
    decoupling_residual : float
        ||(h C - I) E||_F / ||E||_F (0 when there is no boundary agent).
    error_residual : float
        ||T A - F T - K C||_F / (||A||_F + ||F||_F): the coefficient of the cluster state in
        the error equation, which must vanish.
    hurwitz_margin : float
        -max Re eig(F).
    hurwitz : Status
        :func:`~glocal_verify.numerics.hurwitz.hurwitz_certificate` verdict on F (eigenvalue sensitivity included).
    hurwitz_ratio : float
        Worst -Re lambda_i / rho_i of that certificate.
    notes : tuple of str
        Remarks of the design (pole list adjusted, poles moved by the placement ...).
    """

    cluster: str
    center: Label
    mode: str
    nodes: tuple[Label, ...]
    positions: tuple[Label, ...]
    velocities: tuple[Label, ...]
    A: np.ndarray
    E: np.ndarray
    C: np.ndarray
    h: np.ndarray
    T: np.ndarray
    A1: np.ndarray
    K1: np.ndarray
    F: np.ndarray
    K: np.ndarray
    poles: np.ndarray
    eigenvalues: np.ndarray
    decoupling_residual: float
    error_residual: float
    hurwitz_margin: float
    hurwitz: Status
    hurwitz_ratio: float
    notes: tuple[str, ...] = field(default_factory=tuple)

    def __repr__(self) -> str:
        return (
            f"UnknownInputObserver({self.cluster}@{self.center}, mode {self.mode}, {self.n_states} states, "
            f"measures {len(self.positions)} positions and {len(self.velocities)} velocities, "
            f"Hurwitz {self.hurwitz.value} (margin {self.hurwitz_margin:.3g}))"
        )

    @property
    def n_states(self) -> int:
        return int(self.F.shape[0])

    def derivative(self, z: np.ndarray, y: np.ndarray) -> np.ndarray:
        """dz/dt = F z + K y."""
        return self.F @ z + self.K @ y

    def estimate(self, z: np.ndarray, y: np.ndarray) -> np.ndarray:
        """x_hat = z + h y (cluster coordinates)."""
        return z + self.h @ y

    def residual(self, z: np.ndarray, y: np.ndarray) -> np.ndarray:
        """r = y - C x_hat (= C e)."""
        return y - self.C @ self.estimate(z, y)

    def initial_state(self, y0: np.ndarray, x_hat0: np.ndarray | None = None) -> np.ndarray:
        """z(0) = x_hat(0) - h y(0) (x_hat(0) = 0 as in eq. ``obs_decent`` by default)."""
        xh = np.zeros(self.F.shape[0]) if x_hat0 is None else np.asarray(x_hat0, dtype=float)
        return xh - self.h @ np.asarray(y0, dtype=float)

    def measure(self, x_cluster: np.ndarray) -> np.ndarray:
        """y = C x_cluster."""
        return self.C @ x_cluster

    def cluster_state(self, system: System, x: np.ndarray) -> np.ndarray:
        """Extract [positions; velocities] of the cluster from a global state [x; v] of ``system``."""
        idx = system.idx(self.nodes)
        n = system.n
        return np.concatenate([x[idx], x[[n + i for i in idx]]])


def _place(Aoo: np.ndarray, Co: np.ndarray, poles: np.ndarray, tol: Tolerance) -> np.ndarray:
    """Gain Lo with eig(Aoo - Lo Co) = poles, by :func:`scipy.signal.place_poles` on the dual."""
    if Aoo.shape[0] == 0:
        return np.zeros((0, Co.shape[0]))
    return _place_dual(Aoo.T, Co.T, poles, tol).T


def _certify(F: np.ndarray, Qo: np.ndarray, Qu: np.ndarray, red: _Reduction | None, tol: Tolerance) -> HurwitzCertificate:
    """The Hurwitz certificate of F: reduced (:func:`~glocal_verify.numerics.hurwitz.hurwitz_reduced`,
    from the default design's Schur basis W = [Qo Q, Qu]) when it applies and F has at least
    ``uio_reduced_min_states`` (:mod:`glocal_verify.config`) states (below that the dense eigen-decomposition is cheap), else dense."""
    if red is not None and F.shape[0] >= config.get("uio_reduced_min_states") and Qo.shape[1] + Qu.shape[1] == F.shape[0]:
        got = hurwitz_reduced(F, np.hstack([Qo @ red.Q, Qu]), red.kept, red.sub, tol)
        if got is not None:
            return got
    return hurwitz_eigenvalues(F, tol)


@single_threaded
def design_uio(
    A: np.ndarray,
    E: np.ndarray,
    C: np.ndarray,
    *,
    poles: Sequence[float | complex] | None = None,
    gamma: float = 1.0,
    tol: Tolerance = DEFAULT_TOLERANCE,
    existence: UIOExistence | None = None,
) -> tuple[UIOExistence, dict[str, Any]]:
    """Design h, T, A1, K1, F, K for (A, E, C) (eqs. ``uio_conds_1``-``uio_conds_3``).

    Returns the existence evidence and a dict of the design matrices and checks (keys of
    :class:`UnknownInputObserver`). Raises :class:`NotApplicableError` when no UIO exists
    (rank condition or detectability fails, or cannot be decided), naming the reason.

    Parameters
    ----------
    A, E, C : ndarray
        Cluster matrices.
    poles : sequence of complex, optional
        Poles of the observable part (default: :func:`default_poles`, slow modes only).
    gamma : float
        Velocity damping (sets the default poles).
    tol : Tolerance
        Rank decisions and the Hurwitz certificate.
    existence : UIOExistence, optional
        The result of :func:`uio_existence` for the same (A, E, C, tol), when the caller has
        it (it is not recomputed).

    Notes
    -----
    Cost: one observable split (unless given; sparse products A_1^T V), one real Schur form of
    the observable part (the kept and placed eigenvalues are read off it), a small pole
    placement on the slow block (closed form when it has as many independent outputs as
    states), and the Hurwitz certificate of F with its eigenvalues. With default poles and at
    least ``uio_reduced_min_states`` (:mod:`glocal_verify.config`) states the certificate reuses that Schur form: W = [Qo Q, Qu]
    block-triangularises F^T, only the small trailing block (moved and unobservable modes) is
    factorised, and the eigenvector condition numbers come from triangular back substitution
    (:func:`~glocal_verify.numerics.hurwitz.hurwitz_reduced`: the same bound
    kappa_i rtol ||F||_2, enlarged by the entries the reduction drops; the dense
    eigen-decomposition with left and right vectors when the reduction does not apply). With
    default poles, an F that is not certified is redesigned along ``slow_ladder`` (:mod:`glocal_verify.config`) (one
    more small placement and certificate per step; the notes say so).
    """
    ex_ = existence if existence is not None else uio_existence(A, E, C, tol)
    if ex_.rank_condition is not Status.HOLDS:
        raise NotApplicableError(f"no UIO: rank(C E) = rank(E) is {ex_.rank_condition.value} (a boundary agent's velocity is not measured)")
    if ex_.status is not Status.HOLDS:
        lam = ex_.unstable_mode[0] if ex_.unstable_mode else None
        why = f"unobservable mode {lam:.6g} of (A1, C) is not stable" if lam is not None else "detectability of (A1, C) is undecided"
        raise NotApplicableError(f"no UIO: {why}")
    assert ex_.h is not None and ex_.T is not None and ex_.A1 is not None and ex_.split is not None
    h, T, A1 = ex_.h, ex_.T, ex_.A1
    Qo = ex_.split.Qo
    no = Qo.shape[1]
    notes: list[str] = []
    Aoo = Qo.T @ np.asarray(matrix_operator(A1) @ Qo)
    Co = C @ Qo
    placed: np.ndarray
    ladder: tuple[float, ...] = (config.get("slow_ladder")[0],)
    sch: tuple[np.ndarray, np.ndarray, int] | None = None
    red: _Reduction | None = None
    if poles is None:
        if no:
            sch = _slow_schur(Aoo, gamma)
            ladder = config.get("slow_ladder") if sch[2] < no else ladder
            Lo, want, placed, red = _place_slow(Aoo, Co, gamma, tol, ladder[0], sch)
        else:
            Lo, want, placed = np.zeros((0, C.shape[0])), np.zeros(0), np.zeros(0)
    else:
        user = np.asarray([complex(p) for p in poles])
        if len(user) >= no:
            want = user[:no]
            if len(user) > no:
                notes.append(f"{len(user) - no} of the {len(user)} requested poles ignored: the observable part has dimension {no}")
        else:
            left = float(np.min(user.real)) if len(user) else -max(gamma, 1.0)
            extra = left * (1.0 + (1.0 + np.arange(no - len(user))) / max(no - len(user), 1))
            want = np.concatenate([user, extra])
            notes.append(f"{no - len(user)} default poles added left of {left:.4g}: the observable part has dimension {no}")
        if np.all(want.imag == 0.0):
            want = want.real
        Lo = _place(Aoo, Co, want, tol)
        placed = np.linalg.eigvals(Aoo - Lo @ Co) if no else np.zeros(0)
    if no and np.all(np.asarray(want).imag == 0.0):
        want = np.asarray(want).real
    K1 = Qo @ Lo
    F = A1 - K1 @ C
    Qu = ex_.split.Qu
    cert = _certify(F, Qo, Qu, red, tol)
    hurwitz, hurwitz_ratio, eig = cert.status, cert.ratio, cert.eigenvalues
    for theta in ladder[1:]:
        # moving weakly observable slow modes that are already stable can take a huge gain
        # and make F too ill-conditioned to certify: keep more of them, move only the slowest
        # (a small gain means the trouble is elsewhere, e.g. a repeated eigenvalue: no retry)
        if hurwitz is Status.HOLDS or norm2(K1) <= config.get("uio_ladder_gain") * max(norm2(A1), 1.0):
            break
        Lo2, want2, placed2, red2 = _place_slow(Aoo, Co, gamma, tol, theta, sch)
        F2 = A1 - (Qo @ Lo2) @ C
        cert2 = _certify(F2, Qo, Qu, red2, tol)
        h2, r2, e2 = cert2.status, cert2.ratio, cert2.eigenvalues
        notes.append(
            f"default placement (modes with Re > -{ladder[ladder.index(theta) - 1]:g} sigma moved) not certified Hurwitz "
            f"(ratio {hurwitz_ratio:.3g}, ||K1||_2 {float(np.linalg.norm(K1, 2)):.3g}); retried moving only Re > -{theta:g} sigma"
        )
        Lo, want, placed, K1, F, hurwitz, hurwitz_ratio, eig = Lo2, want2, placed2, Qo @ Lo2, F2, h2, r2, e2
    K = K1 + F @ h
    nE = float(np.linalg.norm(E))
    dec_res = float(np.linalg.norm((h @ C - np.eye(A.shape[0])) @ E) / nE) if nE > 0 else 0.0
    # T A - F T - K C with T A = A - h (C A) and F T = F - (F h) C: O(n^2 p), not two n^3 products
    err_res = float(np.linalg.norm((A - h @ (C @ A)) - (F - (F @ h) @ C) - K @ C)) / max(float(np.linalg.norm(A)) + float(np.linalg.norm(F)), 1e-300)
    if no and max(float(np.min(np.abs(placed - p))) for p in np.atleast_1d(want)) > 1e-6 * max(1.0, float(np.max(np.abs(want)))):
        notes.append("the placed poles differ from the requested ones by more than 1e-6 (ill-conditioned placement)")
    design = {
        "h": h,
        "T": T,
        "A1": A1,
        "K1": K1,
        "F": F,
        "K": K,
        "poles": np.asarray(want),
        "eigenvalues": eig,
        "decoupling_residual": dec_res,
        "error_residual": err_res,
        "hurwitz_margin": float(-np.max(eig.real)) if len(eig) else float("inf"),
        "hurwitz": hurwitz,
        "hurwitz_ratio": hurwitz_ratio,
        "notes": tuple(notes),
    }
    return ex_, design


def _modal_design(system: System, observer: LocalObserver, mode: str, C: np.ndarray, tol: Tolerance) -> dict[str, Any] | None:
    """The design dict of :func:`design_uio` from :func:`~glocal_verify.observers.uio_modal.design_uio_modal`
    (None when the rank condition does not hold or the modal basis does not apply)."""
    cm = system.cluster_model(observer.cluster, mode)
    dec = decoupling(cm.E, C, tol)
    h = dec.h
    if dec.status is not Status.HOLDS or h is None:
        return None
    idx = {a: k for k, a in enumerate(cm.nodes)}
    try:
        md = design_uio_modal(
            cm.A_sparse,
            interior_modes(system, cm.name, mode),
            [idx[a] for a in observer.positions],
            [idx[a] for a in observer.velocities],
            alpha=system.alpha,
            gamma=system.gamma,
            tol=tol,
            input_error=state_rounding_bound(system, cm.name, mode),
        )
    except NotApplicableError:
        return None
    if md.detectable is not Status.HOLDS or md.certificate is None:
        return None
    A = cm.A
    n2 = A.shape[0]
    T = np.eye(n2) - h @ C
    A1 = A - h @ (C @ A)
    F = A1 - md.K1 @ C
    K = md.K1 + F @ h
    nE = float(np.linalg.norm(cm.E))
    eig = md.eigenvalues
    cert = md.certificate
    return {
        "h": h,
        "T": T,
        "A1": A1,
        "K1": md.K1,
        "F": F,
        "K": K,
        "poles": md.poles,
        "eigenvalues": eig,
        "decoupling_residual": float(np.linalg.norm(h @ (C @ cm.E) - cm.E) / nE) if nE > 0 else 0.0,
        "error_residual": float(np.linalg.norm(A1 - (F - (F @ h) @ C) - K @ C)) / max(float(np.linalg.norm(A)) + float(np.linalg.norm(F)), 1e-300),
        "hurwitz_margin": float(-np.max(eig.real)) if len(eig) else float("inf"),
        "hurwitz": Status.HOLDS if cert.certified else Status.UNDECIDED,
        "hurwitz_ratio": 1.0 / (cert.perturbation * cert.resolvent) if cert.perturbation * cert.resolvent > 0 else float("inf"),
        "notes": md.notes + ("designed in modal coordinates (one eigh of the interior block)",),
    }


def local_uio(
    system: System,
    observer: LocalObserver,
    *,
    mode: str = NORMAL_MODE,
    poles: Sequence[float | complex] | None = None,
    tol: Tolerance = DEFAULT_TOLERANCE,
    method: str = "dense",
) -> UnknownInputObserver:
    """Design the UIO of a local observer of ``system`` (the object the simulator runs).

    Parameters
    ----------
    system : System
    observer : LocalObserver
        From :meth:`System.observers`; its ``poles`` are used unless ``poles`` is given.
    mode : str
        Mode whose A^i the design uses (default the normal mode).
    poles : sequence of complex, optional
        Poles of the observable part; default the observer's, else :func:`default_poles`.
    tol : Tolerance
        Rank decisions and the Hurwitz certificate (:func:`design_uio`).
    method : str
        ``dense`` (default, :func:`design_uio`), ``modal``
        (:func:`~glocal_verify.observers.uio_modal.design_uio_modal`: the same default poles
        from one eigh of the cluster's interior block, certified by its modal bound; used
        with default poles only, else dense) or ``auto`` (modal from
        ``modal_min_agents`` (:mod:`glocal_verify.config`) agents on).

    Raises
    ------
    NotApplicableError
        When no UIO exists for this observer (the message says which condition fails).
    """
    cm = system.cluster_model(observer.cluster, mode)
    C = cm.C(observer.positions, observer.velocities)
    want = poles if poles is not None else (None if observer.poles is None else [float(p) for p in observer.poles])
    d = None
    if want is None and (method == "modal" or (method == "auto" and len(cm.nodes) >= config.get("modal_min_agents"))):
        d = _modal_design(system, observer, mode, C, tol)
    if d is None:
        try:
            _, d = design_uio(cm.A, cm.E, C, poles=want, gamma=system.gamma, tol=tol)
        except NotApplicableError as exc:
            raise NotApplicableError(f"cluster {observer.cluster!r}, observer {observer.center!r}: {exc}") from None
    return UnknownInputObserver(
        cluster=observer.cluster,
        center=observer.center,
        mode=mode,
        nodes=cm.nodes,
        positions=tuple(observer.positions),
        velocities=tuple(observer.velocities),
        A=cm.A,
        E=cm.E,
        C=C,
        **d,
    )
