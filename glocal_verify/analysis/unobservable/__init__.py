"""Unobservable subspaces: Lemma II.3, Lemma III.1 and Problem 1 (i).

The paper's objects: the eigen-groups of L_q with their unobservable parts (the modal
structure of eq. ``cl_sys``), the unobservable subspace :math:`\\mathcal N_q` of
:math:`(A_q, C)` per mode, the switched unobservable subspace of a mode sequence
(Lemma II.3, ``lemma:observability``), and the invariant unobservable subspace behind privacy
(Lemma III.1, ``lemma:Inv_unobs_subspace``).

- :mod:`.modal` -- eigen-groups of L_q with their unobservable parts;
- :mod:`.subspace` -- :math:`\\mathcal N_q` per mode, certified from the modal structure and over Q;
- :mod:`.switched` -- the switched unobservable subspace over a mode sequence;
- :mod:`.observability` -- the rule of ``switched-observability`` and its state-map witnesses;
- :mod:`.privacy` -- the rules of the ``privacy.*`` conditions.

Layer: above :mod:`glocal_verify.analysis.laplacian`; imports no other topic.
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): importing one module of this folder loads no other
    from glocal_verify.analysis.unobservable.modal import ModalDecomposition, modal_decomposition
    from glocal_verify.analysis.unobservable.subspace import CertifiedUnobservable, certified_unobservable, unobservable_subspace, unobservable_subspace_exact
    from glocal_verify.analysis.unobservable.switched import CertifiedSwitched, certified_switched, switched_unobservable_subspace
    from glocal_verify.analysis.unobservable.observability import observability_verdict, schedule_observability_verdict
    from glocal_verify.analysis.unobservable.privacy import connected_verdict, consensus_unobservable_verdict, consensus_value_verdict, initial_state_verdict, kernel_verdict, schedule_consensus_unobservable_verdict, schedule_consensus_value_verdict, schedule_initial_state_verdict

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "ModalDecomposition": "glocal_verify.analysis.unobservable.modal",
    "modal_decomposition": "glocal_verify.analysis.unobservable.modal",
    "CertifiedUnobservable": "glocal_verify.analysis.unobservable.subspace",
    "certified_unobservable": "glocal_verify.analysis.unobservable.subspace",
    "unobservable_subspace": "glocal_verify.analysis.unobservable.subspace",
    "unobservable_subspace_exact": "glocal_verify.analysis.unobservable.subspace",
    "CertifiedSwitched": "glocal_verify.analysis.unobservable.switched",
    "certified_switched": "glocal_verify.analysis.unobservable.switched",
    "switched_unobservable_subspace": "glocal_verify.analysis.unobservable.switched",
    "observability_verdict": "glocal_verify.analysis.unobservable.observability",
    "schedule_observability_verdict": "glocal_verify.analysis.unobservable.observability",
    "connected_verdict": "glocal_verify.analysis.unobservable.privacy",
    "consensus_unobservable_verdict": "glocal_verify.analysis.unobservable.privacy",
    "consensus_value_verdict": "glocal_verify.analysis.unobservable.privacy",
    "initial_state_verdict": "glocal_verify.analysis.unobservable.privacy",
    "kernel_verdict": "glocal_verify.analysis.unobservable.privacy",
    "schedule_consensus_unobservable_verdict": "glocal_verify.analysis.unobservable.privacy",
    "schedule_consensus_value_verdict": "glocal_verify.analysis.unobservable.privacy",
    "schedule_initial_state_verdict": "glocal_verify.analysis.unobservable.privacy",
})

#: ``glocal_verify.analysis.unobservable.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.analysis.unobservable", _LAZY, globals())

__all__ = [
    "ModalDecomposition",
    "modal_decomposition",
    "CertifiedUnobservable",
    "certified_unobservable",
    "unobservable_subspace",
    "unobservable_subspace_exact",
    "CertifiedSwitched",
    "certified_switched",
    "switched_unobservable_subspace",
    "observability_verdict",
    "schedule_observability_verdict",
    "connected_verdict",
    "consensus_unobservable_verdict",
    "consensus_value_verdict",
    "initial_state_verdict",
    "kernel_verdict",
    "schedule_consensus_unobservable_verdict",
    "schedule_consensus_value_verdict",
    "schedule_initial_state_verdict",
]
