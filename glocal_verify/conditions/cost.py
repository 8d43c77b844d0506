"""What a command will cost, estimated from the spec's sizes before any computation.

A run of ``verify``, ``place-observers``, ``audit`` or ``design`` is dominated by dense
:math:`O(N^3)` factorizations of N x N Laplacians and by the dense linear algebra of each
cluster's :math:`2 n_i`-state model. Both are predictable from the sizes alone: N, the cluster
sizes :math:`n_i`, the local observers, the safe modes (and which clusters they change), the
monitored channels and the attack. This module turns those sizes into an estimate of seconds
and peak memory (:class:`CostEstimate`), and compares it with :class:`Limits` so that a run
that would take hours or exhaust memory is refused at once with one line giving the estimate
(:func:`check_limits`, :class:`SizeLimitError`); the command line lifts the limits with
``--allow-large``.

Nothing here builds a :class:`~glocal_verify.model.System`'s spectra: :meth:`SpecSizes.from_spec`
reads the :class:`~glocal_verify.spec.types.SystemSpec` in time linear in its size, so the
estimate of a 20,000-agent spec is instant. Every function is pure; the only input read from
the machine is the available memory of :func:`default_limits`.

The constants (``C_*``) were measured on a 2-core x86_64 machine with
``OPENBLAS_NUM_THREADS=1`` (``glocal-verify verify SPEC --quiet`` on
``random_clustered_spec(N, 3, seed=7)`` for N = 250 ... 3000, its checkers timed one by one,
peak memory as ``ru_maxrss``) and rounded up; ``docs/performance.md`` ("Size limits and
estimates") lists the measurements. Expect the seconds within a factor of about two on such a
machine; the memory is meant to err high.
"""

from __future__ import annotations

import math
import os
import dataclasses
from dataclasses import dataclass, field
from typing import Iterable, Sequence

from glocal_verify import config
from glocal_verify.conditions.catalogue import CATALOGUE, DESIGN_ASSESSMENT_IDS
from glocal_verify.conditions.exact_cost import exact_seconds
from glocal_verify.simulation.limits import THRESHOLD_ARRAYS, SizeLimitError, detector_work, refuse, samples_over
from glocal_verify.spec.types import SystemSpec

__all__ = [
    "dense_bytes",
    "phase_estimate",
    "SizeLimitError",
    "SpecSizes",
    "CostEstimate",
    "Limits",
    "default_limits",
    "estimate_verify",
    "estimate_place_observers",
    "estimate_audit",
    "audit_set_seconds",
    "estimate_design",
    "refusal",
    "check_limits",
    "format_seconds",
    "format_bytes",
]

GIB = 1024.0**3
MIB = 1024.0**2

# --------------------------------------------------------------------------------------------
# constants (seconds per flop-like unit on one core; arrays counted at the peak)

#: start-up of a command (imports, loading, report): seconds
C_START = 3.0
#: resident memory of a command before its matrices (interpreter, numpy, scipy): bytes
B_BASE = 300 * MIB

#: global checkers, fit to whole verify runs on random_clustered_spec(N, 3, seed=7) (two one-link
#: safe modes, four links between clusters) with one BLAS thread: 5.9 / 7.7 / 26 / 235 CPU-s at
#: N = 1000 / 2000 / 4000 / 10,000, their local parts the terms below. A spectrum: C_EIGH per
#: n^3 for an eigendecomposition with its certified bounds (the normal mode's N^3, or the sum
#: of its clusters' n_i^3 when it is built from blocks: 3 x 3333 agents in 21.6 s), C_FACTOR
#: per N^2 for each rank-one factor (a link between clusters of a block-built normal mode, a
#: changed link of a safe mode: its secular equation, certificate and the rows read through
#: it, 4.3-8 s at 10,000), C_GLOBAL_MODE per N^3 for a safe mode decomposed afresh (more than
#: rank_one_max_changes links, or fewer than rank_one_min_agents agents). The rest of the global
#: work (the ZDA staircase on the modal pencil, the modal analyses, the switched recursion) is
#: C_GLOBAL_REST N^3 + C_GLOBAL_REST_SQ N^2: 10 s at 4000, 82 s at 10,000.
C_EIGH = 2.1e-10
C_FACTOR = 8e-8
C_GLOBAL_MODE = 0.5e-9
C_GLOBAL_REST = 3.3e-11
C_GLOBAL_REST_SQ = 5e-7
#: dense N x N float64 arrays the global checkers hold at their peak: A_GLOBAL with an explicit
#: normal eigenbasis (the basis, the eigh workspace, its syrk, the modal pencil's two staircase
#: buffers), plus A_GLOBAL_MODE per safe mode decomposed afresh (a factored one keeps O(N)); a
#: normal mode built from blocks holds A_GLOBAL_BLOCKS (the staircase; its blocks are small:
#: measured 0.8 beside base and UIO memory at N = 4000, 1.6 at 10,000); local checkers alone hold one
A_GLOBAL = 5.0
A_GLOBAL_MODE = 1.0
A_GLOBAL_BLOCKS = 2.0
A_LOCAL_ONLY = 1.0

