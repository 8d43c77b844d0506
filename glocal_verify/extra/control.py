"""python-control: a state-space model of given matrices (an optional dependency).

``pip install 'glocal-verify[control]'`` installs it; without it :func:`state_space` raises
:class:`~glocal_verify.errors.NotApplicableError` with that line.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from glocal_verify.errors import NotApplicableError

__all__ = ["state_space"]


def state_space(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, *, states: Sequence[str], inputs: Sequence[str], outputs: Sequence[str], name: str, what: str = "to_statespace") -> Any:
    """``control.ss(A, B, C, D)`` with named states, inputs and outputs.

    Parameters
    ----------
    A, B, C, D : ndarray
        The model's matrices.
    states, inputs, outputs : sequence of str
        Signal names, one per state, input and output.
    name : str
        The system's name.
    what : str
        The caller, for the message when python-control is missing.

    Returns a ``control.StateSpace``; raises :class:`NotApplicableError` without python-control.
    """
    try:
        import control
    except ImportError:
        raise NotApplicableError(f"{what} needs python-control, which is not installed: pip install 'glocal-verify[control]'") from None
    return control.ss(A, B, C, D, states=list(states), inputs=list(inputs), outputs=list(outputs), name=name)
