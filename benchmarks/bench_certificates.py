"""Certificates of verdicts (issue 51): checking them against verifying.

On the realistic family (clusters of about 100 agents, one observer each, one safe mode;
``random_clustered_spec(n, n // 100, seed=7, modes=1)``) at N = 1000 (``--quick``: 250), each
command in its own process: ``glocal-verify verify SPEC`` (the baseline), the same with
``--certificates FILE`` (the cost of writing them) and ``python -m glocal_check SPEC FILE``
(the candidate: the goal is that checking takes no longer than verifying). The note gives the
checker's summary line.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from glocal_verify.design.generators import random_clustered_spec

from .harness import Row, cli, run_command, write_spec

GROUP = "certificates of verdicts: python -m glocal_check against verify (each in its own process)"


def run(quick: bool) -> list[Row]:
    n = 250 if quick else 1000
    spec = random_clustered_spec(n, max(2, n // 100), seed=7, modes=1)
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        path = write_spec(spec, Path(tmp), f"real{n}")
        out, cert = os.path.join(tmp, "r.json"), os.path.join(tmp, "c.json")
        base = run_command(cli("verify", str(path), "--quiet", "--format", "json", "--out", out), timeout=900.0)
        emit = run_command(cli("verify", str(path), "--quiet", "--format", "json", "--out", out, "--certificates", cert), timeout=900.0)
        check = run_command([sys.executable, "-m", "glocal_check", str(path), cert], timeout=900.0)
        summary = subprocess.run([sys.executable, "-m", "glocal_check", str(path), cert], capture_output=True, text=True, timeout=900.0).stdout.strip().splitlines()
        case = f"N = {n}, {max(2, n // 100)} clusters of ~100 (realistic)"
        rows.append(Row(GROUP, case, "glocal-verify verify", base.seconds, "verify --certificates FILE", emit.seconds, f"{emit.describe(900.0)}; writing the certificates costs {emit.seconds - base.seconds:.1f} s", emit.peak_mib))
        rows.append(
            Row(GROUP, case, "glocal-verify verify", base.seconds, "python -m glocal_check SPEC FILE", check.seconds,
                f"{check.describe(900.0)}; goal: ratio >= 1; {summary[-1] if summary else 'no summary'}", check.peak_mib)
        )
    return rows
