"""The observers as simulated systems: the central Luenberger observer and every local UIO."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Iterator, Mapping, Sequence

import numpy as np

from glocal_verify.errors import ModelError, NotApplicableError
from glocal_verify.model import System
from glocal_verify.simulation.schedule import ANY_MODE
from glocal_verify.spec.types import NORMAL_MODE, Label

if TYPE_CHECKING:
    from glocal_verify.observers.uio_modes import ModeDesigns

__all__ = [
    "NOT_DECOUPLED",
    "cluster_embedding",
    "local_designs",
    "local_observer_model",
    "ObserverModel",
    "ObserverBank",
    "central_observer_model",
    "local_observer_models",
]

#: the note of a mode in which a local observer keeps its normal-mode design (no UIO for the mode)
NOT_DECOUPLED = "no UIO for A^i_q, E^i_q: the normal-mode design keeps running and is not decoupled in this mode"

# --------------------------------------------------------------------------------------------
# observers


@dataclass(frozen=True, slots=True)
class ObserverModel:
    """An observer as plain matrices: :math:`\\dot z = F_q z + G_q y`, :math:`r = R_{y,q} y - R_z z`.

    A local UIO estimates :math:`\\hat x = z + h_q y`; its decoupling matrix :math:`h_q` changes
    in a mode that adds an inter-cluster link at an agent without outside neighbour (a new
    column of :math:`E^i_q`). Its state is then reset at the switch,
    :math:`z \\leftarrow z + (h_p - h_q) y`, so that the estimate :math:`\\hat x`, the error
    :math:`e = x - \\hat x` and the residual stay continuous (:meth:`reset`), and
    :math:`R_{y,q} = I - R_z h_q` (:meth:`output_map`).

    Attributes
    ----------
    name : str
        ``"central"`` or ``"<cluster>@<centre>"``.
    kind : str
        ``"central"`` (its measurement is the global output, which a covert attacker spoofs)
        or ``"local"``.
    C : ndarray
        Measurement map on the global plant state [x; v]: y = C x_plant (p x 2N).
    F, G : mapping of str to ndarray
        Per-mode dynamics; key :data:`ANY_MODE` (``"*"``) is used for modes without their own.
    Ry, Rz : ndarray
        Residual maps (q x p and q x n_o).
    Z0 : ndarray
        Initial state map z(0) = Z0 x_plant(0) (n_o x 2N).
    inputs : tuple of str
        Names of the measured channels (rows of C), e.g. ``"v:7"``.
    channels : tuple of str
        Names of the residual components (rows of Ry).
    cluster : str or None
    center : label or None
    notes : tuple of str
    Hy : mapping of str to ndarray
        Per key of :attr:`F`: the decoupling matrix :math:`h_q` of the estimate
        :math:`\\hat x = z + h_q y` (empty: ``Ry`` in every mode, no reset).
    """

    name: str
    kind: str
    C: np.ndarray
    F: Mapping[str, np.ndarray]
    G: Mapping[str, np.ndarray]
    Ry: np.ndarray
    Rz: np.ndarray
    Z0: np.ndarray
    inputs: tuple[str, ...]
    channels: tuple[str, ...]
    cluster: str | None = None
    center: Label | None = None
    notes: tuple[str, ...] = ()
    Hy: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def order(self) -> int:
        """Observer state dimension n_o."""
        return int(next(iter(self.F.values())).shape[0])

    def dynamics_key(self, mode: str) -> str:
        """Key of :attr:`F`/:attr:`G` used in ``mode``."""
        if mode in self.F:
            return mode
        if ANY_MODE in self.F:
            return ANY_MODE
        raise ModelError(f"observer {self.name!r} has no dynamics for mode {mode!r}")

    def dynamics(self, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """(F, G) in ``mode``."""
        k = self.dynamics_key(mode)
        return self.F[k], self.G[k]

    def output_map(self, mode: str) -> np.ndarray:
        """``R_y`` in ``mode``: :math:`I - R_z h_q` with the mode's decoupling matrix (``Ry`` without one)."""
        k = self.dynamics_key(mode)
        if k == ANY_MODE or k not in self.Hy:
            return self.Ry
        return np.eye(self.Ry.shape[0]) - self.Rz @ self.Hy[k]

    def reset(self, before: str, after: str) -> np.ndarray | None:
        """The reset :math:`z \\leftarrow z + (h_p - h_q) y` at a switch from ``before`` to ``after``
        (None when the decoupling matrix does not change): it keeps :math:`\\hat x = z + h y`
        continuous, so the error and the residual do not jump."""
        if not self.Hy:
            return None
        a, b = self.dynamics_key(before), self.dynamics_key(after)
        if a == b:
            return None
        D = self.Hy[a] - self.Hy[b]
        return D if np.any(D) else None


