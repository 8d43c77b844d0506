"""`glocal-verify verify` on random clustered networks: structured path at scale.

Baselines, measured in the same run:
- the same structured verification at N = 250 (scaling ratio);
- the generic dense methods (2N-state pencil for the ZDA, orthogonal staircase for the
  unobservable subspace) against the structured N-sized ones on the same systems;
- the exact (flint) decision of Theorem III.3 (ii) against the numeric one at small N.
"""

from __future__ import annotations

from glocal_verify import System, verify
from glocal_verify.analysis.unobservable import unobservable_subspace
from glocal_verify.analysis.zda import zda_analysis
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.staircase import unobservable_subspace_dense

from .harness import Row, best_time


def run(quick: bool) -> list[Row]:
    rows: list[Row] = []
    sizes = [250, 500] if quick else [250, 500, 1000, 2000]
    base_t: float | None = None
    for n in sizes:
        spec = random_clustered_spec(n, 3, seed=7)

        def job(spec=spec) -> None:  # type: ignore[no-untyped-def]
            verify(System(spec))

        t = best_time(job, repeat=2 if n >= 1000 else 3, budget=300.0)
        if base_t is None:
            base_t = t
        rows.append(
            Row(
                "verify (every implemented checker, structured paths)",
                f"N = {n}, 3 clusters",
                "same at N = 250",
                base_t,
                "structured verify",
                t,
                f"time grows x{t / base_t:.1f} for x{n / 250:.0f} agents",
            )
        )
    for n in ([40, 80] if quick else [40, 80, 160]):
        system = System(random_clustered_spec(n, 2, seed=5))
        A, C = system.A(), system.C()

        def fresh(system: System = system) -> System:
            return System(system.spec)  # no cached eigen-decomposition

        td = best_time(lambda: zda_analysis(fresh(), method="dense"), budget=120.0)
        ts = best_time(lambda: zda_analysis(fresh()))
        rows.append(Row("stealthy.zda: structured (N-sized modal pencil) vs dense (2N Rosenbrock pencil)", f"N = {n}", "dense pencil", td, "structured", ts))
        tdo = best_time(lambda: unobservable_subspace_dense(A, C), budget=120.0)
        tso = best_time(lambda: unobservable_subspace(fresh()))
        rows.append(Row("unobservable subspace: modal formula vs dense staircase", f"N = {n}", "dense staircase", tdo, "modal", tso))
    for n in ([20, 40] if quick else [20, 40, 80]):
        spec = random_clustered_spec(n, 2, seed=3)
        system = System(spec)
        tn = best_time(lambda: verify(system, ["switching.distinct-eigenvalues"]))
        te = best_time(lambda: verify(system, ["switching.distinct-eigenvalues"], exact=True))
        rows.append(Row("Theorem III.3 (ii): exact vs numeric", f"N = {n}", "exact (flint charpoly, gcd)", te, "numeric (eigh)", tn))
    return rows
