"""The sampled implementation: the closed loop held over a period h, mode by mode.

The paper's objects re-decided for a sampled deployment (``docs/guarantees.md``): the
discretised modes :math:`(\\Phi_q, \\Gamma)` of eq. ``cl_sys`` per Laplacian eigenvalue,
their stability, aliasing and observability, the zero dynamics of the discrete pencil of
:math:`(\\Phi_1, \\Gamma_F, C)`, and the pathological periods where sampling loses any of them.

- :mod:`.loop` -- the sampled modes, their stability, aliasing and observability;
- :mod:`.zda` -- zero-dynamics attacks of the sampled loop;
- :mod:`.scan` -- pathological sampling periods.

Layer: above :mod:`glocal_verify.analysis.unobservable`; imports no other topic.
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): importing one module of this folder loads no other
    from glocal_verify.analysis.sampled.loop import SampledModes, sampled_modes, SampledStability, sampled_stability, Aliasing, sampled_aliasing, SampledObservability, sampled_observability
    from glocal_verify.analysis.sampled.zda import SampledZda, sampled_zda
    from glocal_verify.analysis.sampled.scan import PeriodScan, scan_periods

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "SampledModes": "glocal_verify.analysis.sampled.loop",
    "sampled_modes": "glocal_verify.analysis.sampled.loop",
    "SampledStability": "glocal_verify.analysis.sampled.loop",
    "sampled_stability": "glocal_verify.analysis.sampled.loop",
    "Aliasing": "glocal_verify.analysis.sampled.loop",
    "sampled_aliasing": "glocal_verify.analysis.sampled.loop",
    "SampledObservability": "glocal_verify.analysis.sampled.loop",
    "sampled_observability": "glocal_verify.analysis.sampled.loop",
    "SampledZda": "glocal_verify.analysis.sampled.zda",
    "sampled_zda": "glocal_verify.analysis.sampled.zda",
    "PeriodScan": "glocal_verify.analysis.sampled.scan",
    "scan_periods": "glocal_verify.analysis.sampled.scan",
})

#: ``glocal_verify.analysis.sampled.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.analysis.sampled", _LAZY, globals())

__all__ = [
    "SampledModes",
    "sampled_modes",
    "SampledStability",
    "sampled_stability",
    "Aliasing",
    "sampled_aliasing",
    "SampledObservability",
    "sampled_observability",
    "SampledZda",
    "sampled_zda",
    "PeriodScan",
    "scan_periods",
]
