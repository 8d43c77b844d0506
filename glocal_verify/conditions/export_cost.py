"""Cost estimate of ``export``: the deployment file of a spec, before any observer is designed.

``glocal-verify export`` designs the central observer of every mode (a dense 2N x 2N closed
loop), the local observers, and with thresholds the attack-free envelope over the spec's
horizon; then it writes the tree. The file holds a few dense 2N x 2N matrices (the central
observer's ``A`` and ``F``) and every mode's Laplacian, so its size and the writing time grow as
N^2, and the envelope as the samples times (2N)^2. The estimate is printed, and checked
against the limits, before the work starts (``--allow-large`` lifts them).
"""

from __future__ import annotations

from types import MappingProxyType

from glocal_verify.conditions.cost import B_BASE, C_EIGH, C_SIMULATE_SAMPLE, C_THRESHOLD, CostEstimate, SpecSizes, dense_bytes, phase_estimate
from glocal_verify.simulation.limits import THRESHOLD_ARRAYS

__all__ = ["estimate_export", "export_floats"]

#: attack-free envelope of the thresholds: seconds per output sample and (2N)^2 per mode run
#: (1.1 s at N = 400 and 3.5 s at N = 800 for the 601 samples of a two-cluster ring)
C_ENVELOPE_N2 = 3.0e-9
#: writing a float of the tree, by format: JSON text (0.2 us: 1.2 s for the 5.8 million floats
#: of an 800-agent ring), compressed .mat and .npz (0.04 us)
C_WRITE = MappingProxyType({"json": 2.0e-7, "mat": 4.0e-8, "npz": 4.0e-8})
#: bytes a float of the tree costs while it is written: the array (8), the row being converted
#: and, for JSON, the block of text in flight; the compressed formats hold their whole (small)
#: file and the arrays scipy/numpy copy
B_WRITE = MappingProxyType({"json": 10.0, "mat": 24.0, "npz": 24.0})
#: the sampled section (with ``[implementation]``): floats per sample and unit of detector work
#: (the thresholds of every segment, the guarantee's responses: 112 floats a sample for
#: paper19's work of 656), and passes over the (K, q, d) rows per segment (the thresholds of the
#: segment, the guarantee against them): 8.8 s at K = 1201, 11.6 s at K = 3001 on paper19
F_SAMPLED = 0.17
P_SAMPLED = 2.0
#: start of the sampled section (the exact discretisation and the sampled designs of every mode)
C_SAMPLED_START = 3.0
#: dense 2N x 2N arrays the central observer's design keeps at once (the closed loop, its
#: eigenvectors, the gain's workspace)
A_CENTRAL = 6.0


def export_floats(sizes: SpecSizes, *, thresholds: bool = True) -> float:
    """Floats in the deployment tree of a spec of ``sizes``.

    The central observer's ``A`` and ``F`` (2 (2N)^2), every mode's Laplacian ((S + 1) N^2),
    each local observer's matrices (about 6 (2 n_i)^2 per design) and, with thresholds, the
    envelope of every channel (samples x channels, the central and the local ones).

    Parameters
    ----------
    sizes : SpecSizes
    thresholds : bool
    """
    n = float(sizes.n)
    local = sum(6.0 * (2.0 * ni) ** 2 * obs * (1 + ch) for ni, obs, ch in zip(sizes.cluster_sizes, sizes.observers, sizes.changed_by_modes))
    floats = 2.0 * (2.0 * n) ** 2 + (sizes.modes + 1) * n * n + local
    if thresholds:
        local_channels = sum(2.0 * ni * obs for ni, obs in zip(sizes.cluster_sizes, sizes.observers))
        floats += float(sizes.samples) * (sizes.channels + local_channels + 1)
    floats += F_SAMPLED * float(sizes.threshold_samples) * sizes.detector_work  # 0 without [implementation]
    return floats


def estimate_export(sizes: SpecSizes, fmt: str, *, thresholds: bool = True) -> CostEstimate:
    r"""Seconds and peak memory of ``export`` of a spec of ``sizes`` to format ``fmt``.

    .. math::

        t = C_{start} + C_{eigh} N^3 (S + 1)
            + [\\text{thresholds}]\\, n_s (S + 1) (C_{s,0} + C_{env} (2N)^2)
            + C_{write} F,\\qquad
        m = B_{base} + A_c \\cdot 8 (2N)^2 + (8 + B_{write}) F

    with F the floats of the tree (:func:`export_floats`), :math:`n_s` the output samples of the
    spec's horizon and S the safe modes; with ``[implementation]`` the certified thresholds of
    every segment of the schedule and the guarantee add
    :math:`C_{s} + P\, C_{thr} K W (S + 2)` seconds and the (K, q, d) rows' bytes, with K the
    thresholds' samples and W the detector work (:class:`~glocal_verify.conditions.cost.SpecSizes`).

    Parameters
    ----------
    sizes : SpecSizes
    fmt : {"json", "mat", "npz"}
    thresholds : bool
        The attack-free envelope is computed (not ``--no-thresholds``).

    Returns
    -------
    CostEstimate
    """
    n = sizes.n
    runs = sizes.modes + 1
    floats = export_floats(sizes, thresholds=thresholds)
    phases = {
        "observer designs": C_EIGH * float(n) ** 3 * runs,
        "writing the file": C_WRITE.get(fmt, C_WRITE["json"]) * floats,
    }
    if thresholds:
        phases["attack-free thresholds"] = float(sizes.samples) * runs * (C_SIMULATE_SAMPLE + C_ENVELOPE_N2 * (2.0 * n) ** 2)
    rows = float(sizes.threshold_samples) * sizes.detector_work  # the sampled deployment's (K, q, d) rows
    if rows:
        phases["certified thresholds of the schedule"] = C_SAMPLED_START + P_SAMPLED * C_THRESHOLD * rows * (runs + 1)
    nbytes = B_BASE + A_CENTRAL * dense_bytes(2 * n) + (8.0 + B_WRITE.get(fmt, B_WRITE["json"])) * floats + 8.0 * THRESHOLD_ARRAYS * rows
    return phase_estimate("export", n, phases, nbytes, A_CENTRAL * 4.0)
