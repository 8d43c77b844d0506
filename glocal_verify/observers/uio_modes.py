"""The local unknown-input observers of every mode: one design per mode whose cluster matrices change.

A safe mode changes links. For a local observer of cluster :math:`\\mathcal P_i` it changes

* the cluster matrix :math:`A^i_q` when a changed link has an end in the cluster (the degree of
  that agent changes), and
* the unknown-input matrix :math:`E^i_q` when a changed link joins the cluster to another one
  at an agent that had no outside neighbour (a new boundary agent: a new column), or removes the
  last such link of an agent.

The paper keeps one decoupling matrix :math:`h^i` for every mode (eq. ``E_definition`` is
stated for :math:`\\sigma = 1` only, and eq. ``uio_conds_1`` has no :math:`\\sigma`). With a new
column of :math:`E^i_q`, :math:`(h^i C - I) E^i_q \\ne 0`: the observer of the normal mode is not
decoupled from the neighbours in that mode (its residual moves with agents outside the
cluster). So every mode with other cluster matrices gets its own design
(:func:`~glocal_verify.observers.uio.local_uio` with ``mode=q``): :math:`h_q = E^i_q (C E^i_q)^+`,
:math:`T_q`, :math:`F_q`, :math:`K_q`. The estimate :math:`\\hat x = z + h_q y` is kept continuous
at a switch by resetting :math:`z \\leftarrow z + (h_p - h_q) y`; then
:math:`e = x - \\hat x` is continuous and obeys :math:`\\dot e = F_q e + T_q B u_a` in each mode.

:func:`local_uio_modes` designs them once; the simulator's observer models, the deployment and
its file are built from its result.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from glocal_verify.errors import NotApplicableError
from glocal_verify.model import LocalObserver, System
from glocal_verify.observers.uio import UnknownInputObserver, local_uio
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["ModeDesigns", "local_uio_modes"]


@dataclass(frozen=True, slots=True)
class ModeDesigns:
    """One local observer's designs: the normal mode's and those of the modes that change its cluster.

    Attributes
    ----------
    observer : LocalObserver
    normal : UnknownInputObserver
        The normal-mode design; it also runs in every mode not listed in :attr:`modes`.
    modes : tuple of (str, UnknownInputObserver)
        The modes whose :math:`A^i_q` or :math:`E^i_q` differ from the normal mode's and have a UIO.
    missing : tuple of (str, str)
        Modes whose cluster matrices differ but have no UIO, and why: the normal-mode design
        keeps running there and is **not** decoupled.
    """

    observer: LocalObserver
    normal: UnknownInputObserver
    modes: tuple[tuple[str, UnknownInputObserver], ...]
    missing: tuple[tuple[str, str], ...]

    @property
    def name(self) -> str:
        """``<cluster>@<centre>``."""
        return f"{self.observer.cluster}@{self.observer.center}"

    def design(self, mode: str) -> UnknownInputObserver:
        """The design that runs in ``mode``."""
        return next((d for m, d in self.modes if m == mode), self.normal)

    def decoupled(self, mode: str) -> bool:
        """Whether the observer that runs in ``mode`` is decoupled there (a design for its matrices)."""
        return all(m != mode for m, _ in self.missing)


def local_uio_modes(system: System, observer: LocalObserver, *, modes: Sequence[str] | None = None) -> ModeDesigns:
    """The designs of ``observer`` in the normal mode and every mode of ``modes`` that changes its cluster.

    Parameters
    ----------
    system : System
    observer : LocalObserver
    modes : sequence of str, optional
        Default every mode of the system.

    Raises
    ------
    NotApplicableError
        When the normal mode has no UIO for this observer.
    """
    base = local_uio(system, observer, mode=NORMAL_MODE)
    got: list[tuple[str, UnknownInputObserver]] = []
    missing: list[tuple[str, str]] = []
    for mode in modes if modes is not None else system.modes:
        if mode == NORMAL_MODE:
            continue
        cm = system.cluster_model(observer.cluster, mode)
        if np.array_equal(cm.A, base.A) and np.array_equal(cm.E, base.E):
            continue
        try:
            got.append((mode, local_uio(system, observer, mode=mode)))
        except NotApplicableError as exc:
            missing.append((mode, str(exc)))
    return ModeDesigns(observer, base, tuple(got), tuple(missing))
