"""A stealthy ZDA at lambda0 = 0: the modular rank of Q_0 that proves there is none.

Q_0 = [[alpha L_1, -S_F^T], [S_Mx, 0]]; a stealthy ZDA at 0 exists iff some kernel vector has
an input part, i.e. rank Q_0 < rank [alpha L_1; S_Mx] + |F|. The reference is that criterion
computed over Q (python-flint).
"""

from __future__ import annotations

import random
from fractions import Fraction

import flint
import networkx as nx

from glocal_verify import System, config, spec_from_graph
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda_screens import zero_exponent_status
from glocal_verify.numerics.minors import prime_for
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE

#: the largest primes below 2^24 and 2^30: those a modular certificate tries first
P24, P30 = 16777213, 1073741789


def _exists_at_zero_over_q(system: System, F: list[int]) -> bool:
    """rank Q_0 < rank [alpha L_1; S_Mx] + m, over Q."""
    n, m = system.n, len(F)
    Fi, Mx = system.idx(F), system.idx(system.monitored_positions)
    a = Fraction(system.alpha_q)
    top = flint.fmpq_mat(n + len(Mx), n + m)
    for (i, j), v in laplacian_entries(system, NORMAL_MODE).items():
        q = a * v
        top[i, j] = flint.fmpq(q.numerator, q.denominator)
    for k, f in enumerate(Fi):
        top[f, n + k] = -1
    for t, r in enumerate(Mx):
        top[n + t, r] = 1
    left = flint.fmpq_mat(n + len(Mx), n, [top[i, j] for i in range(n + len(Mx)) for j in range(n)])
    return int(top.rank()) < int(left.rank()) + m


def _random_system(rng: random.Random) -> tuple[System, list[int]]:
    n = rng.randint(5, 9)
    G = nx.gnm_random_graph(n, rng.randint(n - 1, 2 * n), seed=rng.randrange(10**6))
    G = nx.relabel_nodes(G, {v: v + 1 for v in G})
    scale = [Fraction(1), Fraction(2), Fraction(1, 3), Fraction(P24**2, 10**6), Fraction(P30**2, 10**7)]
    for u, v in G.edges:
        G[u][v]["weight"] = rng.choice(scale)
    labels = list(G.nodes)
    rng.shuffle(labels)
    mx, F = labels[: rng.randint(1, 3)], labels[3 : 3 + rng.randint(1, 3)]
    spec = spec_from_graph(G, monitor_positions=sorted(mx), attack={"kind": "zda", "actuators": sorted(F)})
    return System(spec), sorted(F)


def test_the_rank_of_q0_modulo_a_prime_proves_no_zda_at_zero_only_when_the_exact_criterion_agrees() -> None:
    rng = random.Random(47)
    by_prime = 0
    with config.override(zero_exponent_dense_max_agents=0):  # the certified dense bounds decide nothing here
        for _ in range(150):
            system, F = _random_system(rng)
            st, how = zero_exponent_status(system, F)
            exists = _exists_at_zero_over_q(system, F)
            assert st is not (Status.FAILS if exists else Status.HOLDS), (how, exists)
            if "modulo the prime" in how:
                by_prime += 1
                assert st is Status.FAILS
            if st is Status.UNDECIDED:
                assert exists, how  # rank [alpha L_1; S_Mx] = N - free exactly: only a ZDA at 0 is left to the dense bounds
    assert by_prime >= 10  # the modular rank decides where zero forcing stops


def test_the_modular_rank_at_zero_is_not_tried_above_its_tunable() -> None:
    rng = random.Random(48)
    with config.override(zero_exponent_dense_max_agents=0, zero_exponent_modular_max_agents=0):
        for _ in range(40):
            system, F = _random_system(rng)
            assert "modulo the prime" not in zero_exponent_status(system, F)[1]


def test_the_prime_of_a_modular_certificate_divides_no_weight_numerator() -> None:
    values = [Fraction(P30**2, 10**7), Fraction(P24**2, 10**6), Fraction(3, 7)]
    p = prime_for(values)
    assert p not in (P30, 7) and all(v.numerator % p and v.denominator % p for v in values)
    assert prime_for([Fraction(P24**2, 10**6)], limit=2**24) != P24
