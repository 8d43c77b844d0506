"""Proposition III.2 (i) and (ii): the rules of ``local.k-connected`` and ``local.rank``.

Both are decided on one :class:`~glocal_verify.analysis.local.cases.LocalCase` (a cluster,
an observer, a suspected set): (i) counts the neighbours of the observer's centre against the
cut edges and the suspected agents (combinatorial); (ii) compares the ranks of ``E^i`` and
``C_loc E^i``, exact 0/1 matrices, with certified singular values or over Q.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from glocal_verify.analysis.local.cases import LocalCase, certificate_verdict, exact_int
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.pencil_exact import rank_bounds
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import Status, Verdict

__all__ = ["k_connected_verdict", "rank_verdict"]


def k_connected_verdict(system: System, case: LocalCase) -> Verdict:
    """Proposition III.2 (i) for one case: ``deg(c) >= |E_cut(P_i)| + |suspected|`` (combinatorial).

    ``deg(c)`` counts the neighbours of the observer's centre in the normal-mode graph.

    Parameters
    ----------
    system : System
    case : LocalCase

    Returns
    -------
    Verdict
        Margin ``deg(c) - (|E_cut| + |suspected|)``; witness ``degree``, ``neighbours``,
        ``inter_cluster_edges``, ``rank_E``, ``suspected``, ``required``,
        ``required_with_rank_E``, ``holds_with_rank_E`` and ``measured``.
    """
    cm, obs = case.model, case.observer
    nb = system.neighbours(obs.center)
    deg = len(nb)
    cut = len(cm.cut_edges)
    rE = len(cm.boundary)
    need = cut + len(case.suspected)
    need_r = rE + len(case.suspected)
    measured = sorted(set(obs.positions) | set(obs.velocities), key=cm.nodes.index)
    witness = {
        "degree": deg,
        "neighbours": nb,
        "inter_cluster_edges": cut,
        "rank_E": rE,
        "suspected": list(case.suspected),
        "required": need,
        "required_with_rank_E": need_r,
        "holds_with_rank_E": deg >= need_r,
        "measured": measured,
    }
    return Verdict(Status.HOLDS if deg >= need else Status.FAILS, margin=deg - need, witness=witness, combinatorial=True)


def rank_verdict(case: LocalCase, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> Verdict:
    """Proposition III.2 (ii) for one case: ``rank(C_loc E^i) = rank(E^i)``.

    Numeric: certified ranks (:func:`~glocal_verify.numerics.pencil_exact.rank_bounds`: the
    Weyl lower bound of the SVD against the structural rank of the exact support; E^i and
    C_loc E^i are exact 0/1 matrices); undecided unless both bounds meet for both matrices.
    Exact: ranks over Q.

    Parameters
    ----------
    case : LocalCase
    tol : Tolerance
    exact : bool
        Ranks over Q instead of singular values.

    Returns
    -------
    Verdict
        Margin the rank(E^i)-th singular value of C_loc E^i (1 without boundary agent);
        witness ``rank_E``, ``rank_CE``, ``boundary``, the numeric ``certificate`` and, on
        failure, ``unmeasured_boundary``.
    """
    cm = case.model
    C = case.C
    unmeasured = [a for a in cm.boundary if a not in case.observer.velocities]
    CE = C @ cm.E
    if exact:
        rE = ex.rank(exact_int(cm.E), cm.E.shape[1]) if cm.E.shape[1] else 0
        rCE = ex.rank(exact_int(CE), CE.shape[1]) if CE.size else 0
        status = Status.HOLDS if rCE == rE else Status.FAILS
    else:
        # certified ranks: Weyl lower bound (SVD backward error; E and C_loc E are exact 0/1
        # matrices, no data rounding) against the structural rank of the exact support
        exact_data = bool(np.all(cm.E == np.round(cm.E)) and np.all(CE == np.round(CE)))
        bE, bCE = rank_bounds(cm.E), rank_bounds(CE)
        rE, rCE = bE.lower, bCE.lower
        bound = max(bE.error_bound, bCE.error_bound)
        cert: dict[str, Any] = {"error_bound": bound, "by": "Weyl bound of the SVD (backward error 8 max(m, n) eps ||M||_F) and the structural rank"}
        if not (exact_data and bE.decided and bCE.decided):
            status = Status.UNDECIDED
            cert["note"] = (
                f"rank(E^i) in [{bE.lower}, {bE.upper}], rank(C_loc E^i) in [{bCE.lower}, {bCE.upper}]: the certified bounds "
                f"(error bound {bound:.3g}) do not meet" + ("" if exact_data else "; C_loc E^i is not an exact 0/1 matrix")
            )
        else:
            status = Status.HOLDS if rCE == rE else Status.FAILS
    sv = np.linalg.svd(CE, compute_uv=False) if CE.size else np.zeros(0)
    margin = 1.0 if rE == 0 else (float(sv[rE - 1]) if len(sv) >= rE else 0.0)
    witness: dict[str, Any] = {"rank_E": rE, "rank_CE": rCE, "boundary": list(cm.boundary)}
    if not exact:
        witness["certificate"] = cert
    if unmeasured:
        witness["unmeasured_boundary"] = unmeasured
    return certificate_verdict(status, margin, witness, exact=exact)
