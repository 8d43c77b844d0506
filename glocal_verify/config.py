"""The tunable thresholds of glocal-verify, in one place (as python-control's ``config.defaults``).

Every size at which a method changes (dense or structured, modal or dense, factored or
decomposed afresh), every budget of a search and every limit of a run is a :class:`Tunable`
of :data:`TUNABLES`: its name, default, unit, meaning, the reason for its value and the module
that reads it. No tunable changes what is *proved*: a threshold only chooses how a verdict is
reached (or when to stop trying and say ``undecided``), so any value in its domain keeps every
verdict sound.

Reading and changing them::

    from glocal_verify import config

    config.get("rank_one_min_agents")            # the value in force
    config.defaults()                            # every value in force (read-only mapping)
    with config.override(dense_max_agents=40):   # for a block of code; restored on exit
        report = verify(system)
    config.set_defaults(max_seconds=1200.0)      # for the rest of the process
    config.reset_defaults()                      # every value back to its default

Modules read a tunable when they use it, so an override takes effect at once: a module never
keeps a tunable in a constant of its own. A function argument that stands for a tunable
defaults to None (or :data:`IN_FORCE` where None means something else) and is read through
the one resolver, :func:`resolve`: the argument if given, else the value in force when the
function runs (python-control's ``config._get_param``).
A value must have the default's type (an int where the default is an int; a real, possibly
infinite, where it is a float) and be non-negative; anything else raises :class:`ConfigError`. The
values hold in this process: an exact re-decision forked by ``verify`` inherits them, a
Dask worker of ``sweep`` or ``audit --workers`` starts from the defaults.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Iterator, Mapping

from glocal_verify.errors import ConfigError, did_you_mean, shorten

__all__ = [
    "ConfigError",
    "IN_FORCE",
    "TUNABLES",
    "Tunable",
    "default",
    "defaults",
    "get",
    "override",
    "reset_defaults",
    "resolve",
    "set_defaults",
]

_GIB = 1024**3


@dataclass(frozen=True, slots=True)
class Tunable:
    """One tunable threshold.

    Attributes
    ----------
    name : str
        Its name (lowercase, unique).
    default : int, float or tuple of float
    unit : str
        ``agents``, ``states``, ``seconds``, ``bytes``, ``count``, ``ratio`` ...
    home : str
        The module that reads it.
    meaning : str
        What it decides.
    why : str
        Why it has this value (a measurement, a bound, a compromise).
    """

    name: str
    default: Any
    unit: str
    home: str
    meaning: str
    why: str


def _t(name: str, default: Any, unit: str, home: str, meaning: str, why: str) -> Tunable:
    return Tunable(name, default, unit, home, meaning, why)


_ALL = (
    # ---- spectra of the Laplacians (model) ---------------------------------------------------
    _t("rank_one_min_agents", 500, "agents", "glocal_verify.model",
       "from this size a safe mode's spectrum is the normal mode's updated by rank-one factors",
       "below it an eigh of the safe mode is as fast as the factors' secular equations"),
    _t("rank_one_max_changes", 3, "links", "glocal_verify.model",
       "a safe mode changing at most this many links is factored (one rank-one factor each)",
       "every factor adds O(N^2) to each row read through the spectrum; beyond three a fresh eigh is cheaper"),
    _t("block_min_agents", 2000, "agents", "glocal_verify.model",
       "from this size a clustered normal mode is decomposed cluster by cluster",
       "the blocks' eigh plus the cut-link factors beat one N^3 eigh only for large N"),
    _t("block_max_cut_links", 16, "links", "glocal_verify.model",
       "a block-built normal mode allows at most this many links between clusters (each a rank-one factor)",
       "each factor is O(N^2) and one more factor every computed row goes through"),
    # ---- verdicts and escalation (results, conditions) ---------------------------------------
    _t("fragile_below", 1e-9, "relative margin", "glocal_verify.conditions.registry",
       "a verdict whose relative margin is below this is marked fragile (never changes its status)",
       "the default tolerance rtol: a margin below it is within the rounding of the data"),
    _t("escalation_estimate_fraction", 0.25, "ratio", "glocal_verify.conditions.registry",
       "an exact re-decision is not started when this fraction of its estimated seconds exceeds the whole budget",
       "the exact-cost model holds within a factor of about two; a quarter keeps every re-decision that might finish"),
    _t("zda_certificate_max_seconds", 10.0, "seconds", "glocal_verify.analysis.stealthy.zda_screens",
       "the minor certificate's tables are built (after an uncertified numeric zero set; by the escalation scheduler to learn the exact ZDA path) only while they cost at most this",
       "above it the certificate's own cost is the estimate (about N = 1700)"),
    # ---- the exact-cost model (conditions.cost) ------------------------------------------------
    _t("exact_central_seconds_n4", 2.5e-8, "seconds / N^4", "glocal_verify.conditions.exact_cost",
       "exact central.observer: the rational characteristic polynomial and its Routh test",
       "24 s of CPU at N = 200, 2.8 s at N = 100 (random_clustered_spec(N, 3, seed=7)), rounded up"),
    _t("exact_zda_seconds_n3", 1e-6, "seconds / N^3", "glocal_verify.conditions.exact_cost",
       "exact stealthy.zda or switching.avoids-attack on the proved zero polynomial (the fast path)",
       "1.8-2.6 s of CPU at N = 200, 1.2-1.4 s at N = 100, rounded up"),
    _t("exact_zda_dense_seconds_n4", 2.5e-6, "seconds / N^4", "glocal_verify.conditions.exact_cost",
       "exact ZDA analysis when the pencil needs the dense V* iteration over Q (not left-invertible)",
       "104 s at N = 80; hours at N = 200"),
    _t("zda_certificate_seconds_n3", 5.75e-9, "seconds / N^3", "glocal_verify.analysis.stealthy.zda_screens",
       "the minor certificate of the exact ZDA analysis (a characteristic polynomial modulo a prime)",
       "46 s at N = 2000"),
    _t("exact_global_seconds_n3", 1e-6, "seconds / N^3", "glocal_verify.conditions.exact_cost",
       "the other exact global checkers (switched-observability, privacy.*)",
       "1.1 s at N = 120"),
    # ---- size limits of a command (conditions.cost) --------------------------------------------
    _t("max_seconds", 600.0, "seconds", "glocal_verify.conditions.cost",
       "a command estimated above this is refused (the CLI's --allow-large lifts it)",
       "ten minutes: beyond it a run deserves a deliberate decision"),
    _t("max_bytes", 8.0 * _GIB, "bytes", "glocal_verify.conditions.cost",
       "a command estimated above this memory (or memory_fraction of the available memory) is refused",
       "a laptop's memory; the estimate errs high"),
    _t("memory_fraction", 0.8, "ratio", "glocal_verify.conditions.cost",
       "the share of the available memory a command may plan to use",
       "leaves room for the rest of the machine"),
    _t("notice_seconds", 30.0, "seconds", "glocal_verify.conditions.cost",
       "a command estimated above this (and within the limits) says what it expects before starting",
       "shorter runs need no warning"),
    # ---- local conditions (analysis.local.pencil, observers) -----------------------------------
    _t("dense_max_agents", 16, "agents", "glocal_verify.analysis.local.pencil",
       "clusters of at most this many agents get the dense generic pencil analysis (method auto)",
       "the dense 2n pencil is the reference and cheap there; the structured one scales"),
    _t("max_reported_zeros", 12, "count", "glocal_verify.analysis.local.pencil",
       "zeros reported and verified per local case (up to three times more while none verifies)",
       "a witness needs one verified zero; more only bloat reports"),
    _t("exact_rank_max_columns", 400, "columns", "glocal_verify.analysis.local.cases",
       "a reported local zero at a real s is proved by the rank of the reduced pencil over Q only up to this many unmeasured agents",
       "a rational elimination of that order takes well under a second"),
    _t("exact_norm_columns", 400, "columns", "glocal_verify.analysis.local.pencil",
       "full pencils with at most this many columns get an exact ||P||_2 in the residual of a zero",
       "above, a lower bound of the norm (the ratio can then only be larger) avoids an SVD"),
    _t("modal_min_agents", 60, "agents", "glocal_verify.observers.uio_modal_verdict",
       "clusters of at least this many agents get the modal UIO design and certificate (method auto)",
       "below it the dense design is as fast and is the reference"),
    _t("uio_reduced_min_states", 150, "states", "glocal_verify.observers.uio",
       "an observer's F of at least this many states is certified through the default design's Schur basis",
       "below it the dense eigen-decomposition with left vectors is cheap"),
    _t("uio_ladder_gain", 10.0, "ratio", "glocal_verify.observers.uio",
       "an uncertified default UIO design is redone moving fewer slow modes only when ||K1|| exceeds this times max(||A_1||, 1)",
       "a small gain means the trouble is elsewhere (a repeated eigenvalue): no retry"),
    _t("slow_ladder", (0.9, 0.3, 0.1, 0.02), "ratio of gamma / 2", "glocal_verify.observers.uio",
       "the default UIO design moves the observable modes with Re > -theta sigma, theta taken along this ladder",
       "moving weakly observable slow modes can take a huge gain; each step keeps more of them"),
    _t("hurwitz_reduced_tail", 400, "states", "glocal_verify.numerics.hurwitz",
       "the reduced Hurwitz certificate is used when the trailing block has at most this many states",
       "its Schur form and back substitution stay cheap"),
    _t("sparse_min", 64, "states", "glocal_verify.numerics.hurwitz",
       "products with a matrix of at least this order go through a CSR copy when it is sparse",
       "below, dense products are faster"),
    _t("sparse_density", 0.05, "ratio", "glocal_verify.numerics.hurwitz",
       "... and when at most this fraction of its entries is nonzero",
       "the cluster matrices A_1 have a few nonzeros per row"),
    _t("central_certify_max_states", 800, "states", "glocal_verify.observers.central",
       "largest observable part the dense Bauer-Fike certificate of central.observer handles (above: undecided)",
       "a dense nonsymmetric eigen-decomposition of that order"),
    _t("central_max_design", 100, "states", "glocal_verify.observers.central",
       "largest block the central observer's gain is designed on densely (default of design_central_observer)",
       "Riccati and pole placement are cubic and ill-conditioned beyond"),
    _t("all_cores_min_agents", 1000, "agents", "glocal_verify.analysis.local.cluster_modal",
       "interior blocks of at least this many agents are decomposed on every core",
       "below, one thread is as fast and skips the thread-pool switch"),
    # ---- unobservable subspaces (analysis.unobservable.subspace) ---------------------------------
    _t("candidate_zero", 1e-9, "singular value", "glocal_verify.analysis.unobservable.subspace",
       "singular values of S_M U_g below this are read as zero when rationalising unobservable candidates",
       "a candidate is used only after its exact proof: this only chooses what to try"),
    _t("max_verified_candidates", 400, "vectors", "glocal_verify.analysis.unobservable.subspace",
       "most candidate vectors the exact verification of the unobservable subspace takes on",
       "each is an exact check of an N-vector"),
    # ---- exact arithmetic and certificates (numerics) ------------------------------------------
    _t("max_primes", 48, "count", "glocal_verify.numerics.exact_subspace",
       "primes tried by the modular closure before it leaves the closure to the rational iteration",
       "48 primes of about 26 bits reconstruct rationals of several hundred digits"),
    _t("normal_rank_points", 3, "count", "glocal_verify.numerics.pencil",
       "random points at which a pencil's normal rank is cross-checked",
       "a rank drop at every one of three random points is certain for practical purposes"),
    _t("standard_eig_cond", 1e4, "condition number", "glocal_verify.numerics.pencil",
       "below this condition number of the final square D, zeros come from eig(A - B D^-1 C)",
       "above it the generalized eigenproblem is more accurate"),
    _t("cluster_dense_max", 256, "points", "glocal_verify.numerics.pencil",
       "up to this many points the single-linkage clustering compares all pairs directly",
       "above it a k-d tree is faster"),
    _t("minor_max_inputs", 4, "agents", "glocal_verify.numerics.minors",
       "input sets with more unmeasured input agents are not certified by exact minors",
       "the number of minors grows combinatorially"),
    _t("minor_max_row_choices", 6, "count", "glocal_verify.numerics.minors",
       "choices of replaced rows tried per input set by the minor certificate",
       "most certificates succeed on the first or second choice"),
    _t("minor_random_combinations", 2, "count", "glocal_verify.numerics.minors",
       "random combinations of maximal minors a full-effort minor certificate tries last",
       "the chosen minors of a fifth of the singles of the 1000-agent benchmark network shared a factor that one combination breaks"),
    _t("minor_max_extra_rows", 80, "rows", "glocal_verify.numerics.minors",
       "extra replaced rows (anchors) per input set of the minor certificate",
       "bounds the work of a failing certificate"),
    _t("local_zero_support_max_agents", 400, "agents", "glocal_verify.analysis.stealthy.zda_local",
       "a computed ZDA direction at a rational s0 is proved exactly on its support and neighbours only up to this many agents",
       "one rational elimination of that size: well under a second at 400; the benchmark's wide zeros have 175"),
    _t("local_zero_max_agents", 120, "agents", "glocal_verify.analysis.stealthy.zda_local",
       "the pencil of the attacked agents' clusters is searched exactly for zeros only up to this many agents",
       "two determinants per evaluation point, cubic in the clusters' size: about a second at 120 agents"),
    _t("zero_polynomial_subsets", 8, "count", "glocal_verify.numerics.zero_polynomial",
       "output subsets whose exact minors bound the zero polynomial",
       "a few subsets settle the gcd almost always"),
    _t("zero_polynomial_compressions", 2, "count", "glocal_verify.numerics.zero_polynomial",
       "random compressions modulo the prime before the bounds are compared",
       "two independent compressions make a false agreement negligible (and it is then proved)"),
    _t("zero_polynomial_retries", 2, "count", "glocal_verify.numerics.zero_polynomial",
       "further attempts (a compression and a new prime each) when the bounds do not meet",
       "bounded work before the dense path decides"),
    _t("zero_count_primes", 3, "count", "glocal_verify.numerics.zero_count",
       "primes tried by the modular zero count before it gives up (an unlucky prime divides a leading coefficient or keeps A derogatory)",
       "a prime below 2^31 is unlucky with probability about N / p; three make a repeated failure a property of the system"),
    _t("zero_count_squarings", 2, "count", "glocal_verify.numerics.zero_count",
       "random squarings-down det(R P(s)) whose gcd modulo p bounds the number of invariant zeros",
       "two random ones share a spurious factor with probability about N / p; each more costs one truncated product"),
    _t("zero_count_values_max_inputs", 32, "inputs", "glocal_verify.numerics.zero_count",
       "the modular zero count runs up to this many inputs (det(R P(s)) from its values at n + 1 points above three inputs)",
       "a 300-agent cluster's pencil with 12 inputs takes well under a second; the determinants grow like the cube of the inputs"),
    _t("zero_count_max_states", 20000, "states", "glocal_verify.numerics.zero_count",
       "the modular zero count (2N sparse products and a Berlekamp-Massey of length 2N) runs up to this many states",
       "about 1 s at N = 4000 (random_clustered_spec(4000, 40, seed=7, modes=1)); quadratic beyond"),
    _t("zero_count_exact_terms", 400, "terms", "glocal_verify.numerics.zero_count",
       "Markov parameters recomputed over Z to check that the prime keeps the leading coefficient of det(R_1 P(s))",
       "the leading term sits about twice the graph distance from F to M deep (15 in the realistic family); integer growth makes hundreds slow"),
    _t("zero_count_cluster_max_agents", 250, "agents", "glocal_verify.analysis.stealthy.zda_completeness",
       "the largest union of clusters whose exact maximal minors locate the zeros the modular count finds",
       "exact minors of a 100-agent cluster take well under a second; their cost grows like the cube of the size "
       "(a failing search at N = 4000: 9.6 s in all with 400, 5.9 s with 250)"),
    _t("zero_count_cluster_steps", 4, "steps", "glocal_verify.analysis.stealthy.zda_completeness",
       "clusters peeled off, from the attacked agents outward, to locate the zeros the modular count finds",
       "each step costs one modular count of the rest (about a second at N = 4000) and exact minors of a cluster; "
       "random_clustered_spec(800, 8, seed=7, modes=1) closes after two"),
    _t("update_accept", 1.5, "ratio", "glocal_verify.numerics.updated_spectrum",
       "a rank-one update is kept when its certified radius is at most this times the larger of its base's and an eigh's",
       "an update barely less sharp than an eigh costs no verdict"),
    _t("keep_columns_max", 2048, "columns", "glocal_verify.numerics.updated_spectrum",
       "columns a factored spectrum keeps at most from one request",
       "a request for most of the basis is recomputed rather than held"),
    _t("exact_norm_max", 600, "order", "glocal_verify.numerics.balancing",
       "matrices with at most this many rows or columns get their 2-norm from an SVD (else a bound)",
       "an SVD of that size is cheap"),
    _t("threaded_min", 1500, "order", "glocal_verify.numerics.balancing",
       "from this order the symmetric step's two large products use every core",
       "below, one thread is as fast and skips the thread-pool switch"),
    _t("fused_min", 128, "order", "glocal_verify.numerics.balancing",
       "from this order a deflation step uses the fused update",
       "measured: 30 against 46 us at n = 30, 44 against 51 us at n = 100"),
    # ---- simulation --------------------------------------------------------------------------
    _t("simulation_max_samples", 10**7, "samples", "glocal_verify.simulation.limits",
       "most output samples (horizon / step + 1) one simulation may store without allow_large",
       "80 MB per stored channel"),
    _t("simulation_max_bytes", 2 * _GIB, "bytes", "glocal_verify.simulation.limits",
       "most bytes one simulation may allocate without allow_large",
       "well within a laptop's memory"),
    _t("simulation_max_internal_steps", 5 * 10**6, "steps", "glocal_verify.simulation.limits",
       "most internal (Taylor) steps one simulation may take (stiff systems need many per output step)",
       "bounds the run time of a stiff system"),
    _t("dense_limit", 600, "states", "glocal_verify.simulation.engine",
       "largest augmented dimension for which method auto picks the dense propagator",
       "the dense exponential is cubic in it"),
    _t("detects_max_agents", 150, "agents", "glocal_verify.conditions.detects",
       "largest network on which switching.detects simulates (each safe mode one 2N-column batch)",
       "61 s for one N = 1000 run; 150 agents keep the check to seconds"),
    # ---- design ------------------------------------------------------------------------------
    _t("placement_exact_limit", 2000, "agents", "glocal_verify.design.placement",
       "default of place_observers' exact_limit (the exhaustive observer search)",
       "measured: the same run time at N = 2000 with the limit 0 and 2000"),
    _t("full_delete_max", 80, "agents", "glocal_verify.design.placement",
       "largest cluster whose greedy reverse delete runs the full numeric test on every trial",
       "larger clusters use zero forcing only"),
    _t("sweep_max_members", 1_000_000, "members", "glocal_verify.design.sweep",
       "most members an ensemble may have",
       "a bad input limit: a typo should not start a million-hour sweep"),
    _t("cost_mode_seconds", 0.25, "seconds", "glocal_verify.conditions.cost",
       "the global checkers' work per safe mode beyond the calibration's (constant part)",
       "random_clustered_spec(N, 3, seed=2), one-link modes, --escalate never: 0.28 s per further mode at N = 300, 0.29 s at 600, 0.70 s at 1100"),
    _t("cost_mode_seconds_sq", 3.5e-7, "seconds / N^2", "glocal_verify.conditions.cost",
       "the global checkers' work per safe mode beyond the calibration's (N^2 part)",
       "fit with cost_mode_seconds; 1000 modes at N = 1100 ran over 20 minutes where the old estimate said 2"),
    _t("charpoly_mod_max_agents", 500, "agents", "glocal_verify.analysis.laplacian.twins",
       "above this size Theorem III.3 (ii) and (iii) are not retried by modular characteristic polynomials when the Krylov certificate falls short",
       "both certify the same exact fact (each fails only on an unlucky prime, with probability about N / p); the characteristic polynomial costs O(N^3): "
       "two of them took 239 s at N = 4000 where the Krylov degrees take a second"),
    _t("cost_calibration_modes", 2, "modes", "glocal_verify.conditions.cost",
       "safe modes of the calibration runs (their cost is in the other cost constants)",
       "the benchmark specs have two"),
    _t("exact_fallback_max_agents", 60, "agents", "glocal_verify.design.audit",
       "the audit re-decides numeric undecided parts over Q by default up to this many agents",
       "the exact ZDA analysis grows fast with N"),
    _t("exact_fallback_full_agents", 20, "agents", "glocal_verify.design.audit",
       "above this (up to exact_fallback_max_agents) only rows left undecided are re-decided over Q",
       "every row is cheap to re-decide below it"),
    _t("growth_full_max_agents", 60, "agents", "glocal_verify.design.audit",
       "up to this many agents every stealthy set gets its whole zero set (growth full)",
       "the whole zero set is an O(N^3) analysis per set"),
    _t("witness_xi_max_agents", 100, "agents", "glocal_verify.design.audit",
       "above this many agents a row's witness leaves out xi (N entries per row)",
       "keeps audit reports linear in the rows"),
    _t("witness_certificate_patience", 1, "minors", "glocal_verify.analysis.stealthy.zda_verdict",
       "the witness minor certificate stops after this many minors leave the gcd's degree unchanged",
       "measured on the N = 200, k = 2 audit of the benchmarks"),
    _t("witness_certificate_extra_rows", 0, "rows", "glocal_verify.analysis.stealthy.zda_verdict",
       "costlier minors with an extra replaced row the witness certificate tries",
       "none of 7,854 successful pair certificates used one; the failing ones spent a third of their time there"),
    _t("monitors_exact_max_agents", 30, "agents", "glocal_verify.design.monitors",
       "monitor design searches exhaustively up to this many agents in the union of the switching components",
       "the search is exponential"),
    _t("safe_modes_exact_max_agents", 40, "agents", "glocal_verify.design.safe_modes",
       "safe-mode design re-verifies its proposals over Q up to this many agents",
       "exact Theorem III.3 checks grow fast with N"),
    _t("monitor_step_set_seconds", 5e-3, "seconds", "glocal_verify.conditions.design_cost",
       "constant part of one audit of one hard attack set in design's monitor step",
       "the sets left there are stealthy and unexposed: their witnesses are the costly ones"),
    _t("monitor_step_set_seconds_g", 8e-7, "seconds / N^3 (N^2 above growth_full_max_agents)", "glocal_verify.conditions.design_cost",
       "size-dependent part of one audit of one hard attack set in design's monitor step",
       "73-80 ms per set measured at N = 42 (the whole zero set of each), on a shared machine"),
    _t("safe_mode_check_seconds", 2e-3, "seconds", "glocal_verify.conditions.design_cost",
       "constant part of the check of one attack set against a proposed safe mode",
       "8 ms per set measured at N = 40; 10 ms over Q at N = 19 (paper19, 80 checks in 0.8 s)"),
    _t("safe_mode_check_seconds_n2", 8e-6, "seconds / N^2", "glocal_verify.conditions.design_cost",
       "N^2 part of the check of one attack set against a proposed safe mode",
       "one-link modes: 20-30 ms per set at N = 80-120, 40 ms at N = 200; symmetry-breaking modes of 3-8 links: "
       "28 ms at N = 60, 0.2 s at N = 100, 0.35 s at N = 200 (decide_avoidance most of it)"),
    _t("safe_mode_check_exact_factor", 5.0, "factor", "glocal_verify.conditions.design_cost",
       "the check over Q costs this many times the numeric one",
       "42 ms against 8 ms per set at N = 40"),
    _t("safe_modes_max_combinations", 200_000, "changes", "glocal_verify.design.safe_modes",
       "multi-link changes scored per size by the safe-mode design",
       "bounds the scoring work"),
    _t("safe_modes_max_screens", 4000, "changes", "glocal_verify.design.safe_modes",
       "changes screened per chosen mode (fewer for large N: safe_modes_max_screen_work)",
       "bounds the screening work"),
    _t("safe_modes_max_screen_work", 2e9, "entry operations", "glocal_verify.design.safe_modes",
       "about this many entry operations of the screen per chosen mode (64 s N^2 each)",
       "a few seconds of screening"),
    _t("safe_modes_screen_batch", 64, "changes", "glocal_verify.design.safe_modes",
       "changes screened together (one batched secular solve)",
       "amortises the solve's calls"),
    _t("safe_modes_screen_batch_entries", 4e6, "entries", "glocal_verify.design.safe_modes",
       "at most about this many array entries (B (N - 1)^2) per temporary of a batch",
       "32 MB temporaries"),
    _t("multilink_screen_margin", 1e-8, "relative margin", "glocal_verify.design.multilink",
       "a change is proposed only when its screened gaps and eigenvector differences exceed this",
       "above the rounding of the screen; every proposal is verified afterwards"),
    _t("multilink_bisection_steps", 64, "steps", "glocal_verify.design.multilink",
       "bisection steps of the secular equation (each halves the bracket)",
       "64 halvings reach double precision"),
    _t("zero_exponent_modular_max_agents", 2000, "agents", "glocal_verify.analysis.stealthy.zda_screens",
       "with monitored positions, the absence of a ZDA at lambda0 = 0 is proved by the rank of Q_0 modulo a prime up to this many agents",
       "one dense rank modulo p of an (N + |M_x|) x (N + m) matrix (python-flint), tried only where zero forcing stops: "
       "0.06 s at N = 500, 0.3 s at 1000, 1.7 s at 2000 on one core; the dense bounds it spares cost an SVD of an N-sized matrix"),
    _t("zero_exponent_dense_max_agents", 400, "agents", "glocal_verify.analysis.stealthy.zda_screens",
       "with monitored positions, lambda0 = 0 of a ZDA is decided by dense certified rank bounds up to this many agents",
       "the bounds need an SVD of an N-sized exact matrix"),
    _t("zero_touch_note_agents", 500, "agents", "glocal_verify.analysis.switching.avoidance",
       "up to this many agents an undecided touch test at lambda0 = 0 notes what Q says there",
       "the note costs an N-sized exact solve"),
    _t("zero_touch_modular_max_agents", 2000, "agents", "glocal_verify.analysis.switching.zero_touch",
       "an audit's modular touch screen inverts the grounded Laplacian modulo a prime up to this many agents (one attack set solves sparsely instead)",
       "O(N^3) once per system"),
    _t("avoidance_dense_max_agents", 600, "agents", "glocal_verify.analysis.switching.avoidance",
       "the numeric touch test at an exact lambda0 is certified by dense rank bounds (SVDs of N-sized exact matrices) up to this many agents",
       "four SVDs and an N^2 table of rationals: 42 s at N = 2000 on the adverse family; beyond, the touch test over Q at lambda0 = 0 decides, or the verdict stays undecided"),
    _t("zero_touch_primes", 3, "count", "glocal_verify.analysis.switching.zero_touch",
       "primes (with fresh random vectors and diagonal) the sparse modular solve of the attack's potentials tries",
       "a try fails only when L_g D is derogatory or p divides det L_g: about N / p each"),
    _t("zero_touch_exact_max_agents", 400, "agents", "glocal_verify.analysis.switching.zero_touch",
       "the touch test at lambda0 = 0 solves the grounded Laplacian over Q (what the modular and structural proofs leave) up to this many agents",
       "a dense rational solve; beyond, the verdict stays undecided and says so instead of running for minutes"),
    # ---- run options and limits read where they are in force ---------------------------------
    _t("exact_budget", 30.0, "seconds", "glocal_verify.conditions.registry",
       "one time budget for all the exact escalations of a verify run (verify's and the CLI's --exact-budget default)",
       "half a minute keeps an interactive run interactive; most re-decisions of the bundled examples take a second"),
    _t("guarantee_max_agents", 150, "agents", "glocal_verify.simulation.guarantees",
       "largest network whose certified detection guarantee (detection.*) is computed (dense 2N-sized composites)",
       "the composites are dense, cubic in 2N; the same bound as detects_max_agents (no separate measurement)"),
    # ---- certificates of verdicts (docs/certificates.md) --------------------------------------
    _t("certificate_dense_max_agents", 300, "agents", "glocal_verify.certificates.global_certificates",
       "certificates that need dense exact or modular work on N-sized matrices (touch ranks, Krylov rows of observability, ZDAs at lambda0 != 0) are written up to this many agents",
       "O(N^3) exact elimination per certificate; 0.1 s at N = 200"),
    _t("certificate_max_states", 100, "states", "glocal_verify.certificates.encode",
       "Hurwitz certificates (local.uio per mode, central.observer's quotient) state the characteristic polynomial up to this many states, a Lyapunov matrix above",
       "the checker's exact characteristic polynomial and root enclosures: 0.4 s at 100 states, 45 s at 240, growing like n^4; a Lyapunov matrix costs one floating-point Cholesky and exact integer products: 2 s at 240 states"),
    _t("certificate_field_unknowns", 1000, "unknowns", "glocal_verify.certificates.zero_sets",
       "a kernel vector over a number field Q[t]/(g) is solved over Q in its N deg g coefficients (eigenvector_in_field, the regular representation of a pencil's kernel when the minors' route fails) up to this many unknowns",
       "a dense rational solve of that size: 0.3 s for 84 unknowns (a 45-agent cluster, degree 2), 4 s for 960 (a 60-agent path, degree 16)"),
    _t("certificate_minor_tries", 40, "row sets", "glocal_verify.certificates.local_certificates",
       "row sets of the reduced local pencil T(s) tried for coprime minors (and for an anchor of large degree) before no certificate is written",
       "two or three minors suffice on every bundled and generated network"),
    _t("certificate_lift_primes", 200, "primes", "glocal_verify.certificates.zero_sets",
       "primes tried to lift the zero polynomial of a pencil in s from its reductions to Q (Chinese remainders, rational reconstruction) before no zero set is written",
       "one set of minors modulo each prime; degree 90 needs about 100 primes"),
    # ---- replay (simulation.replay) ------------------------------------------------------------
    _t("replay_noise_slack", 0.01, "fraction", "glocal_verify.simulation.replay",
       "a replayed channel's fourth-difference noise estimate above (1 + this) x its [uncertainty] bound says the noise premise failed",
       "noise at its bound reaches exactly 1; the loop's own signal adds h^4 |y''''| / 16, below 1e-4 of the bound on paper19's logs"),
    _t("symmetry_weight_tries", 4, "weightings", "glocal_verify.design.symmetry",
       "generic weightings of one symmetry-breaking link plan decided by the Theorem III.3 rules before a failing link is banned",
       "a generic weighting passes at the first or second try on symmetric clusters"),
    _t("symmetry_plan_tries", 6, "plans", "glocal_verify.design.symmetry",
       "link plans drawn per symmetry-breaking mode (each after banning the link a failed plan names)",
       "bounds the rule decisions of one mode"),
    _t("symmetry_max_links", 12, "links", "glocal_verify.design.symmetry",
       "largest number of links of a symmetry-breaking mode when --max-links is not given",
       "the interlacing bound asks as many links as the largest multiplicity of L_1"),
)

#: every tunable by name (read-only)
TUNABLES: Mapping[str, Tunable] = MappingProxyType({t.name: t for t in _ALL})


class _Registry:
    """The values in force: the one piece of module-level mutable state of the package."""

    __slots__ = ("values",)

    def __init__(self) -> None:
        self.values: dict[str, Any] = {name: t.default for name, t in TUNABLES.items()}


_REGISTRY = _Registry()


def _tunable(name: str) -> Tunable:
    t = TUNABLES.get(name)
    if t is None:
        raise ConfigError(f"unknown tunable {shorten(repr(name), 80)}{did_you_mean(str(name), TUNABLES)}")
    return t


def _checked(t: Tunable, value: Any) -> Any:
    d = t.default
    if isinstance(d, tuple):
        if not isinstance(value, (tuple, list)) or not value or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x >= 0 for x in value):
            raise ConfigError(f"{t.name}: expected a non-empty sequence of non-negative numbers, got {value!r}")
        return tuple(float(x) for x in value)
    if isinstance(d, int):
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise ConfigError(f"{t.name}: expected a non-negative integer ({t.unit}), got {value!r}")
        return value
    if not isinstance(value, (int, float)) or isinstance(value, bool) or math.isnan(value) or value < 0:
        raise ConfigError(f"{t.name}: expected a non-negative number ({t.unit}), got {value!r}")
    return float(value)


def get(name: str) -> Any:
    """The value of tunable ``name`` in force.

    Parameters
    ----------
    name : str
        A key of :data:`TUNABLES`.

    Raises
    ------
    ConfigError
        For an unknown name (naming the closest ones).
    """
    try:
        return _REGISTRY.values[name]
    except KeyError:
        _tunable(name)
        raise  # pragma: no cover - _tunable raised


@dataclass(frozen=True, slots=True)
class _InForce:
    """The type of :data:`IN_FORCE` (one instance, no state)."""

    def __repr__(self) -> str:
        return "IN_FORCE"

    def __reduce__(self) -> str:
        return "IN_FORCE"


#: the default of an argument that stands for a tunable when None already means something
#: else (``exact_budget=None``: no budget): "the value in force when the function runs"
IN_FORCE: Any = _InForce()


def resolve(name: str, value: Any = None) -> Any:
    """The argument if given, else the value of tunable ``name`` in force (read now).

    The one resolver of the package (python-control's ``config._get_param``): a function whose
    argument stands for a tunable defaults it to None (or :data:`IN_FORCE`) and calls this
    when it runs, so that :func:`override` and :func:`set_defaults` reach it.

    Parameters
    ----------
    name : str
        A key of :data:`TUNABLES` (checked even when ``value`` is given).
    value : object, optional
        The argument; None or :data:`IN_FORCE` mean "not given".

    Raises
    ------
    ConfigError
        For an unknown name.
    """
    in_force = get(name)
    return in_force if value is None or value is IN_FORCE else value


def default(name: str) -> Any:
    """The documented default of tunable ``name`` (whatever is in force).

    Parameters
    ----------
    name : str
    """
    return _tunable(name).default


def defaults() -> Mapping[str, Any]:
    """Every tunable's value in force, as a read-only mapping (a snapshot)."""
    return MappingProxyType(dict(_REGISTRY.values))


def set_defaults(**values: Any) -> None:
    """Set tunables for the rest of the process (until :func:`reset_defaults`).

    Parameters
    ----------
    **values
        ``name=value`` pairs; every name is checked before any value changes.
    """
    new = {name: _checked(_tunable(name), v) for name, v in values.items()}
    _REGISTRY.values.update(new)


def reset_defaults(*names: str) -> None:
    """Put tunables back to their defaults (every one when no name is given).

    Parameters
    ----------
    *names : str
    """
    for name in names or tuple(TUNABLES):
        _REGISTRY.values[name] = _tunable(name).default


@contextlib.contextmanager
def override(**values: Any) -> Iterator[None]:
    """Set tunables inside a ``with`` block; the previous values come back on exit (also on error).

    Parameters
    ----------
    **values
        ``name=value`` pairs, checked as :func:`set_defaults` checks them.
    """
    new = {name: _checked(_tunable(name), v) for name, v in values.items()}
    old = {name: _REGISTRY.values[name] for name in new}
    _REGISTRY.values.update(new)
    try:
        yield
    finally:
        _REGISTRY.values.update(old)