#: local.uio: seconds per (2 n_i)^3 per observer design (one per observer and distinct cluster
#: block: the normal mode and every safe mode that changes the cluster). Measured 9.8-13.4 s per
#: design at 2 n_i = 1334 (4.1e-9 - 5.7e-9), 2.1 s at 2 n_i = 667 (6.9e-9).
C_UIO = 6.5e-9
#: local.uio on clusters of at least modal_min_agents agents (numeric): the modal design and
#: certificate (one eigh of the interior block, n-sized work per observer), seconds per
#: (2 n_i)^3 per design: 9.6 s for the five designs of 2 n_i ~ 2666 at N = 4000 (11.2 s before
#: the sparse residual checks), 2.8 s at 2000, about 60 s for the designs of 2 n_i ~ 6666 at
#: 10,000 (the n-sized work makes the cubic term err high there)
C_UIO_MODAL = 0.8e-10
#: arrays of (2 n_i)^2 doubles each design keeps until the checker ends (measured 6.3 beside
#: the global arrays, 12 alone, at N = 2000 and 3000)
A_UIO = 10.0
#: the same for a modal design, which keeps n-sized factors only and reads the cluster's A^i in
#: sparse form: 1 covers the N = 4000 and 10,000 runs (0.96 and 5.1 GiB) with the global arrays
A_UIO_MODAL = 1.0
#: local.pencil: seconds per (2 n_i)^3 per case (an observer and one suspected set: "attack"
#: when the spec has one, and "all"): about 7 s for the six cases of 2 n_i ~ 2666 at N = 4000
#: (30 s before the sparse residuals and the fused deflation steps), about 60 s at N = 10,000.
C_PENCIL = 0.6e-10

#: switching.detects with simulation (``--simulate always`` above ``detects_max_agents`` agents): seconds per N^3
#: per safe mode (61 s for one N = 1000 run, reports/benchmarks.md)
C_SIMULATE = 6.1e-8
#: and per output sample of each simulated switch: a constant and a term per (2N)^2 (the modal
#: propagation); 30 us a sample measured on a 4-agent spec with 200,001 samples (5.5 s)
C_SIMULATE_SAMPLE = 3.0e-5
C_SIMULATE_SAMPLE_N2 = 2.5e-8
#: bytes a simulated switch keeps per sample and stored state (the trajectories, the residuals):
#: about 1 kB a sample on the 4-agent spec (16 stored states)
SIMULATION_BYTES_PER_SAMPLE_STATE = 40.0
#: the certified thresholds and guarantees of detection.*: seconds per sample and unit of
#: detector work sum q (d + 2) (0.18 ms a sample for paper19's sampled deployment, work 656)
C_THRESHOLD = 3.0e-7

#: exact arithmetic (``--exact``, and ``verify``'s re-decisions): :func:`exact_seconds`, with the
#: tunables ``exact_central_seconds_n4``, ``exact_zda_seconds_n3``, ``exact_zda_dense_seconds_n4``,
#: ``zda_certificate_seconds_n3`` and ``exact_global_seconds_n3`` of :mod:`glocal_verify.config`
#: (their measurements are documented there). Exact local.uio per design and local.pencil per case: seconds per (2 n_i)^3 (3.8 s for 5
#: designs and 5.5 s for 6 cases at 2 n_i ~ 134, random_clustered_spec(200, 3, seed=7))
C_EXACT_UIO = 5e-7
C_EXACT_PENCIL = 6e-7
#: exact memory: bytes per N^2 (rational entries; 833 MiB peak at N = 120)
B_EXACT = 48_000.0

#: place-observers: seconds per (2 n_i)^3 and per (2 n_i)^2 for each cluster searched (fit to
#: 21.5 s per cluster at 2 n_i = 1334, 3.4 s at 667, 0.16 s at 200); memory: N x N arrays and
#: (2 n_i)^2 arrays per cluster, kept (peak 1.0 GiB at N = 2000 with 3 clusters)
C_PLACE = 9e-9
C_PLACE_SQ = 2.5e-6
A_PLACE = 5.0
A_PLACE_CLUSTER = 18.0

#: audit, measured in CPU seconds on random_clustered_spec(N, c, seed=1) (N = 200 / 10
#: clusters, 300 / 3, 500 / 10, 1000 / 50), samples of singles, pairs inside one cluster and
#: pairs across clusters:
#: - set-up (spectrum, minor tables, Theorem III.3 per mode): C_AUDIT_SETUP N^3 (0.15 s at
#:   N = 200, 9.2 s at N = 1000);
#: - per candidate, its local verdicts: C_AUDIT_AGENT + C_AUDIT_AGENT_N N + C_AUDIT_AGENT_LOCAL
#:   (2 n_c)^3 with n_c its cluster's size (5.3 ms at n_c = 20, 20 ms at 50, 0.34 s at 100);
#: - per single actuator, its ZDA: C_AUDIT_SINGLE_0 + C_AUDIT_SINGLE N^3 (7.4 ms at N = 200,
#:   about 1.3 s at N = 1000, where many singles need their whole zero set);
#: - per larger set C_AUDIT_SET + C_AUDIT_SET_SQ N^2 (0.23 ms at N = 200, 0.4 ms at N = 1000 since
#:   a worker keeps its memo across chunks: 181 CPU-s for the 499,500 pairs, profiled),
#:   plus C_AUDIT_SET_INTRA + C_AUDIT_SET_LOCAL (2 n_c)^3 when two of its agents share a cluster
#:   (0.8 ms at n_c = 20, 3.2 ms at 50, 43 ms at 100);
#: - per row, writing it out: C_AUDIT_ROW_OUT.
#: A set whose minor certificate fails gets the whole O(N^3) zero-set analysis when a safe mode
#: may expose it; how many do is not known from the sizes (none on the 50-cluster network, a
#: fifth of the pairs on the 3-cluster N = 300 one, whose audit the estimate puts 3x low). The
#: whole N = 1000 audit (50 clusters, k = 2, JSON, 2 workers): 226 s and 3540 MiB summed over the
#: processes on 2026-12-06 (estimate 4.8 min); a single costs about 0.15 s there since the minors'
#: random combinations and the local zero search decide it (it was 1.2 s, the whole zero set), a
#: pair about 0.36 ms (one core, nothing else running).
C_AUDIT_SETUP = 1.2e-8
C_AUDIT_AGENT = 3e-3
C_AUDIT_AGENT_N = 1.3e-5
C_AUDIT_AGENT_LOCAL = 4.5e-8
C_AUDIT_SINGLE_0 = 5e-3
C_AUDIT_SINGLE = 1.2e-10
C_AUDIT_SET = 2e-4
C_AUDIT_SET_SQ = 2e-10
C_AUDIT_SET_INTRA = 4e-4
C_AUDIT_SET_LOCAL = 4e-9
#: the safe modes' part of a row: each set is tested against every safe mode that meets
#: Theorem III.3 (its touch test, the exposing modes of the row), seconds per set and per safe
#: mode. Measured on random_clustered_spec(60, 3, seed=1) with 15 monitors, k = 2 (1830 sets):
#: 10 s with 2 safe modes, 114 s with 50, 271 s with 100, i.e. 1.2-1.5 ms per set and mode.
#: The constants above were fit on specs with cost_calibration_modes safe modes, so only the
#: modes beyond those count. Safe modes that fail Theorem III.3 cost almost nothing (N = 120
#: with 20 such modes took no longer than with 2), so this term is an upper estimate there
C_AUDIT_SET_MODE = 1.5e-3
#: audit memory: N x N arrays (eigenvectors, minor tables: 136 MB at N = 1000) and bytes per row
#: held until the report is written: 3.5 kB per row with the shared memo (traced); rows received
#: from a worker share their repeated parts (SharedParts). The N = 1000 audit of 500,500 rows on
#: 2 workers peaked at 3540 MiB summed over its three processes on 2026-12-06 (main 2.0 GB,
#: workers about 0.7 GB each; estimate 3.5 GiB): 6.5 kB per row with the workers' share
A_AUDIT = 20.0
B_AUDIT_ROW = 6_500.0
#: writing a row (JSON or Markdown text): seconds (the 1.4 GB JSON of 500,500 rows took about 60-80 s)
C_AUDIT_ROW_OUT = 2e-4
#: exact audit rows (``--exact``): a factor on the per-set seconds
F_AUDIT_EXACT = 10.0
C_AUDIT_EXACT_FALLBACK = 0.01  # N <= exact_fallback_full_agents: rows re-decided over Q, s per set and safe mode (paper19: 5.4 CPU-s)

