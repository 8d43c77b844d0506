"""A stealthy ZDA at lambda0 = 0: the modular rank of Q_0 that proves there is none, and the
persistent ZDA the numeric zero set misses on badly scaled weights, decided as over Q.

Q_0 = [[alpha L_1, -S_F^T], [S_Mx, 0]]; a stealthy ZDA at 0 exists iff some kernel vector has
an input part, i.e. rank Q_0 < rank [alpha L_1; S_Mx] + |F|. The reference is that criterion
computed over Q (python-flint), and the exact decider of ``stealthy.zda``.
"""

from __future__ import annotations

import random
from fractions import Fraction
from pathlib import Path

import flint
import networkx as nx
import numpy as np
from certificate_support import certify

from glocal_verify import System, config, spec_from_graph
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda_screens import zero_exponent_status
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda, growth_rank
from glocal_verify.numerics.minors import prime_for
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE
from glocal_verify.spec.load import load_spec
from glocal_verify.spec.writer import dump_spec

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


def _badly_scaled_network() -> System:
    """Seven agents with weights p^2 / 10^6 and p^2 / 10^7 beside 1-2; velocities of 2 and 4 monitored, 5 and 6 attacked."""
    big, huge = Fraction(P24**2, 10**6), Fraction(P30**2, 10**7)
    G = nx.Graph()
    G.add_weighted_edges_from([(2, 3, huge), (3, 4, 2), (2, 5, huge), (2, 6, 1), (2, 7, big), (5, 6, 2), (5, 7, big), (4, 5, 1), (1, 7, 1)])
    return System(spec_from_graph(G, monitor_velocities=[2, 4], attack={"kind": "zda", "actuators": [5, 6]}))


def test_a_persistent_zda_at_zero_the_numeric_zero_set_misses_on_badly_scaled_weights_holds_as_over_q() -> None:
    system = _badly_scaled_network()
    v = decide_zda(system)
    exact = decide_zda(system, options=ZdaOptions(exact=True))
    at0 = decide_zda(system, options=ZdaOptions(exact=True, lambda0=0))
    assert exact.status is Status.HOLDS and at0.direction_source == "requested lambda0"  # a ZDA at 0 over Q
    assert v.numeric_analysis is not None and not v.numeric_analysis.exists  # the point of the example: the numeric zero set misses it
    assert v.status is Status.HOLDS and v.note.startswith("the numeric zero set missed it")
    assert v.certificate is not None and v.certificate.lambda0 == 0 and "exact, from the graph" in v.proof
    # nothing the numeric analysis decided is kept: growth and left-invertibility as proven, or unknown
    assert v.left_invertible in (None, exact.left_invertible)
    if v.growth == "undecided":
        assert not v.complete and growth_rank(v.growth_at_least) <= growth_rank(exact.growth)
    else:
        assert v.growth == exact.growth
    if v.direction is not None:  # a witness is checked against the definition: alpha L_1 xi = S_F^T u0, u0 != 0
        L = np.asarray(system.laplacian(), dtype=float)
        Fi = system.idx((5, 6))
        rhs = np.zeros(system.n, dtype=complex)
        rhs[Fi] = v.direction.u0
        assert np.linalg.norm(float(system.alpha) * L @ v.direction.xi - rhs) <= 1e-6 * np.linalg.norm(L, 2) * np.linalg.norm(v.direction.xi)
        assert np.linalg.norm(v.direction.u0) > 0 and complex(v.direction.value) == 0


def test_the_zda_at_zero_the_numeric_zero_set_misses_gets_an_exact_witness_the_checker_accepts(tmp_path: Path) -> None:
    system = _badly_scaled_network()
    _, doc, out = certify(dump_spec(system.spec), tmp_path)
    zda = next(e for e in doc["verdicts"] if e["id"] == "stealthy.zda")
    assert zda["status"] == "holds" and zda["certificate"]["kind"] == "zda"
    assert out.rejected == []


