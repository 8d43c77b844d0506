"""Shared pytest configuration: hypothesis profiles chosen by GLOCAL_PROFILE.

- ``ci`` (default): derandomized, bounded example counts, so the whole suite stays well under
  ten minutes on two cores and every run sees the same examples.
- ``dev``: random, a few more examples.
- ``fuzz``: long campaigns, ``GLOCAL_PROFILE=fuzz pytest tests/properties``.
"""

from __future__ import annotations

import os

# The suite solves many small dense problems; on a 2-core machine threaded BLAS only adds
# contention (placement ran ~60x slower under load). Must be set before numpy loads BLAS.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
import sys
from pathlib import Path

from hypothesis import HealthCheck, settings

sys.path.insert(0, str(Path(__file__).parent))

settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=40,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.register_profile("dev", max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile(
    "fuzz", max_examples=3000, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large]
)
settings.load_profile(os.environ.get("GLOCAL_PROFILE", "ci"))