#: the default limits are the tunables ``max_seconds``, ``max_bytes`` (with ``memory_fraction`` of
#: the available memory) and ``notice_seconds`` of :mod:`glocal_verify.config`

#: condition ids of the cluster-level checkers (the rest need the global spectra)
LOCAL_CHEAP = frozenset({"local.k-connected", "local.rank"})


# --------------------------------------------------------------------------------------------
# sizes


@dataclass(frozen=True, slots=True)
class SpecSizes:
    """The sizes an estimate needs, read from a spec without any linear algebra.

    Attributes
    ----------
    n : int
        Agents N.
    cluster_sizes : tuple of int
        n_i of every cluster, in spec order.
    cluster_names : tuple of str
    observers : tuple of int
        Local observers of every cluster.
    changed_by_modes : tuple of int
        For every cluster, the safe modes whose link changes touch one of its agents (its
        block L[P_i, P_i] changes, so its observer is designed again).
    mode_changes : tuple of int
        For every safe mode, the number of links it adds or removes.
    modes : int
        Safe modes (the normal mode not counted).
    channels : int
        Globally monitored channels |M_x| + |M_v|.
    attack : bool
        Whether the spec has an attack (local checkers then run two suspected sets).
    cut_links : int
        Links of the normal mode between two clusters.
    partitioned : bool
        Whether the clusters (two or more) hold every agent once: the normal mode can then be
        built from their blocks (:meth:`System.spectrum <glocal_verify.model.System.spectrum>`).
    samples : int
        Output samples of one simulation of the spec, ``floor(horizon / step) + 1``.
    threshold_samples : int
        Samples K of the certified thresholds, ``floor(horizon / period) + 1`` with
        ``[implementation]``; 0 without.
    detector_work : int
        :math:`\\sum_o q_o (d_o + 2)` over the sampled deployment's detectors (the central
        observer: its channels times 2N; a local observer: twice its measured agents times
        2 n_i), the (q, d) of :func:`~glocal_verify.simulation.limits.estimate_threshold_size`.
    """

    n: int
    cluster_sizes: tuple[int, ...] = ()
    cluster_names: tuple[str, ...] = ()
    observers: tuple[int, ...] = ()
    changed_by_modes: tuple[int, ...] = ()
    modes: int = 0
    mode_changes: tuple[int, ...] = ()
    channels: int = 0
    attack: bool = False
    cut_links: int = 0
    partitioned: bool = False
    samples: int = 0
    threshold_samples: int = 0
    detector_work: int = 0

    @property
    def block_built(self) -> bool:
        """Whether the normal mode is built from its clusters' blocks (the rule of :class:`~glocal_verify.model.System`)."""
        return self.partitioned and self.n >= config.get("block_min_agents") and 0 < self.cut_links <= config.get("block_max_cut_links")

    @classmethod
    def from_spec(cls, spec: SystemSpec) -> SpecSizes:
        """The sizes of ``spec``, in time linear in its nodes, edges and link changes.

        Parameters
        ----------
        spec : SystemSpec
        """
        touched: list[set[object]] = []
        for m in spec.modes:
            nodes: set[object] = set()
            for e in m.add:
                nodes.update((e.u, e.v))
            for u, v in m.remove:
                nodes.update((u, v))
            touched.append(nodes)
        changed = []
        owner: dict[object, int] = {}
        for k, c in enumerate(spec.clusters):
            members = set(c.nodes)
            changed.append(sum(1 for t in touched if not members.isdisjoint(t)))
            owner.update((x, k) for x in c.nodes)
        partitioned = len(spec.clusters) >= 2 and len(owner) == len(spec.nodes) == sum(len(c.nodes) for c in spec.clusters)
        cut = sum(1 for e in spec.edges if owner.get(e.u, -1) != owner.get(e.v, -2)) if partitioned else 0
        horizon = float(spec.simulation.horizon)
        samples = samples_over(horizon, float(spec.simulation.step))
        k_thr, work = 0, 0
        if spec.implementation is not None:
            k_thr = samples_over(horizon, float(spec.implementation.period))
            work = detector_work(spec)
        return cls(
            n=len(spec.nodes),
            cluster_sizes=tuple(len(c.nodes) for c in spec.clusters),
            cluster_names=tuple(c.name for c in spec.clusters),
            observers=tuple(len(c.observers) for c in spec.clusters),
            changed_by_modes=tuple(changed),
            modes=len(spec.modes),
            mode_changes=tuple(len(m.add) + len(m.remove) for m in spec.modes),
            channels=len(spec.monitor.positions) + len(spec.monitor.velocities),
            attack=spec.attack is not None,
            cut_links=cut,
            partitioned=partitioned,
            samples=samples,
            threshold_samples=k_thr,
            detector_work=work,
        )

    def only_cluster(self, name: str | None) -> SpecSizes:
        """The same sizes with only cluster ``name`` (all clusters when None or unknown).

        Parameters
        ----------
        name : str, optional
        """
        if name is None or name not in self.cluster_names:
            return self
        i = self.cluster_names.index(name)
        return dataclasses.replace(
            self, cluster_sizes=(self.cluster_sizes[i],), cluster_names=(name,), observers=(self.observers[i],), changed_by_modes=(self.changed_by_modes[i],)
        )