def _agrees_with_exact_where_it_decides(system: System) -> None:
    """What the numeric verdict claims beyond its status (left-invertibility, growth class, the witness's exponent) is exact arithmetic's."""
    v = decide_zda(system)
    exact = decide_zda(system, options=ZdaOptions(exact=True))
    if v.status is not Status.UNDECIDED:
        assert v.status is exact.status
    if v.left_invertible is not None:
        assert v.left_invertible == exact.left_invertible, (v.left_invertible, v.proof)
    if v.growth != "undecided":
        assert v.growth == exact.growth, (v.growth, exact.growth)
    elif v.growth_at_least:
        assert growth_rank(v.growth_at_least) <= growth_rank(exact.growth)
    if v.status is Status.UNDECIDED and v.direction is not None:  # a numeric candidate is said to be one
        assert v.direction_source == "requested lambda0" or v.direction_source.startswith("not proven"), v.direction_source
    elif v.direction is not None:  # a stealthy ZDA exists at the witness's exponent, over Q
        lam = complex(v.direction.value)
        if lam.imag == 0 and lam.real == round(lam.real):
            there = decide_zda(system, options=ZdaOptions(exact=True, lambda0=int(lam.real)))
            assert there.direction_source == "requested lambda0", v.direction_source
        elif exact.left_invertible is not False:  # an irrational exponent: one of the exact zeros (not left-invertible: any)
            assert exact.exact_analysis is not None
            assert any(abs(complex(z.value) - lam) <= 1e-6 * max(1.0, abs(lam)) for z in exact.exact_analysis.zeros), (lam, v.direction_source)


def test_a_numeric_rank_drop_of_the_whole_pencil_that_exact_arithmetic_refutes_claims_neither_unbounded_growth_nor_a_witness_at_one() -> None:
    system = System(load_spec(Path(__file__).parent / "data" / "identical-clusters-badly-scaled.toml"))
    v = decide_zda(system)
    assert v.numeric_analysis is not None and not v.numeric_analysis.left_invertible  # the point of the example
    assert decide_zda(system, options=ZdaOptions(exact=True)).left_invertible  # ... which exact arithmetic refutes
    assert v.status is Status.HOLDS and v.left_invertible is None and v.growth == "undecided"
    assert v.direction is None or complex(v.direction.value) == 0
    _agrees_with_exact_where_it_decides(system)


def test_on_badly_scaled_random_networks_the_numeric_verdict_claims_only_what_exact_arithmetic_confirms() -> None:
    rng = random.Random(4701)
    for _ in range(60):
        system, _ = _random_system(rng)
        _agrees_with_exact_where_it_decides(system)


def test_a_direction_inside_f_that_no_outside_link_sees_proves_not_left_invertible_only_when_exact_arithmetic_agrees() -> None:
    from glocal_verify.analysis.stealthy.zda_screens import invisible_inside_f

    rng = random.Random(4702)
    proved = 0
    for k in range(120):
        system, F = _random_system(rng)
        if k % 3 == 0:  # twin attacked agents: the same links, so e_a - e_r is seen by no outside agent
            a, r = F[0], system.n + 1
            G = nx.Graph()
            G.add_nodes_from(system.labels)
            for (i, j), w in laplacian_entries(system, NORMAL_MODE).items():
                if i < j and w != 0:
                    G.add_edge(system.labels[i], system.labels[j], weight=-w)
            G.add_node(r)
            for b in list(G.neighbors(a)):
                G.add_edge(r, b, weight=G[a][b]["weight"])
            mx = [m for m in system.monitored_positions if m not in (a, r)]
            system = System(spec_from_graph(G, monitor_positions=mx or [next(b for b in G if b not in (a, r))], attack={"kind": "zda", "actuators": sorted({*F, r})}))
            F = sorted({*F, r})
        if invisible_inside_f(system, F) is not None:
            proved += 1
            assert decide_zda(system, options=ZdaOptions(exact=True)).left_invertible is False
    assert proved >= 20


def test_a_separator_keeps_its_proof_of_unbounded_growth_when_the_spec_requests_lambda0() -> None:
    # path 1-2-3-4-5, position of 5 measured, agents 1 and 3 attacked: one path from F to M < |F| = 2,
    # and no direction inside F that no outside link sees (the separator proves it, the kernel test cannot)
    from glocal_verify.analysis.stealthy.zda_screens import invisible_inside_f

    system = System(spec_from_graph(nx.path_graph(range(1, 6)), monitor_positions=[5], attack={"kind": "zda", "actuators": [1, 3]}))
    assert invisible_inside_f(system, [1, 3]) is None
    for lam in (None, 1):
        v = decide_zda(system, options=ZdaOptions(lambda0=lam))
        exact = decide_zda(system, options=ZdaOptions(exact=True, lambda0=lam))
        assert exact.left_invertible is False and exact.growth == "unbounded"
        assert v.status is Status.HOLDS and v.left_invertible is False and v.growth == "unbounded", (lam, v.growth)