@dataclass(frozen=True, slots=True)
class ObserverBank:
    """The observers that run in a simulation (Algorithm 1, line 2).

    Attributes
    ----------
    observers : tuple of ObserverModel
    notes : tuple of str
        Observers that could not be built and why.
    """

    observers: tuple[ObserverModel, ...]
    notes: tuple[str, ...] = ()

    def __repr__(self) -> str:
        names = ", ".join(self.names[:6]) + (f", ... ({len(self.observers)} in all)" if len(self.observers) > 6 else "")
        return f"ObserverBank([{names}]" + (f", {len(self.notes)} notes" if self.notes else "") + ")"

    @property
    def names(self) -> tuple[str, ...]:
        """Observer names, in order."""
        return tuple(o.name for o in self.observers)

    def __getitem__(self, name: str) -> ObserverModel:
        for o in self.observers:
            if o.name == name:
                return o
        raise KeyError(name)

    def __iter__(self) -> Iterator[ObserverModel]:
        return iter(self.observers)

    def __len__(self) -> int:
        return len(self.observers)

    def select(self, kind: str) -> "ObserverBank":
        """The sub-bank of observers of ``kind`` (``"central"`` or ``"local"``)."""
        return ObserverBank(tuple(o for o in self.observers if o.kind == kind), self.notes)

    @classmethod
    def for_system(
        cls,
        system: System,
        *,
        central: bool = True,
        local: bool = True,
        modes: Sequence[str] | None = None,
    ) -> "ObserverBank":
        """Design the centralized observer (``central.design_central_observer``) and one UIO
        per local observer of the spec (``uio.local_uio``), for every mode in ``modes``.

        Parameters
        ----------
        system : System
        central, local : bool
            Which observers to include.
        modes : sequence of str, optional
            Modes for which the local observers get a mode-matched design (default all).
        """
        obs: list[ObserverModel] = []
        notes: list[str] = []
        if central:
            try:
                obs.append(central_observer_model(system))
            except (ImportError, NotApplicableError) as exc:
                notes.append(f"central observer: {exc}")
        if local:
            models, more = local_observer_models(system, modes=modes)
            obs.extend(models)
            notes.extend(more)
        return cls(tuple(obs), tuple(notes))


def central_observer_model(system: System, H: np.ndarray | None = None) -> ObserverModel:
    """The centralized observer of eq. ``obs_cent`` on the normal-mode model.

    :math:`\\dot{\\hat x} = A_1 \\hat x + H (y - C \\hat x)`, :math:`\\hat x(0) = 0`,
    :math:`r_0 = y - C \\hat x`; the same in every mode (the model stays :math:`A_1`).

    Parameters
    ----------
    system : System
    H : ndarray, optional
        Observer gain (2N x p); default ``central.design_central_observer(system).H``.
    """
    if H is None:
        from glocal_verify.observers.central import design_central_observer  # type: ignore[attr-defined]

        H = np.asarray(design_central_observer(system).H, dtype=float)
    C = system.C()
    F = system.A(NORMAL_MODE) - H @ C
    p = C.shape[0]
    ch = system.output_channels()
    return ObserverModel(
        "central",
        "central",
        C,
        {ANY_MODE: F},
        {ANY_MODE: np.array(H, dtype=float)},
        np.eye(p),
        C.copy(),
        np.zeros((2 * system.n, 2 * system.n)),
        ch,
        ch,
    )