# --------------------------------------------------------------------------------------------
# estimates


@dataclass(frozen=True, slots=True)
class CostEstimate:
    """Estimated seconds and peak memory of one command (:func:`estimate_verify` and friends).

    Attributes
    ----------
    command : str
        ``verify``, ``place-observers``, ``audit`` or ``design``.
    n : int
        Agents.
    seconds : float
        Estimated wall time on one core.
    bytes : float
        Estimated peak resident memory.
    dense_arrays : float
        N x N float64 arrays counted in ``bytes`` (8 N^2 bytes each).
    phases : tuple of (str, float)
        Seconds of each phase, largest first.
    extra_seconds : float
        Time the run may add on top, bounded by an option (``verify``'s exact re-decisions,
        ``--exact-budget``); counted against the time limit, not in ``seconds``.
    """

    command: str
    n: int
    seconds: float
    bytes: float
    dense_arrays: float = 0.0
    phases: tuple[tuple[str, float], ...] = field(default_factory=tuple)
    extra_seconds: float = 0.0

    @property
    def bound_seconds(self) -> float:
        """``seconds + extra_seconds``: what the time limit is compared with."""
        return self.seconds + self.extra_seconds

    def describe(self) -> str:
        """``"36 min and 15 GiB (5 dense 20000 x 20000 arrays; mostly global spectra)"``."""
        parts = []
        if self.dense_arrays >= 1:
            parts.append(f"{self.dense_arrays:.3g} dense {self.n} x {self.n} arrays")
        if self.phases and self.phases[0][1] > 0:
            parts.append(f"mostly {self.phases[0][0]}")
        extra = f" (+ up to {format_seconds(self.extra_seconds)} of exact re-decisions)" if self.extra_seconds > 0 else ""
        inner = f" ({'; '.join(parts)})" if parts else ""
        return f"{format_seconds(self.seconds)}{extra} and {format_bytes(self.bytes)}{inner}"


def phase_estimate(command: str, n: int, phases: dict[str, float], nbytes: float, arrays: float, extra: float = 0.0) -> CostEstimate:
    """A :class:`CostEstimate` from named phases (seconds), with the start-up constant :data:`C_START` once."""
    ordered = tuple(sorted(((k, float(v)) for k, v in phases.items() if v > 0), key=lambda kv: -kv[1]))
    return CostEstimate(command, n, C_START + sum(v for _, v in ordered), float(nbytes), float(arrays), ordered, float(extra))


def dense_bytes(n: int) -> float:
    """Bytes of one dense N x N float64 array."""
    return 8.0 * float(n) ** 2


def _designs(s: SpecSizes) -> list[tuple[int, int]]:
    """(2 n_i, UIO designs) of every cluster: observers x (1 + safe modes changing it)."""
    return [(2 * ni, obs * (1 + ch)) for ni, obs, ch in zip(s.cluster_sizes, s.observers, s.changed_by_modes)]


def _cases(s: SpecSizes) -> list[tuple[int, int]]:
    """(2 n_i, local cases) of every cluster: observers x suspected sets (attack and all)."""
    per = 2 if s.attack else 1
    return [(2 * ni, obs * per) for ni, obs in zip(s.cluster_sizes, s.observers)]


