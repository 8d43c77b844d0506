"""The condition catalogue: every public condition id, its paper reference, its statement and polarity.

A light module (it imports only the verdict types), so that listing conditions and parsing
command lines never load the numerics.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

from glocal_verify.results import Status

__all__ = ["ConditionInfo", "CATALOGUE", "DESIGN_ASSESSMENT_IDS", "THEOREM_III3_IDS"]


@dataclass(frozen=True, slots=True)
class ConditionInfo:
    """Catalogue entry of a condition.

    Attributes
    ----------
    id : str
        Public id (report key, CLI filter).
    reference : str
        Place in the paper.
    statement : str
        What ``holds`` means, in one line.
    favourable : Status
        The status that is good for the defender (``FAILS`` for ``stealthy.*`` and
        ``switching.avoids-attack``, ``HOLDS`` otherwise).
    margin_is_distance : bool
        The margin measures how far the exact system is from the condition's boundary on a
        relative scale (so a small one makes the result fragile); False for counts, growth
        rates and combinatorial facts.
    """

    id: str
    reference: str
    statement: str
    favourable: Status = Status.HOLDS
    margin_is_distance: bool = True


_H, _F = Status.HOLDS, Status.FAILS

_ENTRIES = (
    ("switched-observability", "Lemma II.3", "The switched pair (A_sigma, C) over the mode sequence is observable: N_1^m = {0}.", _H, True),
    ("stealthy.zda", "Proposition II.4 (ii), Definition II.2", "A stealthy zero-dynamics attack exists for (A_1, B, C, 0).", _F, False),
    ("stealthy.covert", "Proposition II.4 (i)", "A covert attack is feasible: every monitored channel reached by u_a is compromised.", _F, False),
    ("privacy.connected", "Lemma III.1", "The communication graph G_q is connected.", _H, False),
    ("privacy.kernel", "Lemma III.1", "[1; 0] lies in ker C (no position of any agent is monitored globally).", _H, False),
    ("privacy.unobservable", "Lemma III.1", "span{[1; 0]} is A_q-invariant and unobservable in every mode and for the switched system.", _H, False),
    ("privacy.initial-state", "Problem 1 (i)", "The initial state x(t0) cannot be reconstructed from the global measurements.", _H, True),
    ("privacy.consensus-value", "Problem 1 (i)", "The consensus value x* = (1/N) 1^T x(t0) cannot be reconstructed.", _H, True),
    ("local.k-connected", "Proposition III.2 (i)", "The observer centre has degree >= inter-cluster edges + suspected agents of the cluster.", _H, False),
    ("local.rank", "Proposition III.2 (ii)", "rank(C_loc E^i) = rank(E^i).", _H, True),
    ("local.pencil", "Proposition III.2 (iii)", "[[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]] has full column rank for every complex lam.", _H, True),
    ("local.uio", "Proposition III.2, eqs. uio_conds_1-uio_conds_3", "An unknown-input observer for the cluster exists and is verified.", _H, True),
    ("central.observer", "eq. obs_cent", "A_1 - H C is stable on the observable part; fixed unobservable eigenvalues reported.", _H, True),
    ("switching.image-kernel", "Theorem III.3 (i)", "Im(dL_q) ∩ ker([S_Mx; S_Mv]) = {0}, i.e. rank(S_M dL_q) = rank(dL_q).", _H, True),
    ("switching.distinct-eigenvalues", "Theorem III.3 (ii)", "L_q has N distinct eigenvalues.", _H, True),
    ("switching.eigenvector-differences", "Theorem III.3 (iii)", "[U_q]_{i,l} != [U_q]_{j,l} for every l != 1 and every pair i != j in one component D_c.", _H, True),
    ("switching.coverage", "Lemma A.2", "Every component D_c of the switching links contains a globally monitored agent.", _H, False),
    (
        "switching.avoids-attack",
        "Remark III.3.1, eq. unsafe_set",
        "The safe mode avoids the attack: some stealthy direction at lambda0 has dL_q xi = 0, so the switch does not expose it (remark's reading; both readings reported).",
        _F,
        False,
    ),
    ("switching.detects", "Theorem III.3 (conclusion)", "After the switch the global residual leaves its attack-free band (simulation).", _H, False),
    ("sampled.stability", "eq. cl_sys sampled at period h", "The sampled closed loop is stable apart from its consensus: every other eigenvalue of Phi_q has modulus < 1.", _H, True),
    ("sampled.no-aliasing", "Theorem III.3 (ii), sampled", "Sampling aliases no two modes: distinct eigenvalues of L_q keep disjoint eigenvalues of Phi_q, and no block is a multiple of I.", _H, True),
    ("sampled.observability", "Lemma II.3, sampled (Kalman-Ho-Narendra)", "Sampling hides nothing more: the unobservable subspace of (Phi_q, C) equals that of (A_q, C).", _H, True),
    ("sampled.zda", "Proposition II.4 (ii), sampled", "A stealthy zero-dynamics attack exists for the sampled pencil (Phi_1, Gamma_F, C).", _F, False),
    ("sampled.local-uio", "Proposition III.2, sampled", "A sampled-data unknown-input observer of the cluster exists (exact decoupling, certified stable error).", _H, True),
    ("detection.thresholds", "Algorithm 1 (thresholds), Section III.E", "Certified thresholds: no attack-free run crosses them, for every admissible initial state, noise and disturbance.", _H, False),
    ("detection.local-alarm", "Algorithm 1 (line 3), Proposition III.2", "Every admissible run of the spec's attack raises this local observer's alarm within the horizon.", _H, False),
    ("detection.guarantee", "Algorithm 1, Theorem III.3 (conclusion)", "Every admissible run of the spec's attack raises the control centre's alarm within the horizon (local alarm, switch, global alarm).", _H, False),
)


CATALOGUE: Mapping[str, ConditionInfo] = MappingProxyType({e[0]: ConditionInfo(*e) for e in _ENTRIES})

#: the conditions of a design's before/after assessment (``glocal-verify design``): privacy,
#: stealthy ZDA, the local observers and Theorem III.3 with the attack's avoidance
#: the conditions of Theorem III.3 (i)-(iii), decided per safe mode: what Algorithm 1 (line 4)
#: evaluates and the answer for one attacker reads (the one list of the package)
THEOREM_III3_IDS: tuple[str, ...] = ("switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences")

DESIGN_ASSESSMENT_IDS: tuple[str, ...] = (
    "privacy.initial-state",
    "privacy.consensus-value",
    "stealthy.zda",
    "local.pencil",
    "local.uio",
    "switching.image-kernel",
    "switching.distinct-eigenvalues",
    "switching.eigenvector-differences",
    "switching.avoids-attack",
)
