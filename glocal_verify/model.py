"""The closed-loop model of eq. ``cl_sys`` and the cluster model of eq. ``cluster_dyn2``.

.. math::

    A_q = \\begin{bmatrix} 0 & I \\\\ -\\alpha L_q & -\\gamma I \\end{bmatrix},\\quad
    B = \\begin{bmatrix} 0 \\\\ S_F^\\top \\end{bmatrix},\\quad
    C = \\operatorname{blkdiag}(S_{M_x}, S_{M_v})

Node labels are kept end to end: every public method takes and returns the user's labels;
0-based indices appear only in arrays, in the order of :attr:`System.labels`.

The cluster model follows ``docs/conditions.md``: A^i is built from the principal block L[P_i, P_i]
(it keeps the degree contributed by inter-cluster edges), the coupling enters the velocity rows
of the boundary agents dP_i, and E^i = [0; S_{dP_i}^T] has one column per boundary agent.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import networkx as nx
import numpy as np
import scipy.sparse

from glocal_verify import config
from glocal_verify.derived import Analysis, Kind
from glocal_verify.errors import ModelError, SpecError
from glocal_verify.extra.control import state_space
from glocal_verify.numerics.block_spectrum import clustered_spectrum, laplacian_csr
from glocal_verify.numerics.spectrum import Spectrum
from glocal_verify.numerics.updated_spectrum import update_spectrum
from glocal_verify.spec.load import as_spec
from glocal_verify.spec.types import (
    NORMAL_MODE,
    ClusterSpec,
    Label,
    ObserverSpec,
    SystemSpec,
)

__all__ = [
    "Analysis",
    "ClusterModel",
    "LocalObserver",
    "System",
    "selection",
    "state_matrix",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_CLUSTER_LAPLACIAN_ENTRIES_KIND: Kind[dict[tuple[int, int], Fraction]] = Kind("cluster-laplacian-entries", __name__, "dict[tuple[int, int], Fraction]")
_CLUSTER_LAPLACIAN_EXACT_KIND: Kind[list[list[Fraction]]] = Kind("cluster-laplacian-exact", __name__, "list[list[Fraction]]")
_MONITORED_KIND: Kind[tuple[Label, ...]] = Kind("monitored", __name__, "tuple[Label, ...]")
_COMPONENTS_KIND: Kind[tuple[tuple[Label, ...], ...]] = Kind("components", __name__, "tuple[tuple[Label, ...], ...]")
_OBSERVERS_KIND: Kind[tuple[LocalObserver, ...]] = Kind("observers", __name__, "tuple[LocalObserver, ...]")
_SWITCHING_LINKS_KIND: Kind[list[tuple[Label, Label, Fraction]]] = Kind("switching-links", __name__, "list[tuple[Label, Label, Fraction]]")
_DELTA_LAPLACIAN_KIND: Kind[scipy.sparse.csr_matrix] = Kind("delta-laplacian", __name__, "scipy.sparse.csr_matrix")

def selection(indices: Sequence[int], n: int) -> np.ndarray:
    """Selection matrix S_X with rows e_i^T, i in ``indices`` (shape ``len(indices) x n``)."""
    S = np.zeros((len(indices), n))
    for r, i in enumerate(indices):
        S[r, i] = 1.0
    return S


def state_matrix(L: np.ndarray, alpha: float, gamma: float) -> np.ndarray:
    """A = [[0, I], [-alpha L, -gamma I]] for a (principal block of a) Laplacian L."""
    n = L.shape[0]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -alpha * L
    A[n:, n:] = -gamma * np.eye(n)
    return A


def state_matrix_sparse(L: scipy.sparse.spmatrix, alpha: float, gamma: float) -> scipy.sparse.csr_matrix:
    """:func:`state_matrix` in CSR form: the same entries (each ``-alpha L_ij`` one rounded product), zeros not stored."""
    n = L.shape[0]
    eye = scipy.sparse.identity(n, format="csr")
    A = scipy.sparse.bmat([[None, eye], [(-alpha) * scipy.sparse.csr_matrix(L), (-gamma) * eye]], format="csr", dtype=float)
    if A.shape != (2 * n, 2 * n):  # bmat drops an all-None row or column only when n = 0
        A = scipy.sparse.csr_matrix((2 * n, 2 * n))
    A.eliminate_zeros()
    A.sort_indices()
    return A  # type: ignore[no-any-return]


@dataclass(frozen=True, slots=True)
class LocalObserver:
    """A local observer with its resolved measured sets (labels)."""

    cluster: str
    center: Label
    positions: tuple[Label, ...]
    velocities: tuple[Label, ...]
    poles: tuple[Fraction, ...] | None = None


@dataclass(frozen=True, slots=True)
class ClusterModel:
    """Matrices of one cluster subsystem (eq. ``cluster_dyn2``) in a given mode.

    Attributes
    ----------
    nodes : tuple of labels
        Agents of the cluster, in the order of the rows of ``L`` (positions first, then
        velocities in the state).
    L : ndarray
        Principal block L[P_i, P_i] of the mode's Laplacian.
    A_sparse : scipy.sparse.csr_matrix
        A^i = [[0, I], [-alpha L, -gamma I]] in CSR form (its nonzeros only: O(n + edges)).
        :attr:`A` is the dense form, built on each access.
    boundary : tuple of labels
        Agents of the cluster with at least one inter-cluster edge (dP_i).
    cut_edges : tuple of (inside, outside, weight)
        Inter-cluster edges of the cluster.
    E : ndarray
        E^i = [0; S_{dP_i}^T] (one column per boundary agent, full column rank).
    coupling : dict
        A^{ij} blocks per neighbouring cluster name (``scipy.sparse`` CSR: the cut edges only).

    The arrays are read-only: a safe mode that changes no link of the cluster shares them
    with the normal mode's model.
    """

    name: str
    mode: str
    nodes: tuple[Label, ...]
    L: np.ndarray
    A_sparse: scipy.sparse.csr_matrix
    boundary: tuple[Label, ...]
    cut_edges: tuple[tuple[Label, Label, Fraction], ...]
    E: np.ndarray
    coupling: dict[str, scipy.sparse.csr_matrix]

    @property
    def A(self) -> np.ndarray:
        """A^i = [[0, I], [-alpha L, -gamma I]] as a dense (2n x 2n) read-only array, built from :attr:`A_sparse` on each access."""
        A = self.A_sparse.toarray()
        A.setflags(write=False)
        return A

    def B(self, suspected: Iterable[Label]) -> np.ndarray:
        """B^i = [0; S_F^T] for the suspected actuators inside the cluster."""
        idx = [self.nodes.index(a) for a in suspected if a in self.nodes]
        n = len(self.nodes)
        B = np.zeros((2 * n, len(idx)))
        for c, i in enumerate(idx):
            B[n + i, c] = 1.0
        return B

    def C(self, positions: Iterable[Label], velocities: Iterable[Label]) -> np.ndarray:
        """Local output matrix blkdiag(S_pos, S_vel) in cluster coordinates."""
        n = len(self.nodes)
        pi = [self.nodes.index(a) for a in positions]
        vi = [self.nodes.index(a) for a in velocities]
        C = np.zeros((len(pi) + len(vi), 2 * n))
        for r, i in enumerate(pi):
            C[r, i] = 1.0
        for r, i in enumerate(vi):
            C[len(pi) + r, n + i] = 1.0
        return C


class System:
    """A multi-agent system built from a validated :class:`~glocal_verify.spec.types.SystemSpec`.

    Parameters
    ----------
    spec : SystemSpec
        The validated specification (a mapping shaped like the file is validated first).

    Examples
    --------
    >>> from glocal_verify.spec import load_example
    >>> sys = System(load_example("paper19"))
    >>> sys.n, sys.modes[:2]
    (19, ('normal', 'case-1'))
    """

    def __init__(self, spec: SystemSpec) -> None:
        self.spec = spec = as_spec(spec, "System")
        self.labels: tuple[Label, ...] = spec.nodes
        self.n = len(self.labels)
        self.index: dict[Label, int] = {lab: i for i, lab in enumerate(self.labels)}
        self.alpha_q = spec.alpha
        self.gamma_q = spec.gamma
        self.alpha = float(spec.alpha)
        self.gamma = float(spec.gamma)
        self.modes: tuple[str, ...] = spec.mode_names
        self._edges: dict[str, dict[frozenset[Label], Fraction]] = {}
        self._lap: dict[str, scipy.sparse.csr_matrix] = {}
        self._spectra: dict[str, Spectrum] = {}
        self._adjacency: dict[str, dict[Label, tuple[Label, ...]]] = {}
        self._cluster_models: dict[tuple[str, str], ClusterModel] = {}
        self._cluster_of: dict[Label, str] = {lab: c.name for c in spec.clusters for lab in c.nodes}
        #: derived results shared by the analyses and checkers run on this system
        self.analysis = Analysis()
        base = {e.key: e.weight for e in spec.edges}
        self._edges[NORMAL_MODE] = base
        for m in spec.modes:
            w = dict(base)
            for u, v in m.remove:
                del w[frozenset((u, v))]
            for e in m.add:
                w[e.key] = e.weight
            self._edges[m.name] = w

    # -- labels ---------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.spec.name

    def idx(self, labels: Iterable[Label]) -> list[int]:
        """0-based indices of ``labels``."""
        out = []
        for lab in labels:
            if lab not in self.index:
                raise ModelError(f"node {lab!r} is not in the graph")
            out.append(self.index[lab])
        return out

    def vector_by_label(self, v: Sequence[object] | np.ndarray, *, digits: int | None = None) -> dict[Label, object]:
        """Map a length-N vector to ``{label: value}`` (the form every witness uses)."""
        out: dict[Label, object] = {}
        for lab, x in zip(self.labels, v):
            out[lab] = round(float(x), digits) if digits is not None else x  # type: ignore[arg-type]
        return out

    def check_mode(self, mode: str) -> str:
        if mode not in self._edges:
            raise ModelError(f"no mode named {mode!r} (modes: {', '.join(self.modes)})")
        return mode

    @property
    def safe_modes(self) -> tuple[str, ...]:
        return self.modes[1:]

    # -- graphs and Laplacians --------------------------------------------------------------
    def edges(self, mode: str = NORMAL_MODE) -> dict[frozenset[Label], Fraction]:
        """Edge weights of a mode, ``{frozenset({u, v}): w}``."""
        return dict(self._edges[self.check_mode(mode)])

    def graph(self, mode: str = NORMAL_MODE) -> nx.Graph:
        """The mode's communication graph as a networkx graph (weights as floats)."""
        G = nx.Graph()
        G.add_nodes_from(self.labels)
        G.add_weighted_edges_from((*tuple(key), float(w)) for key, w in self._edges[self.check_mode(mode)].items())
        return G

    def laplacian_sparse(self, mode: str = NORMAL_MODE) -> scipy.sparse.csr_matrix:
        """L_q as a sparse (CSR) float matrix, every entry correctly rounded (kept per mode; read-only data).

        Formed exactly from the spec's rational weights and rounded once
        (:func:`~glocal_verify.numerics.block_spectrum.laplacian_csr`), so ``||fl(L) - L||_2 <=
        u ||L||_F``: the input error the certified bounds of
        :class:`~glocal_verify.numerics.spectrum.Spectrum` add. O(N + |E|) memory: the form
        every large-N consumer reads, instead of the dense N x N array.
        """
        self.check_mode(mode)
        if mode not in self._lap:
            self._lap[mode] = laplacian_csr(self.n, self._links(self._edges[mode].items()))
        return self._lap[mode]

    def _links(self, edges: Iterable[tuple[frozenset[Label], Fraction]]) -> Iterator[tuple[int, int, Fraction]]:
        for key, w in edges:
            i, j = sorted(self.index[x] for x in key)
            yield i, j, w

    def laplacian(self, mode: str = NORMAL_MODE) -> np.ndarray:
        """L_q as a dense float array (read-only), every entry correctly rounded.

        The dense form of :meth:`laplacian_sparse` (same entries, same input-error bound),
        built anew on each call: N^2 doubles, so large-N code reads the sparse form.
        """
        L = self.laplacian_sparse(mode).toarray()
        L.setflags(write=False)
        return L

    def laplacian_exact(self, mode: str = NORMAL_MODE) -> list[list[Fraction]]:
        """L_q with exact rational entries (row lists)."""
        self.check_mode(mode)
        L = [[Fraction(0)] * self.n for _ in range(self.n)]
        for key, w in self._edges[mode].items():
            u, v = (self.index[x] for x in key)
            L[u][v] -= w
            L[v][u] -= w
            L[u][u] += w
            L[v][v] += w
        return L

    def delta_laplacian(self, mode: str) -> np.ndarray:
        """dL_q = L_q - L_1 as a dense float array (read-only), every entry correctly rounded.

        The entries of :meth:`delta_laplacian_sparse`, expanded on each call and not kept: dL_q
        has a few nonzeros per changed link, and a kept N x N copy per mode (0.8 GB at
        N = 10,000) would outlive the check that asked for it.
        """
        D = self.delta_laplacian_sparse(mode).toarray()
        D.setflags(write=False)
        return D

    def delta_laplacian_sparse(self, mode: str) -> scipy.sparse.csr_matrix:
        """dL_q = L_q - L_1 as a sparse (CSR) float matrix, every entry correctly rounded (kept per mode: do not modify it).

        Formed from the exact rational link differences of :meth:`switching_links` and only
        then rounded (never as ``fl(L_q) - fl(L_1)``, which cancels: a weight changed from 3
        to 3 + 1e-15 would vanish). Entries that are exactly zero are not stored, so the
        support of the matrix is the exact support of dL_q.
        """
        kept = _DELTA_LAPLACIAN_KIND.peek(self, (self.check_mode(mode),))
        if kept is not None:
            return kept
        rows: list[int] = []
        cols: list[int] = []
        vals: list[float] = []
        deg: dict[int, Fraction] = {}
        for a, b, d in self.switching_links(mode):
            u, v = self.index[a], self.index[b]
            rows += [u, v]
            cols += [v, u]
            vals += [-float(d), -float(d)]
            deg[u] = deg.get(u, Fraction(0)) + d
            deg[v] = deg.get(v, Fraction(0)) + d
        for i, d in sorted(deg.items()):
            if d != 0:
                rows.append(i)
                cols.append(i)
                vals.append(float(d))
        D = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(self.n, self.n))  # no duplicates: one entry per link
        _DELTA_LAPLACIAN_KIND.put(self, (mode,), D)
        return D

    def delta_laplacian_exact(self, mode: str) -> list[list[Fraction]]:
        """dL_q = L_q - L_1 with exact rational entries (row lists), from the changed links
        (:meth:`switching_links`) alone: O(N^2) zeros and a few sums per link, not N^2
        rational subtractions."""
        zero = Fraction(0)
        dL = [[zero] * self.n for _ in range(self.n)]
        for u, v, d in self.switching_links(mode):
            i, j = self.index[u], self.index[v]
            dL[i][j] -= d
            dL[j][i] -= d
            dL[i][i] += d
            dL[j][j] += d
        return dL

    def switching_links(self, mode: str) -> list[tuple[Label, Label, Fraction]]:
        """Pairs whose weight differs between ``mode`` and the normal mode, with the change (stored once per mode)."""
        mode = self.check_mode(mode)

        def build() -> list[tuple[Label, Label, Fraction]]:
            a, b = self._edges[mode], self._edges[NORMAL_MODE]
            out = []
            changed = [k for k, w in a.items() if b.get(k) != w] + [k for k in b if k not in a]  # O(|E|); only the changes are sorted
            for key in sorted(changed, key=lambda k: sorted(self.index[x] for x in k)):
                d = a.get(key, Fraction(0)) - b.get(key, Fraction(0))
                if d != 0:
                    u, v = sorted(key, key=lambda x: self.index[x])
                    out.append((u, v, d))
            return out

        return list(_SWITCHING_LINKS_KIND.get(self, (mode,), build))

    def switching_components(self, mode: str) -> tuple[tuple[Label, ...], ...]:
        """Connected components D_c (>= 2 nodes) of the graph of switching links (Definition A.1).

        The links are the nonzero off-diagonal entries of dL_q; they come exactly from the
        spec's ``add``/``remove`` lists, so no tolerance is involved.
        """
        G = nx.Graph()
        for u, v, _ in self.switching_links(mode):
            G.add_edge(u, v)
        comps = [tuple(sorted(c, key=self.index.__getitem__)) for c in nx.connected_components(G)]
        return tuple(sorted(comps, key=lambda c: self.index[c[0]]))

    def spectrum(self, mode: str = NORMAL_MODE) -> Spectrum:
        """The eigendecomposition of L_q with its error bounds (computed once per mode).

        A large clustered normal mode is decomposed cluster by cluster, the links between
        clusters added as rank-one factors (:meth:`_block_spectrum`); a safe mode that changes at
        most ``rank_one_max_changes`` (:mod:`glocal_verify.config`) links is the normal spectrum times one factor per
        change. Both are certified from their factors (:mod:`glocal_verify.numerics.updated_spectrum`,
        which also computes the rows the checks read) or replaced by one ``eigh`` of L_q.

        Parameters
        ----------
        mode : str
            The mode q.
        """
        self.check_mode(mode)
        if mode not in self._spectra:
            L = self.laplacian_sparse(mode)
            sp: Spectrum | None = None
            if mode == NORMAL_MODE and self.n >= config.get("block_min_agents"):
                sp = self._block_spectrum(L)
            if mode != NORMAL_MODE and self.n >= config.get("rank_one_min_agents"):
                # a safe mode that changes a few links: rank-one updates of the normal mode's
                # spectrum, certified like eigh's output (update_spectrum), else a fresh eigh
                changes = [(self.index[a], self.index[b], float(d)) for a, b, d in self.switching_links(mode)]
                if 0 < len(changes) <= config.get("rank_one_max_changes"):
                    sp = update_spectrum(L, self.spectrum(NORMAL_MODE), changes)
            self._spectra[mode] = sp if sp is not None else Spectrum(L)
            if not self._spectra[mode].explicit:  # the rows every check reads, in one pass over the factors
                self._spectra[mode].rows(sorted(set(self.idx(self.monitored)) | set(self.idx(self.attacked)) | {self.index[x] for m in self.safe_modes for link in self.switching_links(m) for x in link[:2]}))
        return self._spectra[mode]

    def _block_spectrum(self, L: scipy.sparse.csr_matrix) -> Spectrum | None:
        """The normal mode from its clusters' blocks and its links between them (:func:`clustered_spectrum`).

        None unless the spec's clusters (two or more) hold every agent once and share between one
        and ``block_max_cut_links`` (:mod:`glocal_verify.config`) links, or when the update is refused.
        """
        if len(self.clusters) < 2 or sum(len(c.nodes) for c in self.clusters) != self.n or len(self._cluster_of) != self.n:
            return None
        edges = self._edges[NORMAL_MODE].items()
        inside = [(k, w) for k, w in edges if len({self._cluster_of[x] for x in k}) == 1]
        cut = [(i, j, float(w)) for i, j, w in self._links((k, w) for k, w in edges if len({self._cluster_of[x] for x in k}) == 2)]
        if not 0 < len(cut) <= config.get("block_max_cut_links"):
            return None
        blocks = [np.array(sorted(self.index[x] for x in c.nodes), dtype=np.intp) for c in self.clusters]
        return clustered_spectrum(L, laplacian_csr(self.n, self._links(inside)), blocks, cut)

    def eigh(self, mode: str = NORMAL_MODE) -> tuple[np.ndarray, np.ndarray]:
        """Eigen-decomposition L_q = U diag(w) U^T (ascending w; read-only), from :meth:`spectrum`."""
        sp = self.spectrum(mode)
        return sp.values, sp.vectors

    # -- global matrices --------------------------------------------------------------------
    @property
    def monitored_positions(self) -> tuple[Label, ...]:
        return self.spec.monitor.positions

    @property
    def monitored_velocities(self) -> tuple[Label, ...]:
        return self.spec.monitor.velocities

    @property
    def monitored(self) -> tuple[Label, ...]:
        """M = M_x union M_v, in label order."""

        def compute() -> tuple[Label, ...]:
            s = set(self.monitored_positions) | set(self.monitored_velocities)
            return tuple(lab for lab in self.labels if lab in s)

        return _MONITORED_KIND.get(self, (), compute)

    @property
    def attacked(self) -> tuple[Label, ...]:
        """Attacked actuators F of the spec's attack (empty without an attack)."""
        return self.spec.attack.actuators if self.spec.attack else ()

    def A(self, mode: str = NORMAL_MODE) -> np.ndarray:
        """Dense A_q (2N x 2N). For large N use the modal structure instead."""
        return state_matrix(self.laplacian(mode), self.alpha, self.gamma)

    def B(self, actuators: Iterable[Label] | None = None) -> np.ndarray:
        """B = [0; S_F^T] (2N x |F|); default F = the spec's attacked actuators."""
        F = self.idx(self.attacked if actuators is None else actuators)
        B = np.zeros((2 * self.n, len(F)))
        for c, i in enumerate(F):
            B[self.n + i, c] = 1.0
        return B

    def C(self) -> np.ndarray:
        """C = blkdiag(S_{M_x}, S_{M_v}) (|M_x| + |M_v| rows)."""
        px = self.idx(self.monitored_positions)
        pv = self.idx(self.monitored_velocities)
        C = np.zeros((len(px) + len(pv), 2 * self.n))
        for r, i in enumerate(px):
            C[r, i] = 1.0
        for r, i in enumerate(pv):
            C[len(px) + r, self.n + i] = 1.0
        return C

    def output_channels(self) -> tuple[str, ...]:
        """Names of the rows of C: ``"x:<label>"`` for positions, ``"v:<label>"`` for velocities."""
        return tuple(f"x:{a}" for a in self.monitored_positions) + tuple(f"v:{a}" for a in self.monitored_velocities)

    # -- connectivity -----------------------------------------------------------------------
    def components(self, mode: str = NORMAL_MODE) -> list[list[Label]]:
        """Connected components of the mode's graph, each in label order (computed once per mode, a fresh list each call)."""

        def compute() -> tuple[tuple[Label, ...], ...]:
            G = self.graph(mode)
            comps = [sorted(c, key=self.index.__getitem__) for c in nx.connected_components(G)]
            return tuple(tuple(c) for c in sorted(comps, key=lambda c: self.index[c[0]]))

        return [list(c) for c in _COMPONENTS_KIND.get(self, (self.check_mode(mode),), compute)]

    def require_connected(self, purpose: str) -> None:
        """Raise :class:`SpecError` if some mode's graph is disconnected.

        Used by the commands that assume connectivity (consensus simulation, observer
        placement); ``verify`` reports disconnection as the verdict of ``privacy.connected``.
        """
        for mode in self.modes:
            comps = self.components(mode)
            if len(comps) > 1:
                where = "graph" if mode == NORMAL_MODE else f"modes[{self.modes.index(mode) - 1}]"
                raise SpecError(
                    where,
                    f"the {mode} graph is disconnected ({len(comps)} components, e.g. {comps[-1][:6]}); "
                    f"{purpose} assumes a connected graph",
                    self.spec.source,
                )

    # -- clusters ---------------------------------------------------------------------------
    @property
    def clusters(self) -> tuple[ClusterSpec, ...]:
        return self.spec.clusters

    def cluster(self, name: str) -> ClusterSpec:
        for c in self.spec.clusters:
            if c.name == name:
                return c
        raise ModelError(f"no cluster named {name!r} (clusters: {', '.join(c.name for c in self.clusters) or 'none'})")

    def cluster_of(self, label: Label) -> str:
        """Name of the cluster holding ``label``."""
        if label in self._cluster_of:
            return self._cluster_of[label]
        raise ModelError(f"node {label!r} is in no cluster")

    def adjacency(self, mode: str = NORMAL_MODE) -> dict[Label, tuple[Label, ...]]:
        """Neighbour lists of every agent in the mode's graph, in label order (built once per mode, O(E log E))."""
        self.check_mode(mode)
        if mode not in self._adjacency:
            nbrs: dict[Label, list[Label]] = {lab: [] for lab in self.labels}
            for key in self._edges[mode]:
                u, v = tuple(key)
                nbrs[u].append(v)
                nbrs[v].append(u)
            self._adjacency[mode] = {lab: tuple(sorted(ns, key=self.index.__getitem__)) for lab, ns in nbrs.items()}
        return self._adjacency[mode]

    def neighbours(self, label: Label, mode: str = NORMAL_MODE) -> list[Label]:
        """Neighbours of ``label`` in the mode's graph, in label order."""
        if label not in self.index:
            return []
        return list(self.adjacency(mode)[label])

    def observers(self, cluster: str | None = None) -> list[LocalObserver]:
        """Local observers with their measured sets resolved (default: centre + neighbours in P_i).

        Resolved once per cluster (kept on ``analysis``); each call returns a new list.
        """
        if cluster is not None:
            self.cluster(cluster)

        def resolve() -> tuple[LocalObserver, ...]:
            return tuple(self.resolve_observer(c, o) for c in self.spec.clusters if cluster is None or c.name == cluster for o in c.observers)

        return list(_OBSERVERS_KIND.get(self, (cluster,), resolve))

    def resolve_observer(self, cluster: ClusterSpec, obs: ObserverSpec) -> LocalObserver:
        near = set(self.neighbours(obs.center))
        default = tuple(lab for lab in cluster.nodes if lab == obs.center or lab in near)
        return LocalObserver(
            cluster.name,
            obs.center,
            obs.positions if obs.positions is not None else default,
            obs.velocities if obs.velocities is not None else default,
            obs.poles,
        )

    def cluster_unchanged(self, name: str, mode: str) -> bool:
        """Whether ``mode`` is not the normal mode and no link it changes has an end in cluster ``name``.

        The cluster's block L[P_i, P_i], its cut edges and its couplings are then those of the
        normal mode, and so is everything computed from them alone.
        """
        if self.check_mode(mode) == NORMAL_MODE:
            return False
        members = set(self.cluster(name).nodes)
        return not any(a in members or b in members for a, b, _ in self.switching_links(mode))

    def cluster_model(self, name: str, mode: str = NORMAL_MODE) -> ClusterModel:
        """The cluster subsystem of eq. ``cluster_dyn2`` for cluster ``name`` in ``mode``.

        Built once per (cluster, mode) in time proportional to the cluster and its cut edges
        (neighbour lists, not a scan of every edge); the blocks A^{ij} exist only for the
        clusters it is coupled to.
        """
        key = (name, self.check_mode(mode))
        if key in self._cluster_models:
            return self._cluster_models[key]
        c = self.cluster(name)
        members = set(c.nodes)
        if self.cluster_unchanged(name, mode):
            # its block, cut edges and couplings are those of the normal mode (shared, read-only
            # arrays: one copy, not one per mode)
            model = dataclasses.replace(self.cluster_model(name, NORMAL_MODE), mode=mode)
            self._cluster_models[key] = model
            return model
        idx = self.idx(c.nodes)
        Ls = self.laplacian_sparse(mode)[idx][:, idx]
        Lii = Ls.toarray()
        A = state_matrix_sparse(Ls, self.alpha, self.gamma)
        local = {lab: i for i, lab in enumerate(c.nodes)}
        edges = self._edges[mode]
        adj = self.adjacency(mode)
        cut: list[tuple[Label, Label, Fraction]] = []
        for u in c.nodes:
            for v in adj[u]:
                if v not in members:
                    cut.append((u, v, edges[frozenset((u, v))]))
        cut.sort(key=lambda t: (self.index[t[0]], self.index[t[1]]))
        with_cut = {t[0] for t in cut}
        boundary = tuple(lab for lab in c.nodes if lab in with_cut)
        n = len(c.nodes)
        E = np.zeros((2 * n, len(boundary)))
        for col, lab in enumerate(boundary):
            E[n + local[lab], col] = 1.0
        coupling: dict[str, scipy.sparse.csr_matrix] = {}
        for other in self.spec.clusters:
            links = [(local[u], v, w) for u, v, w in cut if self._cluster_of.get(v) == other.name]
            if other.name == name or not links:
                continue
            theirs = {lab: j for j, lab in enumerate(other.nodes)}
            # -alpha L_ij = alpha w for a cut edge (L_ij = -fl(w), as laplacian() rounds it)
            rows = [n + i for i, _, _ in links]
            cols = [theirs[v] for _, v, _ in links]
            vals = [self.alpha * float(w) for _, _, w in links]
            coupling[other.name] = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(2 * n, 2 * len(other.nodes)))
        for X in (Lii, E, A.data, A.indices, A.indptr):
            X.setflags(write=False)
        model = ClusterModel(name, mode, c.nodes, Lii, A, boundary, tuple(cut), E, coupling)
        self._cluster_models[key] = model
        return model

    def cluster_laplacian_exact(self, name: str, mode: str = NORMAL_MODE) -> list[list[Fraction]]:
        """Principal block L[P_i, P_i] with exact rational entries (a fresh copy of a stored block).

        The nonzeros of :meth:`cluster_laplacian_entries` (its degrees count every edge, cut
        edges included) laid out as rows.
        """
        mode = self.check_mode(mode)

        def build() -> list[list[Fraction]]:
            n = len(self.cluster(name).nodes)
            L = [[Fraction(0)] * n for _ in range(n)]
            for (i, j), v in self.cluster_laplacian_entries(name, mode).items():
                L[i][j] = v
            return L

        return [row[:] for row in _CLUSTER_LAPLACIAN_EXACT_KIND.get(self, (name, mode), build)]

    def cluster_laplacian_entries(self, name: str, mode: str = NORMAL_MODE) -> dict[tuple[int, int], Fraction]:
        """The nonzero entries of L[P_i, P_i] (cluster indices) as exact rationals.

        Built from the cluster's neighbour lists in time proportional to its edges, cut edges
        included (they count in the degrees); kept on ``system.analysis`` and shared by every
        caller: the returned mapping must not be modified.
        """
        mode = self.check_mode(mode)
        if self.cluster_unchanged(name, mode):
            return self.cluster_laplacian_entries(name, NORMAL_MODE)

        def build() -> dict[tuple[int, int], Fraction]:
            nodes = self.cluster(name).nodes
            loc = {a: i for i, a in enumerate(nodes)}
            edges = self._edges[mode]
            adj = self.adjacency(mode)
            ent: dict[tuple[int, int], Fraction] = {}
            for a in nodes:
                i = loc[a]
                ws = [(b, edges[frozenset((a, b))]) for b in adj[a]]
                for b, w in ws:
                    if b in loc:
                        ent[(i, loc[b])] = -w  # one link per pair of agents
                ent[(i, i)] = sum((w for _, w in ws), Fraction(0))
            return {k: v for k, v in ent.items() if v}

        return _CLUSTER_LAPLACIAN_ENTRIES_KIND.get(self, (name, mode), build)

    # -- convenience ------------------------------------------------------------------------
    @classmethod
    def from_spec_file(cls, path: str) -> System:
        from glocal_verify.spec import load_spec

        return cls(load_spec(path))

    # -- interoperability and display -------------------------------------------------------
    def to_statespace(self, mode: str = NORMAL_MODE) -> Any:
        """The closed loop of eq. ``cl_sys`` in ``mode`` as a python-control ``StateSpace``.

        .. math::

            \\dot x = A_q x + B u_a,\\quad y = C x,\\qquad
            A_q = \\begin{bmatrix} 0 & I \\\\ -\\alpha L_q & -\\gamma I \\end{bmatrix},\\
            B = \\begin{bmatrix} 0 \\\\ S_F^\\top \\end{bmatrix},\\
            C = \\operatorname{blkdiag}(S_{M_x}, S_{M_v}),\\ D = 0

        with F the spec's attacked actuators (no input when the spec has no attack) and
        :math:`M_x, M_v` its global monitors. Entries are the floats of the spec's exact
        rationals (:meth:`A`, :meth:`B`, :meth:`C`); the states are named ``x:<label>`` and
        ``v:<label>``, the inputs ``u:<label>``, the outputs as :meth:`output_channels`.

        Parameters
        ----------
        mode : str
            The mode q (``"normal"`` or a safe mode).

        Returns
        -------
        control.StateSpace

        Raises
        ------
        NotApplicableError
            When python-control is not installed (``pip install 'glocal-verify[control]'``).
        ModelError
            For an unknown mode.
        """
        self.check_mode(mode)
        A, B, C = self.A(mode), self.B(), self.C()
        D = np.zeros((C.shape[0], B.shape[1]))
        return state_space(
            A,
            B,
            C,
            D,
            states=[f"x:{a}" for a in self.labels] + [f"v:{a}" for a in self.labels],
            inputs=[f"u:{a}" for a in self.attacked],
            outputs=list(self.output_channels()),
            name=f"{self.name}[{mode}]",
        )

    def _facts(self) -> list[tuple[str, str]]:
        def short(xs: Sequence[object], limit: int = 8) -> str:
            text = ", ".join(str(x) for x in xs[:limit])
            return f"{text}, ... ({len(xs)})" if len(xs) > limit else text

        clusters = [f"{c.name} ({len(c.nodes)})" for c in self.clusters]
        atk = self.spec.attack
        return [
            ("agents", str(self.n)),
            ("edges", str(len(self._edges[NORMAL_MODE]))),
            ("modes", short(self.modes)),
            ("clusters", short(clusters) or "none"),
            ("local observers", str(sum(len(c.observers) for c in self.clusters))),
            ("monitors", f"x: [{short(self.monitored_positions)}], v: [{short(self.monitored_velocities)}]"),
            ("attack", f"{atk.kind} on [{short(atk.actuators)}]" if atk else "none"),
        ]

    def __repr__(self) -> str:
        facts = dict(self._facts())
        return (
            f"<System {self.name!r}: N={facts['agents']}, modes {facts['modes']}; clusters {facts['clusters']}; "
            f"monitors {facts['monitors']}; attack {facts['attack']}>"
        )

    def _repr_markdown_(self) -> str:
        """A small Markdown table of the system (Jupyter)."""
        rows = "\n".join(f"| {k} | {v.replace('|', '/')} |" for k, v in self._facts())
        return f"**System** `{self.name}`\n\n| | |\n|---|---|\n{rows}\n"

    def _repr_html_(self) -> str:
        """A small HTML table of the system (Jupyter); every string is HTML-escaped."""
        from html import escape

        rows = "".join(f"<tr><th>{escape(k)}</th><td>{escape(v)}</td></tr>" for k, v in self._facts())
        return f"<div><p><b>System</b> <code>{escape(self.name)}</code></p><table>{rows}</table></div>"
