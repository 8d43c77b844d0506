"""Design claims hold on small random clustered networks (glocal_verify.design.generators).

Each property re-checks a claim of :mod:`glocal_verify.design` with the exact checkers: the
one-link form of Theorem III.3, the minimum of the designed monitors, the audit rows, and
the exposure claimed by designed safe modes.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify.conditions.registry import check_conditions
from glocal_verify.design.audit import audit
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.design.monitors import _blocks, _f, design_monitors
from glocal_verify.design.safe_modes import (
    ProposedMode,
    _admissible,
    default_candidates,
    design_safe_modes,
    eigenvector_error,
    with_attack,
    with_modes,
)
from glocal_verify.model import System
from glocal_verify.results import Status

THEOREM = ["switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences"]

networks = st.builds(
    lambda n, seed: System(random_clustered_spec(n, 2, seed=seed, monitors=2, modes=1, max_weight=3, attack=False)),
    st.integers(8, 12),
    st.integers(0, 10_000),
)


@settings(max_examples=4)
@given(networks, st.integers(0, 1000))
def test_one_link_theorem_agrees_with_the_exact_checkers(system: System, pick: int) -> None:
    err = eigenvector_error(system)
    cands = [c for c in default_candidates(system, (Fraction(1),))]
    ok = _admissible(system, cands, err)
    idx = [int(np.flatnonzero(ok)[pick % ok.sum()])] if ok.any() else []
    idx += [int(np.flatnonzero(~ok)[pick % (~ok).sum()])] if err is not None and (~ok).any() else []
    for k in idx:
        mode = ProposedMode("m", cands[k], ()).mode_spec()
        sub = System(with_modes(system.spec, [mode], keep=False))
        if not all(len(c) > 1 for c in sub.components("m")[:1]):
            continue  # a removal that disconnects the graph: (ii) fails, as the filter says
        sts = {r.status for r in check_conditions(sub, THEOREM, exact=True).conditions}
        if ok[k]:
            assert sts == {Status.HOLDS}, cands[k]
        else:
            assert Status.FAILS in sts, cands[k]


@settings(max_examples=4)
@given(networks)
def test_designed_monitors_are_minimal_and_keep_privacy(system: System) -> None:
    d = design_monitors(system)
    assert d.ok, d.verification
    blocks = _blocks(system, system.safe_modes)
    goal = _f(blocks, set(range(system.n)))
    D = sorted({i for Dq, _ in blocks for i in Dq})
    if d.velocities:
        for smaller in itertools.combinations(D, len(d.velocities) - 1):
            assert _f(blocks, set(smaller)) < goal


@settings(max_examples=4)
@given(networks, st.integers(0, 1000))
def test_audit_rows_agree_with_verify_on_their_attack(system: System, pick: int) -> None:
    res = audit(system, 1)
    row = res.rows[pick % len(res.rows)]
    rep = check_conditions(System(with_attack(system.spec, row.actuators)), ["stealthy.zda", "switching.avoids-attack"], exact=True)
    (z,) = rep.results("stealthy.zda")
    assert row.stealthy is (z.status is Status.HOLDS)
    if row.stealthy:
        for r in rep.results("switching.avoids-attack"):
            assert row.witness["modes"][r.scope["mode"]]["switching.avoids-attack"] == r.status.value


@settings(max_examples=4)
@given(networks)
def test_designed_safe_modes_expose_what_they_claim(system: System) -> None:
    res = audit(system, 1)
    stealthy = [r.actuators for r in res.rows if r.stealthy][:3]
    lambdas = {r.actuators: r.lambda0 for r in res.rows if r.lambda0 is not None}
    if not stealthy:
        return
    d = design_safe_modes(system, stealthy, None, 2, lambdas=lambdas, exact=True)
    for m in d.modes:
        for F in m.exposes:
            spec = with_attack(with_modes(system.spec, [m.mode_spec()], keep=False), F)
            rep = check_conditions(System(spec), THEOREM + ["switching.avoids-attack"], exact=True)
            assert all(r.status is Status.HOLDS for r in rep.conditions if r.id in THEOREM)
            assert [r.status for r in rep.results("switching.avoids-attack")] == [Status.FAILS]
    assert set(d.targets) == set(stealthy)
    for F in stealthy:
        assert any(F in m.exposes for m in d.modes) or ",".join(map(str, F)) in d.unexposed