def estimate_verify(
    sizes: SpecSizes,
    only: Iterable[str] | None = None,
    *,
    exact: bool = False,
    simulate: bool = False,
    exact_budget: float | None = config.IN_FORCE,
) -> CostEstimate:
    """Seconds and peak memory of ``verify`` (every checker, or those of ``only``).

    With N agents, S safe modes, clusters of :math:`n_i` agents, :math:`d_i` UIO designs
    (observers times one plus the safe modes that change the cluster) and :math:`c_i` local
    cases (observers times the suspected sets):

    .. math::

        t = C_{start} + [\\text{global}]\\, \\big(T_1 + C_{g,m} S_e N^3 + C_f \\textstyle\\sum_u c_u N^2
            + C_r N^3 + C_{r,2} N^2 + (C_{m,0} + C_{m,2} N^2) \\max(0, S - 2)\\big)
            + [\\texttt{local.uio}] \\sum_i C_{uio} d_i (2 n_i)^3
            + [\\texttt{local.pencil}] \\sum_i C_{pencil} c_i (2 n_i)^3

        m = B_{base} + 8 N^2 a + \\sum_i 8 (2 n_i)^2 A_{uio} d_i,\\quad
            a = A + A_{g,m} S_e \\ (\\text{a global checker selected, else } 1)

    with ``T_1`` the normal mode: ``C_e sum_i n_i^3 + C_f K N^2`` when it is built from its
    clusters' blocks (``K`` links between clusters, :attr:`SpecSizes.block_built`; then
    ``A`` = :data:`A_GLOBAL_BLOCKS`), else ``C_e N^3`` (``A`` = :data:`A_GLOBAL`); ``S_e``
    the safe modes decomposed afresh and ``c_u`` the changed links of each factored one (at most
    ``rank_one_max_changes``, N >= ``rank_one_min_agents``); plus, with ``simulate``, the
    samples of one simulated switch per safe mode, :math:`\\max(1, S)\\, n_s (C_{s,0} + C_{s,2} (2N)^2)`
    (``n_s = horizon / step + 1``), and with ``detection.*`` on a sampled deployment the certified
    thresholds, :math:`C_{thr} K \\sum_o q_o (d_o + 2)` seconds and ``THRESHOLD_ARRAYS`` (K, q, d)
    arrays (:attr:`SpecSizes.threshold_samples`, :attr:`SpecSizes.detector_work`); plus, with ``simulate``,
    :math:`C_{sim} N^3 \\max(1, S)` for ``switching.detects`` above
    ``detects_max_agents`` (:mod:`glocal_verify.config`) agents, and with ``exact`` the rational terms of :func:`exact_seconds` (``central.observer``
    in N^4, ``stealthy.zda`` and ``switching.avoids-attack`` on their fast path in N^3 each, the
    other global checkers in N^3), :data:`C_EXACT_UIO` and :data:`C_EXACT_PENCIL` per
    design and case, :data:`B_EXACT` N^2 bytes). :math:`C_{uio}` is :data:`C_UIO_MODAL` = 0.8e-10
    for clusters of at least ``modal_min_agents`` agents in a numeric run (the modal
    design), else :data:`C_UIO` = 6.5e-9. Constants: :data:`C_START` = 3 s,
    :data:`C_EIGH` (``C_e``) = 2.1e-10, :data:`C_FACTOR` (``C_f``) = 8e-8,
    :data:`C_GLOBAL_MODE` = 0.5e-9, :data:`C_GLOBAL_REST` (``C_r``) = 3.3e-11,
    :data:`C_GLOBAL_REST_SQ` = 5e-7, ``cost_mode_seconds`` (``C_{m,0}``) = 0.25, ``cost_mode_seconds_sq`` (``C_{m,2}``) = 3.5e-7,
    :data:`C_PENCIL` = 0.6e-10 s, :data:`A_GLOBAL` = 5,
    :data:`A_GLOBAL_BLOCKS` = 2, :data:`A_GLOBAL_MODE` = 1,
    :data:`A_UIO` = 10 (:data:`A_UIO_MODAL` = 1 for a modal design), :data:`B_BASE` = 300 MiB;
    measured as the module docstring says.

    Parameters
    ----------
    sizes : SpecSizes
    only : iterable of str, optional
        Resolved condition ids to run (default: the whole catalogue). ``local.*`` ids cost their
        clusters; any other id costs the global spectra (all of it: the global checkers share
        them).
    exact : bool
        ``--exact``: every checker in rational arithmetic.
    simulate : bool
        ``switching.detects`` simulates (``--simulate always``, or auto up to ``detects_max_agents`` agents).
    exact_budget : float, optional
        ``--exact-budget`` of a numeric run (None or 0: no limit, then not counted; default the
        tunable ``exact_budget`` in force); becomes
        :attr:`CostEstimate.extra_seconds`.

    Returns
    -------
    CostEstimate
    """
    ids = set(CATALOGUE) if only is None else set(only)
    n, S = sizes.n, sizes.modes
    phases: dict[str, float] = {}
    glob = any(not c.startswith("local.") and c != "switching.detects" for c in ids)
    uio, pencil = "local.uio" in ids, "local.pencil" in ids
    n3 = float(n) ** 3
    updated = [c for c in sizes.mode_changes if 0 < c <= config.get("rank_one_max_changes")][:S] if n >= config.get("rank_one_min_agents") else []
    fresh = S - len(updated)
    if glob:
        n2 = float(n) ** 2
        if sizes.block_built:
            normal = C_EIGH * sum(float(k) ** 3 for k in sizes.cluster_sizes) + C_FACTOR * sizes.cut_links * n2
        else:
            normal = C_EIGH * n3
        phases["global spectra"] = normal + C_GLOBAL_MODE * fresh * n3 + C_FACTOR * sum(updated) * n2
        phases["global checkers"] = C_GLOBAL_REST * n3 + C_GLOBAL_REST_SQ * n2 + (config.get("cost_mode_seconds") + config.get("cost_mode_seconds_sq") * n2) * max(0, S - config.get("cost_calibration_modes"))
    modal_min = config.get("modal_min_agents")
    if uio:
        phases["local.uio"] = sum((C_UIO if exact or m < 2 * modal_min else C_UIO_MODAL) * d * float(m) ** 3 for m, d in _designs(sizes))
    if pencil:
        phases["local.pencil"] = sum(C_PENCIL * c * float(m) ** 3 for m, c in _cases(sizes))
    if simulate and "switching.detects" in ids:
        runs = max(1, S)
        per_sample = C_SIMULATE_SAMPLE + C_SIMULATE_SAMPLE_N2 * float(2 * n) ** 2
        phases["switching.detects simulations"] = (C_SIMULATE * n3 if n > config.get("detects_max_agents") else 0.0) + runs * sizes.samples * per_sample
    deployment = sizes.threshold_samples > 0 and any(c.startswith("detection.") for c in ids)
    if deployment:
        phases["certified thresholds and guarantees"] = C_THRESHOLD * sizes.threshold_samples * sizes.detector_work
    arrays = ((A_GLOBAL_BLOCKS if sizes.block_built else A_GLOBAL) + A_GLOBAL_MODE * fresh) if glob else A_LOCAL_ONLY
    nbytes = B_BASE + arrays * dense_bytes(n)
    if uio:
        nbytes += sum((A_UIO if exact or m < 2 * modal_min else A_UIO_MODAL) * d * dense_bytes(m) for m, d in _designs(sizes))
    if simulate and "switching.detects" in ids:
        nbytes = max(nbytes, B_BASE + SIMULATION_BYTES_PER_SAMPLE_STATE * sizes.samples * (4 * n + 3))
    if deployment:
        nbytes = max(nbytes, B_BASE + 8.0 * THRESHOLD_ARRAYS * sizes.threshold_samples * sizes.detector_work)
    if exact:
        if "central.observer" in ids:
            phases["exact central.observer"] = exact_seconds("central.observer", n)
        zda = sum(1 for c in ("stealthy.zda", "switching.avoids-attack") if c in ids)
        if zda:
            phases["exact ZDA analysis"] = zda * exact_seconds("stealthy.zda", n)
        if glob:
            phases["exact global checkers"] = exact_seconds("switched-observability", n)
        if uio:
            phases["exact local.uio"] = sum(C_EXACT_UIO * d * float(m) ** 3 for m, d in _designs(sizes))
        if pencil:
            phases["exact local.pencil"] = sum(C_EXACT_PENCIL * c * float(m) ** 3 for m, c in _cases(sizes))
        nbytes += B_EXACT * float(n) ** 2
    budget = None if exact_budget is None else config.resolve("exact_budget", exact_budget)
    extra = float(budget) if (not exact and budget) else 0.0
    return phase_estimate("verify", n, phases, nbytes, arrays, extra)


