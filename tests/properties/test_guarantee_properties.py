"""On random small clustered networks: no attack-free run crosses a certified threshold, and
every attack above its guaranteed size raises an alarm in time (simulation)."""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st
from strategies import clustered_systems

from glocal_verify import System
from glocal_verify.errors import NotApplicableError
from glocal_verify.simulation.certified_thresholds import certified_thresholds
from glocal_verify.simulation.guarantees import detection_guarantee
from glocal_verify.simulation.sampled_attack import SampledAttack
from glocal_verify.simulation.sampled_runs import Target, simulate_sampled
from glocal_verify.spec.types import ImplementationSpec, SimulationSpec, UncertaintySpec

#: each example computes thresholds and simulates: a quarter of the profile's budget
SLOW = settings(max_examples=max(10, settings.default.max_examples // 4), suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much, HealthCheck.data_too_large])


def _deployed(system: System, noise: Fraction, dist: Fraction) -> System:
    spec = dataclasses.replace(
        system.spec,
        simulation=SimulationSpec(2.0, 0.01, 0),
        uncertainty=UncertaintySpec(initial_state=Fraction(1), noise=(("*", noise),), disturbance=dist),
        implementation=ImplementationSpec(Fraction(1, 100)),
        switching=None,
    )
    return System(spec)


@SLOW
@given(clustered_systems(max_n=7), st.sampled_from([Fraction(0), Fraction(1, 100)]), st.sampled_from([Fraction(0), Fraction(1, 50)]), st.integers(0, 2**31 - 1))
def test_no_attack_free_run_crosses_and_every_attack_above_its_guaranteed_size_is_caught(system: System, noise: Fraction, dist: Fraction, seed: int) -> None:
    sy = _deployed(system, noise, dist)
    try:
        th = certified_thresholds(sy)
    except NotApplicableError:
        assume(False)
    assume(th.observers)
    event(f"detectors: {len(th.observers)}")
    rng = np.random.default_rng(seed)
    names = list(th.observers)
    targets = []
    for i in range(8):
        nm = names[i % len(names)]
        targets.append(Target(nm, int(rng.integers(len(th.observers[nm].channels))), int(rng.integers(1, th.horizon)), float(rng.choice([-1, 1]))))
    for kind, n, tg in (("random", 12, None), ("vertex", 12, None), ("adversarial", 8, targets)):
        b = simulate_sampled(sy, th, n, kind=kind, seed=seed, targets=tg)
        assert sum(b.crossings.values()) == 0, (kind, b.crossings, {k: float(v.max()) for k, v in b.max_ratio.items()})
    # a held attack on the spec's actuators (a slowly growing oscillation), from t = 0
    F = sy.spec.attack.actuators  # type: ignore[union-attr]
    u0 = rng.normal(size=len(F)) + 1j * rng.normal(size=len(F))
    z = 1.01 * complex(math.cos(0.2), math.sin(0.2))
    atk = SampledAttack("zda", tuple(F), z, u0 / np.linalg.norm(u0), np.zeros(2 * sy.n, dtype=complex), 0, 1.0)
    try:
        g = detection_guarantee(sy, attack=atk, thresholds=th, size_horizon=1.0)
    except NotApplicableError as exc:
        event(f"no guarantee: {str(exc)[:40]}")
        return
    if g.min_size is None or not math.isfinite(g.min_size) or g.min_size > 1e8:
        event("the attack is caught by no detector within 1 s")
        return
    event("attack checked above its guaranteed size")
    b = simulate_sampled(sy, th, 16, kind="vertex", seed=seed, attack=atk, size=1.01 * g.min_size)
    first = np.min(np.stack([np.where(v >= 0, v, 10**9) for v in b.first_alarm.values()]), axis=0)
    assert np.all(first <= 100), first
