"""The observers as simulated systems: the central Luenberger observer and every local UIO."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Mapping, Sequence

import numpy as np

from glocal_verify.errors import ModelError, NotApplicableError
from glocal_verify.model import System
from glocal_verify.simulation.schedule import ANY_MODE
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "cluster_embedding",
    "ObserverModel",
    "ObserverBank",
    "central_observer_model",
    "local_observer_models",
]

# --------------------------------------------------------------------------------------------
# observers


@dataclass(frozen=True, slots=True)
class ObserverModel:
    """An observer as plain matrices: :math:`\\dot z = F_q z + G_q y`, :math:`r = R_y y - R_z z`.

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


def local_observer_models(system: System, *, modes: Sequence[str] | None = None) -> tuple[list[ObserverModel], list[str]]:
    """One UIO model per local observer of the spec (``uio.local_uio``).

    The design for the normal mode is used before the switch; for every other mode whose
    cluster matrix :math:`A^i_q` differs, the observer is redesigned for :math:`A^i_q` (kept
    continuous: z and h do not change, since E^i and C_loc do not). If no UIO exists in a safe
    mode, the normal-mode design keeps running there (noted).

    Parameters
    ----------
    system : System
    modes : sequence of str, optional
        Modes to design for (default all modes of the system).

    Returns
    -------
    (models, notes)
    """
    from glocal_verify.observers.uio import local_uio

    out: list[ObserverModel] = []
    notes: list[str] = []
    for lo in system.observers():
        try:
            base = local_uio(system, lo, mode=NORMAL_MODE)
        except NotApplicableError as exc:
            notes.append(f"local observer {lo.cluster}@{lo.center}: {exc}")
            continue
        S = cluster_embedding(system, base.nodes)
        Cg = base.C @ S
        Fs: dict[str, np.ndarray] = {ANY_MODE: base.F}
        Gs: dict[str, np.ndarray] = {ANY_MODE: base.K}
        mnotes: list[str] = []
        for mode in modes if modes is not None else system.modes:
            if mode == NORMAL_MODE:
                continue
            cm = system.cluster_model(lo.cluster, mode)
            if np.array_equal(cm.A, base.A):
                continue
            try:
                d = local_uio(system, lo, mode=mode)
            except NotApplicableError as exc:
                mnotes.append(f"mode {mode}: no UIO for A^i_q ({exc}); the normal-mode design keeps running")
                continue
            if not np.allclose(d.h, base.h, rtol=0, atol=1e-12 * max(1.0, float(np.abs(base.h).max(initial=0.0)))):
                mnotes.append(f"mode {mode}: h differs from the normal-mode design")
            Fs[mode], Gs[mode] = d.F, d.K
        p = base.C.shape[0]
        inputs = tuple(f"x:{a}" for a in base.positions) + tuple(f"v:{a}" for a in base.velocities)
        out.append(
            ObserverModel(
                f"{lo.cluster}@{lo.center}",
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
            )
        )
    return out, notes
