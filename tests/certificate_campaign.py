#!/usr/bin/env python
"""The certificate campaign of issue 51 (no pytest needed):

    nice -n 10 python tests/certificate_campaign.py --networks 50 --mutants 1000

1. The bundled examples and ``--networks`` generated networks (``random_clustered_spec``,
   N <= 200: with and without an attack, 1-3 safe modes, 1-2 observers per cluster, 1-4
   clusters, 3-6 monitors): verify, write the certificates, check them with ``glocal_check``;
   one line per network, then the certificates without one by condition id and reason.
2. ``--mutants`` mutants (``tests/certificate_support.py``), spread over paper19 and the
   first generated networks: the rejection rate, and every accepted mutant with whether its
   claim is true (``verify(..., exact=True)``).

Exit 1 when a certificate is rejected, a decided verdict has none, a mutant rate is below 99 %
or an accepted mutant's claim is false.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from certificate_support import certify, mutation_run  # noqa: E402

from glocal_verify.design.generators import random_clustered_spec  # noqa: E402
from glocal_verify.spec.examples import example_names, example_text, finding_names  # noqa: E402
from glocal_verify.spec.writer import dump_spec  # noqa: E402

SIZES = (12, 20, 30, 45, 60, 90, 120, 150, 200)


def networks(count: int) -> list[tuple[str, str]]:
    out = []
    seed = 0
    while len(out) < count:
        n = SIZES[seed % len(SIZES)]
        kw = dict(clusters=1 + seed % 4, seed=seed, modes=1 + seed % 3, attack=seed % 4 != 3, monitors=3 + seed % 4, observers_per_cluster=1 + seed % 2)
        seed += 1
        try:
            out.append((f"random N={n} {kw}", dump_spec(random_clustered_spec(n, **kw))))
        except ValueError:
            continue
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--networks", type=int, default=50)
    ap.add_argument("--mutants", type=int, default=1000)
    args = ap.parse_args()
    bad = False
    missing: collections.Counter[tuple[str, str]] = collections.Counter()
    total = collections.Counter()
    specs = [(name, example_text(name)) for name in list(example_names()) + list(finding_names())] + networks(args.networks)
    with tempfile.TemporaryDirectory() as tmp:
        for k, (name, text) in enumerate(specs):
            t = time.perf_counter()
            _, doc, out = certify(text, Path(tmp), f"s{k}")
            print(f"{name}: {out.summary()} ({time.perf_counter() - t:.1f} s)", flush=True)
            for line in out.rejected:
                print("   ", line)
            bad |= bool(out.rejected) or out.without > 0
            total.update(accepted=out.accepted, rejected=len(out.rejected), without=out.without, observations=out.observations)
            for e in doc["verdicts"]:
                if e["certificate"] is None:
                    missing[(e["id"], e["reason"])] += 1
        print(f"\nall {len(specs)} networks: {total['accepted']} accepted, {total['rejected']} rejected, {total['without']} without a certificate; {total['observations']} simulated observations (switching.detects) listed apart")
        for (cid, why), n in missing.most_common():
            print(f"  {n:4d} x {cid}: {why}")
        targets = [("paper19", example_text("paper19"))] + networks(4)
        per = -(-args.mutants // len(targets))
        tallies = {"main": [0, 0], "weight_refreshed": [0, 0]}
        for k, (name, text) in enumerate(targets):
            got = mutation_run(text, Path(tmp), per, seed=k)
            for key, run in (("main", got), ("weight_refreshed", got["weight_refreshed"])):
                tallies[key][0] += run["mutants"]
                tallies[key][1] += run["rejected"]
                for a in run["accepted"]:
                    print(f"  accepted {key} mutant ({a['how']}) of {a['id']} {a['scope']} on {name}: claim {'true' if a['true'] else 'FALSE'}")
                    bad |= not a["true"]
        for key, (m, r) in tallies.items():
            print(f"mutants ({key}): {r} of {m} rejected ({100.0 * r / max(m, 1):.1f} %)")
        bad |= tallies["main"][1] < 0.99 * tallies["main"][0]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
