"""Theorem III.3 (i) and Lemma A.2: the rules of ``switching.image-kernel`` and ``switching.coverage``.

For a safe mode q with dL_q = L_q - L_1, the switching components D_c are the connected
components (>= 2 nodes) of the graph whose edges are the nonzero off-diagonal entries of dL_q
(Definition A.1). dL_q is block diagonal over the D_c and zero elsewhere, so every subspace
question below splits into one small question per component.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.subspace import svd_rank_bound
from glocal_verify.results import Status, Verdict
from glocal_verify.spec.types import Label

__all__ = ["coverage_verdict", "image_kernel_component", "image_kernel_verdict"]


def _component_block(system: System, mode: str, comp: tuple[Label, ...]) -> tuple[list[int], np.ndarray]:
    idx = system.idx(comp)
    dL = system.delta_laplacian_sparse(mode)
    return idx, dL[idx, :][:, idx].toarray()


def image_kernel_component(system: System, mode: str, comp: tuple[Label, ...], exact: bool = False) -> dict[str, Any]:
    """Theorem III.3 (i) restricted to one switching component D_c: rank(S_M dL_c) = rank(dL_c).

    Structure first (exact, from the spec's rational link differences): dL_c is the
    Laplacian of the connected graph of switching links of D_c with signed weights, so
    ``rank(dL_c) <= |D_c| - 1`` and ``rank(S_M dL_c) <= min(|M ∩ D_c|, |D_c| - 1)``. When all
    link differences of D_c have one sign, dL_c is +- the Laplacian of a connected graph with
    positive weights: ``rank(dL_c) = |D_c| - 1`` and any ``|D_c| - 1`` of its rows are
    independent, so the condition holds on D_c iff ``|M ∩ D_c| >= |D_c| - 1`` (combinatorial,
    no rounding). With mixed signs the numeric decision uses certified singular values
    (:func:`svd_rank_bound`): holds if ``S_M dL_c`` has ``|D_c| - 1`` singular values above
    its bound beta; fails if dL_c has more singular values above beta than
    ``min(|M ∩ D_c|, |D_c| - 1)``; undecided otherwise (escalation decides exactly).
    Exact: rank(dL_c[M, :]) = rank(dL_c) over Q.

    Returns a dict with ``status``, ``sigma_min`` (the robustness margin: the smallest
    fraction of a unit vector of Im(dL_c) seen by the monitors, ``sigma_min(S_M Q_c)``),
    ``rank``, ``monitored``, ``error_bound``/``note`` when undecided and, on failure,
    ``vector`` (a y in Im(dL_q) with S_M y = 0).

    Parameters
    ----------
    system : System
    mode : str
        A safe mode.
    comp : tuple of labels
        A switching component D_c of ``mode``.
    exact : bool
        Ranks over Q.
    """
    monitored = set(system.monitored)
    mon = [a for a in comp if a in monitored]
    nc = len(comp)
    inside = set(comp)
    signs = {d > 0 for a, b, d in system.switching_links(mode) if a in inside and b in inside}
    same_sign = len(signs) == 1
    idx, block = _component_block(system, mode, comp)
    rows = [comp.index(a) for a in mon]
    # robustness margin: Q_c orthonormal basis of Im(dL_c) (1-perp when one sign)
    sv_b, beta_b = svd_rank_bound(block)
    Ub, _, _ = np.linalg.svd(block)
    r_img = nc - 1 if same_sign else max(1, int(np.sum(sv_b > beta_b)))
    Q = Ub[:, :r_img]
    SQ = Q[rows, :]
    s_full = np.zeros(Q.shape[1])
    Vh = np.eye(Q.shape[1])
    if SQ.shape[0]:
        _, s, Vh = np.linalg.svd(SQ, full_matrices=True)
        s_full[: len(s)] = s
    k = int(np.argmin(s_full)) if len(s_full) else 0
    sigma = float(s_full[k]) if len(s_full) else 1.0
    info: dict[str, Any] = {"nodes": list(comp), "rank": r_img, "monitored": mon, "sigma_min": sigma}
    if exact:
        Lc = system.delta_laplacian_exact(mode)
        block_q = [[Lc[i][j] for j in idx] for i in idx]
        r = ex.rank(block_q)
        rows_q = [block_q[i] for i in rows]
        r2 = ex.rank(rows_q, ncols=len(comp)) if rows_q else 0
        info["rank"] = r
        if r2 == r:
            info["status"] = Status.HOLDS
        else:
            info["status"] = Status.FAILS
            # z in ker(S_M dL_c) with dL_c z != 0 gives y = dL_c z in the intersection
            kern = ex.nullspace(rows_q, ncols=len(comp)) if rows_q else [
                [Fraction(int(i == j)) for i in range(len(comp))] for j in range(len(comp))
            ]
            for z in kern:
                y = ex.matvec(block_q, z)
                if any(v != 0 for v in y):
                    info["vector"] = dict(zip(comp, y))
                    break
        return info
    ub_s = min(len(mon), nc - 1)
    if same_sign:
        info["status"] = Status.HOLDS if len(mon) >= nc - 1 else Status.FAILS
        info["decided_by"] = "structure: one-signed link changes, rank(dL_c) = |D_c| - 1 and any |D_c| - 1 rows independent"
        info["error_bound"] = 0.0
    else:
        sv_s, beta_s = svd_rank_bound(block[rows, :]) if rows else (np.zeros(0), 0.0)
        r_s_lo = int(np.sum(sv_s > beta_s))
        r_d_lo = max(1, int(np.sum(sv_b > beta_b)))
        if r_s_lo >= nc - 1:
            info["status"] = Status.HOLDS
            info["error_bound"] = beta_s
        elif r_d_lo > ub_s:
            info["status"] = Status.FAILS
            info["error_bound"] = beta_b
        else:
            info["status"] = Status.UNDECIDED
            smallest = float(sv_s[nc - 2]) if len(sv_s) >= nc - 1 and nc >= 2 else 0.0
            info["error_bound"] = max(beta_s, beta_b)
            info["note"] = (
                f"component {list(comp)}: rank(S_M dL_c) >= {r_s_lo} and rank(dL_c) >= {r_d_lo} are certified; "
                f"singular value {smallest:.3g} of S_M dL_c is below its rounding bound {beta_s:.3g} "
                f"(and the bound {beta_b:.3g} of dL_c proves no more), so the ranks cannot be compared"
            )
    if info["status"] is Status.FAILS and SQ.shape[0] < Q.shape[1]:
        vec = Q @ Vh[-1] if SQ.shape[0] else Q[:, 0]
    elif info["status"] is Status.FAILS:
        vec = Q @ Vh[k]
    else:
        vec = None
    if vec is not None:
        vec = vec / np.max(np.abs(vec))
        info["vector"] = {a: float(x) for a, x in zip(comp, vec)}
    return info


def _combine(statuses: list[Status]) -> Status:
    if any(s is Status.FAILS for s in statuses):
        return Status.FAILS
    if any(s is Status.UNDECIDED for s in statuses):
        return Status.UNDECIDED
    return Status.HOLDS


def image_kernel_verdict(system: System, mode: str, exact: bool = False) -> Verdict:
    """Theorem III.3 (i) for one safe mode: ``Im(dL_q) ∩ ker([S_{M_x}; S_{M_v}]) = {0}``.

    Decided per switching component by :func:`image_kernel_component` and combined: fails
    if some component fails, undecided if some is undecided, holds otherwise (also when the
    mode changes no link: ``Im(dL_q) = {0}``).

    Parameters
    ----------
    system : System
    mode : str
        A safe mode.
    exact : bool
        Ranks over Q.

    Returns
    -------
    Verdict
        Margin: min over components of ``sigma_min(S_M Q_c)`` (0 on an exact failure).
        Witness: the components (nodes, rank, monitored agents, sigma_min) and on failure
        the failing component, ``monitors_needed`` and ``vector``. Numeric: ``error_bound``
        the largest rounding bound of the components.
    """
    comps = system.switching_components(mode)
    infos = [image_kernel_component(system, mode, c, exact) for c in comps]
    status = _combine([i["status"] for i in infos]) if infos else Status.HOLDS
    margin = min((i["sigma_min"] for i in infos), default=1.0)
    if status is Status.FAILS:
        margin = 0.0 if exact else margin
    witness: dict[str, Any] = {
        "components": [{k: v for k, v in i.items() if k not in ("status", "vector")} for i in infos]
    }
    bad = [i for i in infos if i["status"] is status and status is not Status.HOLDS]
    if bad:
        b = bad[0]
        witness["failing_component" if status is Status.FAILS else "undecided_component"] = b["nodes"]
        witness["monitors_needed"] = b["rank"]
        if "vector" in b:
            witness["vector"] = b["vector"]
    premise = None
    if not comps:
        witness["note"] = "the mode changes no link: Im(dL_q) = {0}"
        premise = "the mode changes no link"
    bound = max((float(i.get("error_bound", 0.0)) for i in infos), default=0.0) if not exact else None
    note = bad[0].get("note", "") if (bad and status is Status.UNDECIDED) else ""
    return Verdict(status, margin=margin, error_bound=bound, witness=witness, exact=exact, premise=premise, note=note)


def coverage_verdict(system: System, mode: str) -> Verdict:
    """Lemma A.2 for one safe mode: every switching component D_c meets M = M_x ∪ M_v (combinatorial).

    Parameters
    ----------
    system : System
    mode : str
        A safe mode.

    Returns
    -------
    Verdict
        Margin: min over components of ``|D_c ∩ M|``. Witness: per component its nodes and
        monitored agents; on failure ``uncovered``.
    """
    monitored = set(system.monitored)
    comps = system.switching_components(mode)
    rows = [{"nodes": list(c), "monitored": [a for a in c if a in monitored]} for c in comps]
    uncovered = [r["nodes"] for r in rows if not r["monitored"]]
    witness: dict[str, Any] = {"components": rows}
    if uncovered:
        witness["uncovered"] = uncovered
    margin = min((len(r["monitored"]) for r in rows), default=0)
    premise = None if comps else "the mode changes no link"
    return Verdict(Status.FAILS if uncovered else Status.HOLDS, margin=margin, witness=witness, combinatorial=True, premise=premise)