def cluster_embedding(system: System, nodes: Sequence[Label]) -> np.ndarray:
    """S with x_cluster = S x_plant ([positions of nodes; velocities of nodes])."""
    idx = system.idx(nodes)
    n, k = system.n, len(idx)
    S = np.zeros((2 * k, 2 * n))
    for r, i in enumerate(idx):
        S[r, i] = 1.0
        S[k + r, n + i] = 1.0
    return S


def local_observer_model(system: System, designs: "ModeDesigns") -> ObserverModel:
    """The simulated model of one local observer from its designs in every mode
    (:func:`~glocal_verify.observers.uio_modes.local_uio_modes`).

    The normal-mode design runs in every mode without its own (key :data:`ANY_MODE`); a mode
    whose decoupling matrix differs carries it in :attr:`ObserverModel.Hy` (reset at the
    switch, :meth:`ObserverModel.reset`).
    """
    base = designs.normal
    S = cluster_embedding(system, base.nodes)
    Cg = base.C @ S
    Fs: dict[str, np.ndarray] = {ANY_MODE: base.F}
    Gs: dict[str, np.ndarray] = {ANY_MODE: base.K}
    Hs: dict[str, np.ndarray] = {ANY_MODE: base.h}
    for mode, d in designs.modes:
        Fs[mode], Gs[mode], Hs[mode] = d.F, d.K, d.h
    mnotes = [f"mode {mode}: {NOT_DECOUPLED} ({why})" for mode, why in designs.missing]
    p = base.C.shape[0]
    inputs = tuple(f"x:{a}" for a in base.positions) + tuple(f"v:{a}" for a in base.velocities)
    lo = designs.observer
    return ObserverModel(
        designs.name,
        "local",
        Cg,
        Fs,
        Gs,
        np.eye(p) - base.C @ base.h,
        base.C.copy(),
        -base.h @ Cg,
        inputs,
        inputs,
        lo.cluster,
        lo.center,
        tuple(list(base.notes) + mnotes),
        Hs if any(not np.array_equal(H, base.h) for H in Hs.values()) else {},
    )


def local_observer_models(system: System, *, modes: Sequence[str] | None = None) -> tuple[list[ObserverModel], list[str]]:
    """One UIO model per local observer of the spec (:func:`local_observer_model`).

    The design for the normal mode is used before the switch; for every other mode whose
    cluster matrices :math:`A^i_q`, :math:`E^i_q` differ, the observer is redesigned for them
    (:func:`~glocal_verify.observers.uio_modes.local_uio_modes`). A mode that adds an
    inter-cluster link at an agent without outside neighbour adds a column to :math:`E^i_q`, so
    its decoupling matrix :math:`h_q` differs from the normal mode's: the model carries
    :math:`h_q` (:attr:`ObserverModel.Hy`) and its state is reset at the switch,
    :math:`z \\leftarrow z + (h_p - h_q) y`. If no UIO exists in a safe mode, the normal-mode
    design keeps running there (noted: that observer is not decoupled in that mode).

    Parameters
    ----------
    system : System
    modes : sequence of str, optional
        Modes to design for (default all modes of the system).

    Returns
    -------
    (models, notes)
    """
    out: list[ObserverModel] = []
    notes: list[str] = []
    for designs in local_designs(system, modes=modes, notes=notes):
        out.append(local_observer_model(system, designs))
    return out, notes


def local_designs(system: System, *, modes: Sequence[str] | None = None, notes: list[str] | None = None) -> list["ModeDesigns"]:
    """:func:`~glocal_verify.observers.uio_modes.local_uio_modes` of every local observer of the
    spec that has a normal-mode UIO; the others are appended to ``notes``."""
    from glocal_verify.observers.uio_modes import local_uio_modes

    out = []
    for lo in system.observers():
        try:
            out.append(local_uio_modes(system, lo, modes=modes))
        except NotApplicableError as exc:
            if notes is not None:
                notes.append(f"local observer {lo.cluster}@{lo.center}: {exc}")
    return out