def estimate_place_observers(sizes: SpecSizes, cluster: str | None = None) -> CostEstimate:
    """Seconds and peak memory of ``place-observers`` (every cluster, or ``cluster``).

    .. math::

        t = C_{start} + \\sum_i \\big(C_{place} (2 n_i)^3 + C_{place,2} (2 n_i)^2\\big),\\quad
        m = B_{base} + 8 N^2 A_{place} + \\sum_i 8 (2 n_i)^2 A_{place,i}

    with :data:`C_PLACE` = 9e-9 s, :data:`C_PLACE_SQ` = 2.5e-6 s, :data:`A_PLACE` = 5,
    :data:`A_PLACE_CLUSTER` = 18. The exhaustive search (``--exact-limit``) is not a term: at
    N = 2000 the run took the same time with the limit 0 and 2000.

    Parameters
    ----------
    sizes : SpecSizes
    cluster : str, optional
        ``--cluster``: only this cluster.

    Returns
    -------
    CostEstimate
    """
    s = sizes.only_cluster(cluster)
    secs = sum(C_PLACE * (2.0 * ni) ** 3 + C_PLACE_SQ * (2.0 * ni) ** 2 for ni in s.cluster_sizes)
    arrays = A_PLACE if s.cluster_sizes else 0.0  # no cluster: refused before any matrix
    nbytes = B_BASE + arrays * dense_bytes(s.n) + sum(A_PLACE_CLUSTER * dense_bytes(2 * ni) for ni in s.cluster_sizes)
    return phase_estimate("place-observers", s.n, {"cluster observer searches": secs}, nbytes, arrays)


def _sets(candidates: int, k: int) -> tuple[int, int]:
    """(singles, larger sets) among the sets of 1..k of ``candidates`` agents."""
    k = max(0, min(int(k), int(candidates)))
    larger = sum(math.comb(candidates, j) for j in range(2, k + 1))
    return (candidates if k >= 1 else 0), larger


def audit_set_seconds(sizes: SpecSizes, k: int, candidates: int | None = None) -> tuple[float, float, float]:
    """Estimated seconds of one candidate's local verdicts, one single set, and one larger set on average.

    The terms of :func:`estimate_audit` (one worker, numeric).

    Parameters
    ----------
    sizes : SpecSizes
    k : int
        ``--max-attackers``.
    candidates : int, optional
        Number of candidate agents (default N).

    Returns
    -------
    (per_agent, per_single, per_larger) : tuple of float
        ``per_larger`` averages over the sets of 2..k (0 when k < 2).
    """
    n = sizes.n
    m = n if candidates is None else int(candidates)
    nf = float(max(n, 1))
    cs = [float(c) for c in sizes.cluster_sizes]
    agent_local = sum(c * (2.0 * c) ** 3 for c in cs) / nf  # E_a over all agents (0 outside clusters)
    same = sum(c * (c - 1.0) for c in cs)
    pi = same / (nf * max(nf - 1.0, 1.0))
    pair_local = sum(c * (c - 1.0) * (2.0 * c) ** 3 for c in cs) / same if same else 0.0
    per_agent = C_AUDIT_AGENT + C_AUDIT_AGENT_N * n + C_AUDIT_AGENT_LOCAL * agent_local
    per_single = C_AUDIT_SINGLE_0 + C_AUDIT_SINGLE * float(n) ** 3
    kk = max(0, min(int(k), m))
    counts = [math.comb(m, j) for j in range(2, kk + 1)]
    secs = sum(
        c * (C_AUDIT_SET + C_AUDIT_SET_SQ * float(n) ** 2 + min(1.0, math.comb(j, 2) * pi) * (C_AUDIT_SET_INTRA + C_AUDIT_SET_LOCAL * pair_local))
        for j, c in zip(range(2, kk + 1), counts)
    )
    return per_agent, per_single, (secs / sum(counts) if counts else 0.0)


