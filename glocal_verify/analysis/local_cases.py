"""The local cases of Proposition III.2: one per cluster, observer, mode and suspected set.

A :class:`LocalCase` bundles the cluster model (eq. ``cluster_dyn2``), the observer's output
matrix and the suspected actuators (the spec's attack, or every agent of the cluster for the
worst case of Remark III.2.1), with the pencil matrices numeric and exact.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify.model import ClusterModel, LocalObserver, System
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "LocalCase",
    "local_cases",
    "cluster_summary",
    "pencil_matrices",
    "pencil_matrices_exact",
    "full_pencil",
]

# --------------------------------------------------------------------------------------------
# cases


@dataclass(frozen=True, slots=True)
class LocalCase:
    """One (cluster, observer, suspected set) combination.

    Attributes
    ----------
    model : ClusterModel
        Cluster matrices in ``mode``.
    observer : LocalObserver
        Centre and resolved measured sets.
    kind : str
        ``"attack"`` or ``"all"`` (the scope's ``suspected`` value).
    suspected : tuple of labels
        Suspected agents inside the cluster, in cluster order.
    mode : str
        Mode of the cluster model (the normal mode for the checkers).
    """

    model: ClusterModel
    observer: LocalObserver
    kind: str
    suspected: tuple[Label, ...]
    mode: str = NORMAL_MODE

    @property
    def scope(self) -> dict[str, Any]:
        return {"cluster": self.model.name, "observer": self.observer.center, "suspected": self.kind}

    @property
    def structural(self) -> tuple[Label, ...]:
        """Agents both suspected and on the boundary (each makes (iii) fail at every lam)."""
        b = set(self.model.boundary)
        return tuple(a for a in self.suspected if a in b)

    @property
    def C(self) -> np.ndarray:
        return self.model.C(self.observer.positions, self.observer.velocities)

    @property
    def B(self) -> np.ndarray:
        return self.model.B(self.suspected)


def local_cases(system: System, mode: str = NORMAL_MODE, cluster: str | None = None) -> list[LocalCase]:
    """All (cluster, observer, suspected) cases of ``system`` in ``mode``.

    Parameters
    ----------
    system : System
    mode : str
        Mode of the cluster models.
    cluster : str, optional
        Restrict to one cluster.
    """
    attacked = set(system.attacked)
    out = []
    for c in system.clusters:
        if cluster is not None and c.name != cluster:
            continue
        cm = system.cluster_model(c.name, mode)
        for obs in system.observers(c.name):
            if system.spec.attack is not None:
                out.append(LocalCase(cm, obs, "attack", tuple(a for a in cm.nodes if a in attacked), mode))
            out.append(LocalCase(cm, obs, "all", tuple(cm.nodes), mode))
    return out


def cluster_summary(system: System, name: str, mode: str = NORMAL_MODE) -> dict[str, Any]:
    """Decomposition facts of one cluster: agents, boundary, cut edges, their count and rank(E^i).

    Parameters
    ----------
    system : System
    name : str
        Cluster name.
    mode : str
        Mode of the cluster model.
    """
    cm = system.cluster_model(name, mode)
    return {
        "nodes": list(cm.nodes),
        "boundary": list(cm.boundary),
        "cut_edges": [[u, v, w] for u, v, w in cm.cut_edges],
        "inter_cluster_edges": len(cm.cut_edges),
        "rank_E": int(cm.E.shape[1]),
    }


def pencil_matrices(case: LocalCase) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A^i, G, C_loc) with G = [B^i, -E^i]: the local pencil of eq. ``pencil_uio``,
    [[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]], is the Rosenbrock pencil of (A^i, G, C_loc, 0)."""
    return case.model.A, np.hstack([case.B, -case.model.E]), case.C


def full_pencil(case: LocalCase, lam: complex) -> np.ndarray:
    """The matrix [[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]] of eq. ``pencil_uio`` at ``lam``.

    Parameters
    ----------
    case : LocalCase
    lam : complex
    """
    A, G, C = pencil_matrices(case)
    n, m = A.shape[0], G.shape[1]
    P = np.zeros((n + C.shape[0], n + m), dtype=complex)
    P[:n, :n] = lam * np.eye(n) - A
    P[:n, n:] = -G
    P[n:, :n] = C
    return P


def _exact_A(system: System, case: LocalCase) -> list[list[Fraction]]:
    L = system.cluster_laplacian_exact(case.model.name, case.mode)
    n = len(L)
    A = [[Fraction(0)] * (2 * n) for _ in range(2 * n)]
    for i in range(n):
        A[i][n + i] = Fraction(1)
        A[n + i][n + i] = -system.gamma_q
        for j in range(n):
            A[n + i][j] = -system.alpha_q * L[i][j]
    return A


def _exact_int(M: np.ndarray) -> list[list[Fraction]]:
    return [[Fraction(int(round(float(x)))) for x in row] for row in M]


def pencil_matrices_exact(system: System, case: LocalCase) -> tuple[list[list[Fraction]], list[list[Fraction]], list[list[Fraction]]]:
    """(A^i, G, C_loc) with rational entries (weights and gains exactly as the spec gives them).

    Parameters
    ----------
    system : System
    case : LocalCase
    """
    A = _exact_A(system, case)
    _, G, C = pencil_matrices(case)
    return A, _exact_int(G), _exact_int(C)
