"""The figure of an attack audit: who can hide, drawn per agent or per pair of agents.

For k >= 2 an agent x agent heat map: cell (i, j) is the verdict of the set {i, j}, the
diagonal that of {i} (0 detected, 1 undecided, 2 undetected). For k = 1 one bar per agent,
coloured by its verdict. Drawn with matplotlib's Agg backend (no display needed).
"""

from __future__ import annotations

import io
from pathlib import Path
from types import MappingProxyType

import numpy as np

from glocal_verify.design.audit import AuditResult
from glocal_verify.runtime.files import write_bytes_atomic

__all__ = ["audit_figure", "audit_figure_bytes", "verdict_matrix"]

_CODE = MappingProxyType({"detected": 0.0, "undecided": 1.0, "undetected": 2.0})


def verdict_matrix(result: AuditResult) -> np.ndarray:
    """Candidate x candidate verdict codes (NaN where no row exists; pairs and singletons only).

    Parameters
    ----------
    result : AuditResult
    """
    pos = {a: i for i, a in enumerate(result.candidates)}
    M = np.full((len(pos), len(pos)), np.nan)
    for r in result.rows:
        if len(r.actuators) == 1:
            i = pos[r.actuators[0]]
            M[i, i] = _CODE[r.verdict]
        elif len(r.actuators) == 2:
            i, j = pos[r.actuators[0]], pos[r.actuators[1]]
            M[i, j] = M[j, i] = _CODE[r.verdict]
    return M


def audit_figure(result: AuditResult, path: str | Path) -> Path:
    """Write the audit figure to ``path`` (format from the suffix: ``.svg`` or ``.png``),
    atomically (:func:`~glocal_verify.runtime.files.write_bytes_atomic`).

    Parameters
    ----------
    result : AuditResult
    path : str or Path

    Returns
    -------
    Path
        The file written.
    """
    out = Path(path)
    return write_bytes_atomic(out, audit_figure_bytes(result, out.suffix.lstrip(".").lower() or "png"))


def audit_figure_bytes(result: AuditResult, fmt: str = "svg") -> bytes:
    """The audit figure as ``fmt`` (``"svg"`` or ``"png"``) bytes.

    Parameters
    ----------
    result : AuditResult
    fmt : str
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    cmap = ListedColormap(["#4caf50", "#ffc107", "#e53935"])
    labels = [str(a) for a in result.candidates]
    n = len(labels)
    size = min(12.0, 3.0 + 0.25 * n)
    fig, ax = plt.subplots(figsize=(size, size if result.max_attackers >= 2 else 3.5))
    if result.max_attackers >= 2:
        M = verdict_matrix(result)
        ax.imshow(np.ma.masked_invalid(M), cmap=cmap, vmin=0, vmax=2, interpolation="nearest")
        if n <= 60:
            ax.set_xticks(range(n), labels, fontsize=7, rotation=90)
            ax.set_yticks(range(n), labels, fontsize=7)
        ax.set_xlabel("compromised actuator")
        ax.set_ylabel("compromised actuator")
    else:
        codes = [_CODE[r.verdict] for r in result.rows if len(r.actuators) == 1]
        ax.bar(range(len(codes)), [1] * len(codes), color=[cmap(int(c)) for c in codes])
        ax.set_yticks([])
        if n <= 80:
            ax.set_xticks(range(len(codes)), labels[: len(codes)], fontsize=7, rotation=90)
        ax.set_xlabel("compromised actuator")
    c = result.summary()["counts"]
    ax.set_title(f"{result.system}: green detected ({c['detected']}), amber undecided ({c['undecided']}), red undetected ({c['undetected']})", fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format=fmt)
    finally:
        plt.close(fig)
    return buf.getvalue()