def estimate_audit(sizes: SpecSizes, k: int, candidates: int | None = None, *, exact: bool = False, workers: int = 1) -> CostEstimate:
    """Seconds and peak memory of ``audit`` of every set of 1..k of ``candidates`` actuators.

    With :math:`M` candidates, :math:`R = \\sum_{j=1}^k \\binom{M}{j}` rows, W workers,
    clusters of :math:`n_c` agents, :math:`\\pi = \\sum_c n_c (n_c - 1) / (N (N - 1))` the
    chance that two agents share a cluster (a set of j agents: :math:`\\min(1, \\binom{j}{2} \\pi)`)
    and averages over the agents of a cluster (:math:`E_a`) or over such pairs (:math:`E_p`):

    .. math::

        t = C_{start} + C_{setup} N^3 + \\frac{1}{W}\\Big[M \\big(C_a + C_{a,N} N + C_{a,loc} E_a (2 n_c)^3
            + C_{s,0} + C_s N^3\\big)
            + \\sum_{j \\ge 2} \\binom{M}{j} \\big(C_{set} + C_{set,2} N^2 + \\pi_j (C_{in} + C_{loc} E_p (2 n_c)^3)\\big)
            + C_{mode} R \\max(0, S - 2)\\Big]

        m = B_{base} + 8 N^2 A_{audit} + B_{row} R

    with the constants of this module (:data:`C_AUDIT_SETUP` = 1.2e-8, :data:`C_AUDIT_AGENT` =
    3e-3, :data:`C_AUDIT_AGENT_N` = 1.3e-5, :data:`C_AUDIT_AGENT_LOCAL` = 4.5e-8,
    :data:`C_AUDIT_SINGLE_0` = 5e-3, :data:`C_AUDIT_SINGLE` = 1.2e-10, :data:`C_AUDIT_SET` = 2e-4,
    :data:`C_AUDIT_SET_SQ` = 2e-10, :data:`C_AUDIT_SET_INTRA` = 4e-4, :data:`C_AUDIT_SET_LOCAL`
    = 4e-9, :data:`C_AUDIT_SET_MODE` (``C_mode``, S safe modes) = 1.5e-3,
    :data:`C_AUDIT_ROW_OUT` = 2e-4 s (writing each row), :data:`A_AUDIT` = 20,
    :data:`B_AUDIT_ROW` = 6.5 kB); ``exact`` multiplies the per-set seconds by
    :data:`F_AUDIT_EXACT`; N <= ``exact_fallback_full_agents`` adds :data:`C_AUDIT_EXACT_FALLBACK` R max(1, S) / W. Measured: the whole N = 1000 audit on 50 clusters with JSON output
    on 2 workers took 641 s and 11.9 GiB over its processes (estimate 7.3 min, 8.8 GiB; before
    the singles were decided by minors and local zeros: 29 min and 9.2 GB); N = 200 on 10 clusters 8 s in the
    library, about 20 s with JSON from the command line (estimate 17 s); 27 min at N = 300 on
    3 clusters, where a fifth of the pairs need the whole zero set (estimate 10 min). On the
    adverse family's first member at N = 1000 (10 clusters of 100, mean degree 8, observers
    measuring their neighbours only), the 7,875 sets of every eighth agent took about 110 CPU-s
    in one process (estimate 113 s) and the 2,016 of every sixteenth 33 CPU-s (estimate 56 s);
    the whole audit extrapolates to about 35 min on 2 workers (estimate 22 min).

    Parameters
    ----------
    sizes : SpecSizes
    k : int
        ``--max-attackers``.
    candidates : int, optional
        ``--agents`` count (default N); the candidates are taken to lie in the clusters as all
        agents do.
    exact : bool
        ``--exact``.
    workers : int
        Processes sharing the sets (``--workers``; a remote ``--scheduler`` counts as one).

    Returns
    -------
    CostEstimate
    """
    n = sizes.n
    m = n if candidates is None else int(candidates)
    singles, larger = _sets(m, k)
    f = F_AUDIT_EXACT if exact else 1.0
    w = max(1, int(workers))
    per_agent, per_single, per_larger = audit_set_seconds(sizes, k, m)
    phases = {
        "the spectrum, minor tables and safe-mode verdicts": C_AUDIT_SETUP * float(n) ** 3,
        "local verdicts of each candidate": f * per_agent * singles / w,
        "single actuators": f * per_single * singles / w,
        f"{larger} sets of 2..{k} actuators": f * per_larger * larger / w,
        f"safe-mode tests of {singles + larger} sets x {sizes.modes} modes": f * C_AUDIT_SET_MODE * (singles + larger) * max(0, sizes.modes - config.get("cost_calibration_modes")) / w,
        "exact re-decisions of a small network": (0.0 if exact or n > config.get("exact_fallback_full_agents") else C_AUDIT_EXACT_FALLBACK * (singles + larger) * max(1, sizes.modes) / w),
        "writing the rows": C_AUDIT_ROW_OUT * (singles + larger),
    }
    nbytes = B_BASE + A_AUDIT * dense_bytes(n) + B_AUDIT_ROW * (singles + larger)
    return phase_estimate("audit", n, phases, nbytes, A_AUDIT)


