"""Stealthy attacks: Proposition II.4 (i) and (ii).

The paper's objects: the zero-dynamics attack (ZDA) of the normal mode, i.e. the invariant
zeros of :math:`(A_1, B_F, C, 0)` (eq. ``zda_cond``) with their state and input directions and
their growth, and the covert attack with the channels it must own.

- :mod:`.zda`, :mod:`.zda_exact` -- the zeros and directions, numeric (modal pencil) and over Q;
- :mod:`.zda_verdict` -- the rule of ``stealthy.zda``: the witness and its certificate;
- :mod:`.zda_certificate`, :mod:`.zda_screens`, :mod:`.zda_local`, :mod:`.zda_completeness` --
  what proves a numeric verdict: rigorous bounds, exact supports, whole-system screens, a zero
  proved inside the attacked clusters, and the completeness of the zero set;
- :mod:`.zda_batch` -- witness directions of many actuator sets at once (the audit);
- :mod:`.covert` -- the rule of ``stealthy.covert``: the agents a covert attack reaches.

Layer: above :mod:`glocal_verify.analysis.local` (the cluster pencil's zero forcing); imports
no higher topic.
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): importing one module of this folder loads no other
    from glocal_verify.analysis.stealthy.zda import ZdaZero, ZdaDirection, ZdaAnalysis, zda_analysis
    from glocal_verify.analysis.stealthy.zda_exact import ExactZdaAnalysis, zda_analysis_exact
    from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, ZdaVerdict, decide_zda, zda_direction
    from glocal_verify.analysis.stealthy.zda_certificate import ZdaCertificate
    from glocal_verify.analysis.stealthy.zda_completeness import ZeroSetCompleteness, zero_set_completeness
    from glocal_verify.analysis.stealthy.covert import covert_required_channels, reachable_agents

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "ZdaZero": "glocal_verify.analysis.stealthy.zda",
    "ZdaDirection": "glocal_verify.analysis.stealthy.zda",
    "ZdaAnalysis": "glocal_verify.analysis.stealthy.zda",
    "zda_analysis": "glocal_verify.analysis.stealthy.zda",
    "zda_direction": "glocal_verify.analysis.stealthy.zda_verdict",
    "ZdaOptions": "glocal_verify.analysis.stealthy.zda_verdict",
    "ExactZdaAnalysis": "glocal_verify.analysis.stealthy.zda_exact",
    "zda_analysis_exact": "glocal_verify.analysis.stealthy.zda_exact",
    "ZdaVerdict": "glocal_verify.analysis.stealthy.zda_verdict",
    "decide_zda": "glocal_verify.analysis.stealthy.zda_verdict",
    "ZdaCertificate": "glocal_verify.analysis.stealthy.zda_certificate",
    "ZeroSetCompleteness": "glocal_verify.analysis.stealthy.zda_completeness",
    "zero_set_completeness": "glocal_verify.analysis.stealthy.zda_completeness",
    "covert_required_channels": "glocal_verify.analysis.stealthy.covert",
    "reachable_agents": "glocal_verify.analysis.stealthy.covert",
})

#: ``glocal_verify.analysis.stealthy.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.analysis.stealthy", _LAZY, globals())

__all__ = [
    "ZdaZero",
    "ZdaDirection",
    "ZdaAnalysis",
    "zda_analysis",
    "zda_direction",
    "ExactZdaAnalysis",
    "zda_analysis_exact",
    "ZdaOptions",
    "ZdaVerdict",
    "decide_zda",
    "ZdaCertificate",
    "ZeroSetCompleteness",
    "zero_set_completeness",
    "covert_required_channels",
    "reachable_agents",
]
