"""The local observers' conditions: Proposition III.2 (i)-(iii) on each cluster.

The paper's objects: the cluster subsystem seen by a local observer (its states, the suspected
attacked agents, the measured neighbours), its k-connectivity and rank conditions, and the
cluster's Rosenbrock pencil (eq. ``uio_conds_1``) with its zeros.

- :mod:`.cases` -- the local cases: one per cluster, observer, mode and suspected set;
- :mod:`.structure` -- the rules of ``local.k-connected`` and ``local.rank`` (Prop. III.2 (i), (ii));
- :mod:`.pencil` -- the rule of ``local.pencil`` (Prop. III.2 (iii)), numeric and exact;
- :mod:`.cluster_pencil` -- zero forcing and the reduced symmetric pencil of a cluster;
- :mod:`.cluster_modal` -- the interior eigen-decomposition of a cluster block, shared by the
  unknown-input observer designs of :mod:`glocal_verify.observers`.

Layer: above :mod:`glocal_verify.analysis.unobservable`; imports no higher topic.
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): importing one module of this folder loads no other
    from glocal_verify.analysis.local.cases import LocalCase, local_cases, certify_pencil_verdict
    from glocal_verify.analysis.local.structure import k_connected_verdict, rank_verdict
    from glocal_verify.analysis.local.pencil import pencil_verdict, pencil_verdict_exact
    from glocal_verify.analysis.local.cluster_pencil import ReducedPencil, reduced_pencil
    from glocal_verify.analysis.local.cluster_modal import InteriorModes, interior_modes

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "LocalCase": "glocal_verify.analysis.local.cases",
    "local_cases": "glocal_verify.analysis.local.cases",
    "certify_pencil_verdict": "glocal_verify.analysis.local.cases",
    "k_connected_verdict": "glocal_verify.analysis.local.structure",
    "rank_verdict": "glocal_verify.analysis.local.structure",
    "pencil_verdict": "glocal_verify.analysis.local.pencil",
    "pencil_verdict_exact": "glocal_verify.analysis.local.pencil",
    "ReducedPencil": "glocal_verify.analysis.local.cluster_pencil",
    "reduced_pencil": "glocal_verify.analysis.local.cluster_pencil",
    "InteriorModes": "glocal_verify.analysis.local.cluster_modal",
    "interior_modes": "glocal_verify.analysis.local.cluster_modal",
})

#: ``glocal_verify.analysis.local.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.analysis.local", _LAZY, globals())

__all__ = [
    "LocalCase",
    "local_cases",
    "certify_pencil_verdict",
    "k_connected_verdict",
    "rank_verdict",
    "pencil_verdict",
    "pencil_verdict_exact",
    "ReducedPencil",
    "reduced_pencil",
    "InteriorModes",
    "interior_modes",
]