def estimate_design(sizes: SpecSizes, *, max_attackers: int = 2, place: bool = True, exact_assessment: bool | None = None) -> CostEstimate:
    """Seconds and peak memory of ``design`` before its safe modes: two audits, the placement, two assessments.

    .. math::

        t = 2\\, t_{audit}(k, N) + t_{place} + 2\\, t_{verify}(\\text{assessment ids}),\\quad
        m = \\max(m_{audit}, m_{place}, m_{verify})

    (each term without its own :data:`C_START`, which is counted once). The safe-mode phase depends on
    the number of attack sets the second audit leaves undetected; :func:`~glocal_verify.conditions.design_cost.estimate_safe_modes`
    estimates it once that number is known, before the phase starts.

    Parameters
    ----------
    sizes : SpecSizes
    max_attackers : int
        ``--max-attackers`` (k of the audits).
    place : bool
        Observers are placed (not ``--keep-observers``).
    exact_assessment : bool, optional
        The assessments run exactly (default: N <= 60, as ``design`` does without ``--numeric``).

    Returns
    -------
    CostEstimate
    """
    exact = sizes.n <= 60 if exact_assessment is None else exact_assessment
    parts = [(2.0, estimate_audit(sizes, max_attackers)), (2.0, estimate_verify(sizes, DESIGN_ASSESSMENT_IDS, exact=exact, exact_budget=None))]
    if place:
        parts.append((1.0, estimate_place_observers(sizes)))
    phases: dict[str, float] = {}
    for times, est in parts:
        for name, secs in est.phases:
            key = f"{est.command}: {name}"
            phases[key] = phases.get(key, 0.0) + times * secs
    peak = max(parts, key=lambda p: p[1].bytes)[1]
    return phase_estimate("design", sizes.n, phases, peak.bytes, peak.dense_arrays)


# --------------------------------------------------------------------------------------------
# limits


@dataclass(frozen=True, slots=True)
class Limits:
    """Largest estimate a command runs without ``--allow-large``.

    Attributes
    ----------
    seconds : float
    bytes : float
    notice_seconds : float
        Above this (and within the limits) the command prints its estimate before starting.
    """

    seconds: float = field(default_factory=lambda: float(config.get("max_seconds")))
    bytes: float = field(default_factory=lambda: float(config.get("max_bytes")))
    notice_seconds: float = field(default_factory=lambda: float(config.get("notice_seconds")))


def available_memory() -> float | None:
    """``MemAvailable`` of ``/proc/meminfo`` in bytes (None where there is no such file)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        return None
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def default_limits(available: float | None = None) -> Limits:
    """``max_seconds`` (10 min) and min(``max_bytes``, ``memory_fraction`` (80 %) of the available memory).

    Parameters
    ----------
    available : float, optional
        Available memory in bytes (default :func:`available_memory`, read now).
    """
    avail = available_memory() if available is None else available
    most = float(config.get("max_bytes"))
    cap = most if avail is None else min(most, config.get("memory_fraction") * avail)
    return Limits(float(config.get("max_seconds")), cap)


def refusal(est: CostEstimate, limits: Limits) -> str | None:
    """Why ``est`` exceeds ``limits`` (``"time"``, ``"memory"`` or ``"time and memory"``), or None.

    Parameters
    ----------
    est : CostEstimate
    limits : Limits
    """
    over = [w for w, bad in (("time", est.bound_seconds > limits.seconds), ("memory", est.bytes > limits.bytes)) if bad]
    return " and ".join(over) if over else None


def check_limits(est: CostEstimate, limits: Limits | None = None, *, allow: bool = False, how: Sequence[str] = ()) -> None:
    """Raise :class:`~glocal_verify.simulation.limits.SizeLimitError` when ``est`` exceeds ``limits`` (unless ``allow``), through the one refusal :func:`~glocal_verify.simulation.limits.refuse`.

    The message is one line: the command, N, the estimate, the limits, and how to proceed,
    e.g. ``verify of 20000 agents: estimated 36 min and 15 GiB (5 dense 20000 x 20000 arrays;
    mostly global spectra; limits 10 min, 8 GiB); rerun with --allow-large to run it anyway,
    or --only CONDITION to run fewer checkers``.

    Parameters
    ----------
    est : CostEstimate
    limits : Limits, optional
        Default :func:`default_limits`.
    allow : bool
        Never refuse (``--allow-large``).
    how : sequence of str
        Further ways out, appended after ``--allow-large`` (e.g. ``"--only CONDITION to run
        fewer checkers"``).
    """
    if allow:
        return
    lim = default_limits() if limits is None else limits
    if refusal(est, lim) is None:
        return
    text = est.describe()
    limits_text = f"limits {format_seconds(lim.seconds)}, {format_bytes(lim.bytes)}"
    text = text[:-1] + f"; {limits_text})" if text.endswith(")") else f"{text} ({limits_text})"
    ways = ", or ".join(["rerun with --allow-large to run it anyway", *how])
    refuse(f"{est.command} of {est.n} agents: estimated {text}; {ways}", allow=False, estimate=est, limits=lim)


def format_seconds(seconds: float) -> str:
    """``"45 s"``, ``"12 min"``, ``"3.6 h"``, ``"4.2 days"``, ``"3.2e+08 years"``.

    Parameters
    ----------
    seconds : float
    """
    if not math.isfinite(seconds):
        return "forever"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"{_short(seconds / 3600)} h"
    if seconds < 1000 * 86400:
        return f"{_short(seconds / 86400)} days"
    return f"{seconds / (365.25 * 86400):.2g} years"


def format_bytes(nbytes: float) -> str:
    """``"850 MiB"``, ``"9.6 GiB"``.

    Parameters
    ----------
    nbytes : float
    """
    if nbytes < GIB:
        return f"{nbytes / MIB:.0f} MiB"
    return f"{_short(nbytes / GIB)} GiB"


def _short(x: float) -> str:
    """One decimal below 10, none above: ``3.6``, ``36``, ``1234``."""
    text = f"{x:.1f}" if x < 9.95 else f"{x:.0f}"
    return text[:-2] if text.endswith(".0") else text
