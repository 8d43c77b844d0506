"""The sampled conditions agree with exact arithmetic on random integer-weight systems (N <= 8).

``sampled.zda`` holds only with an attack input: a zero of the sampled pencil whose kernel has
``u = 0`` only is an unobservable mode (the consensus mode at z = 1 when every velocity is
monitored), not a zero-dynamics attack. A numeric verdict that the exact discretisation
contradicts is a bug of the highest priority.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import assert_numeric_matches_exact, systems

from glocal_verify import System
from glocal_verify.spec.types import AttackSpec, ImplementationSpec

#: the sampled conditions with an exact path for the sampled controller
SAMPLED_EXACT = ["sampled.zda", "sampled.stability", "sampled.observability"]


@st.composite
def sampled_systems(draw: st.DrawFn, max_n: int = 8) -> System:
    """A random system with a sampled controller at a rational period and a ZDA attacker."""
    system = draw(systems(max_n=max_n, max_modes=1))
    labels = list(system.labels)
    actuators = tuple(draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=min(3, len(labels)))))
    if draw(st.booleans()):  # every velocity monitored: the z = 1 consensus mode is unobservable, no attack input
        spec = dataclasses.replace(system.spec, monitor=dataclasses.replace(system.spec.monitor, velocities=tuple(labels)))
    else:
        spec = system.spec
    period = draw(st.sampled_from([Fraction(1, 10), Fraction(1, 4), Fraction(1, 100), Fraction(3, 7)]))
    spec = dataclasses.replace(spec, attack=AttackSpec("zda", actuators), implementation=ImplementationSpec(period=period))
    return System(spec)


@settings(max_examples=25, deadline=None)
@given(sampled_systems())
def test_numeric_and_exact_sampled_verdicts_agree(system: System) -> None:
    assert_numeric_matches_exact(system, SAMPLED_EXACT)


def test_the_consensus_mode_of_a_fully_monitored_network_is_no_sampled_attack() -> None:
    from glocal_verify import load_example, verify
    from glocal_verify.spec.writer import dump_spec
    from glocal_verify.spec import loads_spec

    base = load_example("paper19")
    spec = dataclasses.replace(
        base,
        monitor=dataclasses.replace(base.monitor, velocities=tuple(base.nodes)),
        attack=AttackSpec("zda", (3,)),
        implementation=ImplementationSpec(period=Fraction(1, 100)),
    )
    system = System(loads_spec(dump_spec(spec)))
    for exact in (False, True):
        (r,) = verify(system, ["sampled.zda"], exact=exact).conditions
        assert r.status.value == "fails", (exact, r.witness)
        assert all(z["attack"] is False for z in r.witness["zeros"])
    (c,) = verify(system, ["stealthy.zda"]).conditions
    assert c.status.value == "fails"  # the continuous loop agrees: no ZDA for one attacker with every velocity seen
