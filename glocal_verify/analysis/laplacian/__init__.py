"""The Laplacian over Q: the exact objects every topic of the analysis shares.

- :mod:`.twins` -- the exact entries of L_q, and twin agents: exact eigenvectors
  :math:`e_a - e_r` of L_q, with the modular decisions of Theorem III.3 (ii) and (iii) they settle;
- :mod:`.transfer` -- the transfer function of the agents' input dynamics over Q,
  :math:`\\operatorname{adj}(sI + \\alpha L_q) S_F^\\top` (the zero polynomial of eq. ``zda_cond``).

Layer: the lowest topic of :mod:`glocal_verify.analysis`; imports :mod:`glocal_verify.model`
and :mod:`glocal_verify.numerics`, no other topic.
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): importing one module of this folder loads no other
    from glocal_verify.analysis.laplacian.twins import laplacian_entries, distinct_eigenvalues_modular, eigenvector_differences_modular
    from glocal_verify.analysis.laplacian.transfer import laplacian_transfer

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "laplacian_entries": "glocal_verify.analysis.laplacian.twins",
    "distinct_eigenvalues_modular": "glocal_verify.analysis.laplacian.twins",
    "eigenvector_differences_modular": "glocal_verify.analysis.laplacian.twins",
    "laplacian_transfer": "glocal_verify.analysis.laplacian.transfer",
})

#: ``glocal_verify.analysis.laplacian.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.analysis.laplacian", _LAZY, globals())

__all__ = [
    "laplacian_entries",
    "distinct_eigenvalues_modular",
    "eigenvector_differences_modular",
    "laplacian_transfer",
]
