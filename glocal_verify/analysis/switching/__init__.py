"""Safe-mode switching: Theorem III.3 (i)-(iii), Lemma A.2 and Remark III.3.1.

The paper's objects: the link change :math:`\\Delta L_q = L_q - L_1` of a safe mode, the image
and kernel condition and the coverage of Lemma A.2, the distinct eigenvalues and eigenvector
differences of L_q, and whether the switch touches a stealthy attack direction
(:math:`\\Delta L_q \\xi \\ne 0`, Remark III.3.1).

- :mod:`.image_kernel` -- the rules of ``switching.image-kernel`` and ``switching.coverage``;
- :mod:`.eigenstructure` -- the rules of ``switching.distinct-eigenvalues`` and
  ``switching.eigenvector-differences``;
- :mod:`.touch` -- :math:`\\Delta L_q` on its switching components and :class:`Avoidance`;
- :mod:`.avoidance` -- the rule of ``switching.avoids-attack`` (numeric and exact touch tests);
- :mod:`.zero_touch` -- the exact touch test at lambda0 = 0 from potentials of L_1.

Layer: above :mod:`glocal_verify.analysis.stealthy` (a touch test reads the ZDA verdict).
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): importing one module of this folder loads no other
    from glocal_verify.analysis.switching.image_kernel import image_kernel_verdict, coverage_verdict
    from glocal_verify.analysis.switching.eigenstructure import distinct_eigenvalues_verdict, eigenvector_differences_verdict
    from glocal_verify.analysis.switching.touch import Avoidance
    from glocal_verify.analysis.switching.avoidance import AvoidanceVerdict, decide_avoidance, avoidance_exact
    from glocal_verify.analysis.switching.zero_touch import ZeroTouch, touch_at_zero

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "image_kernel_verdict": "glocal_verify.analysis.switching.image_kernel",
    "coverage_verdict": "glocal_verify.analysis.switching.image_kernel",
    "distinct_eigenvalues_verdict": "glocal_verify.analysis.switching.eigenstructure",
    "eigenvector_differences_verdict": "glocal_verify.analysis.switching.eigenstructure",
    "Avoidance": "glocal_verify.analysis.switching.touch",
    "AvoidanceVerdict": "glocal_verify.analysis.switching.avoidance",
    "decide_avoidance": "glocal_verify.analysis.switching.avoidance",
    "avoidance_exact": "glocal_verify.analysis.switching.avoidance",
    "ZeroTouch": "glocal_verify.analysis.switching.zero_touch",
    "touch_at_zero": "glocal_verify.analysis.switching.zero_touch",
})

#: ``glocal_verify.analysis.switching.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.analysis.switching", _LAZY, globals())

__all__ = [
    "image_kernel_verdict",
    "coverage_verdict",
    "distinct_eigenvalues_verdict",
    "eigenvector_differences_verdict",
    "Avoidance",
    "AvoidanceVerdict",
    "decide_avoidance",
    "avoidance_exact",
    "ZeroTouch",
    "touch_at_zero",
]
