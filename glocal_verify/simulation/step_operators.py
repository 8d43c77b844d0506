"""The exact step of an observer driven by a polynomial input, and a cache of them shared by runs.

:func:`observer_step_operator` is the observer propagator of the modal simulator
(:mod:`glocal_verify.simulation.engine`) and of the attack-free envelope
(:mod:`glocal_verify.simulation.envelope`): one ``expm`` of the observer and the chain of the
input's Taylor coefficients. At N = 1000 the centralized observer has 2000 states and this
exponential takes seconds, so the runs of one Algorithm 1 pass (the attack-free envelope, the
attacked run and the attack-only run) share them through a :class:`StepOperators` object
passed explicitly (there is no module-level cache).

**Sharing across Taylor orders is exact.** The block matrix of order J,
:math:`A_J = [[F, G, 0, \\dots], [0, 0, I, \\dots], \\dots]`, is block upper triangular with
respect to the split (observer and the first J' + 1 coefficients | the rest), and its leading
block is :math:`A_{J'}`; so the leading block of :math:`e^{A_J \\delta}` is
:math:`e^{A_{J'} \\delta}`: the operator of order J' < J is the first
:math:`p (J' + 1)` columns of :math:`\\Gamma` of order J, to the rounding of ``expm``
(backward error of order the unit roundoff times :math:`\\|A_J \\delta\\|`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["observer_step_operator", "StepOperators"]


def observer_step_operator(F: np.ndarray, G: np.ndarray, J: int, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact step of an observer ``z' = F z + G y`` over ``delta`` when ``y`` is a polynomial of degree J.

    With the input given by its Taylor coefficients, the observer and the chain of derivatives
    form one LTI system; ``expm`` of that block matrix gives ``(Phi, Gamma)`` with
    ``z(t + delta) = Phi z(t) + Gamma [y; y'; ...; y^(J)]``.

    Parameters
    ----------
    F, G : ndarray
        Observer matrices (``no x no`` and ``no x p``).
    J : int
        Taylor order of the input.
    delta : float
        The step.

    Returns
    -------
    (Phi, Gamma)
        ``no x no`` and ``no x p (J + 1)``.
    """
    no, p = F.shape[0], G.shape[1]
    dim = no + p * (J + 1)
    A = np.zeros((dim, dim))
    A[:no, :no] = F
    A[:no, no : no + p] = G
    for j in range(J):
        r0 = no + j * p
        A[r0 : r0 + p, r0 + p : r0 + 2 * p] = np.eye(p)
    E = scipy.linalg.expm(A * delta)
    return E[:no, :no].copy(), E[:no, no:].copy()


class StepOperators:
    """Observer step operators computed once per (dynamics, step) and shared by several runs.

    The key is the pair of arrays (F, G) by identity, else by equal contents (an observer whose
    dynamics matrix is the same in two modes, or two banks built from one design), and the step
    rounded to 13 digits. Asked for order J, an entry of order J' >= J returns its leading
    columns (module docstring: exact to the rounding of ``expm``); an entry of lower order is
    replaced by one of order J.

    Attributes
    ----------
    computed : int
        Exponentials evaluated so far (the tests check the sharing).
    """

    def __init__(self) -> None:
        self._entries: list[tuple[np.ndarray, np.ndarray, float, int, np.ndarray, np.ndarray]] = []
        self.computed = 0

    def _find(self, F: np.ndarray, G: np.ndarray, key: float) -> int | None:
        for i, (Fe, Ge, d, _, _, _) in enumerate(self._entries):
            if d == key and Fe is F and Ge is G:
                return i
        for i, (Fe, Ge, d, _, _, _) in enumerate(self._entries):
            if d == key and Fe.shape == F.shape and Ge.shape == G.shape and np.array_equal(Fe, F) and np.array_equal(Ge, G):
                return i
        return None

    def get(self, F: np.ndarray, G: np.ndarray, J: int, delta: float) -> tuple[np.ndarray, np.ndarray]:
        """``observer_step_operator(F, G, J, delta)``, from the cache when possible.

        Parameters
        ----------
        F, G : ndarray
            Observer matrices.
        J : int
            Taylor order of the input (at least this many coefficients are integrated exactly).
        delta : float
            The step.

        Returns
        -------
        (Phi, Gamma)
            As :func:`observer_step_operator`; Gamma has exactly ``p (J + 1)`` columns.
        """
        key = round(float(delta), 13)
        p = G.shape[1]
        i = self._find(F, G, key)
        if i is not None and self._entries[i][3] >= J:
            _, _, _, _, Phi, W = self._entries[i]
            return Phi, W[:, : p * (J + 1)]
        Phi, W = observer_step_operator(F, G, J, delta)
        self.computed += 1
        entry = (F, G, key, J, Phi, W)
        if i is None:
            self._entries.append(entry)
        else:
            self._entries[i] = entry
        return Phi, W
