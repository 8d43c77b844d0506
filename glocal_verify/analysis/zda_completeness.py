"""Is the computed ZDA zero set complete beyond lambda = 0? A proof modulo a prime, N-sized.

``stealthy.zda``'s witness exponent is the fastest-growing zero (largest Re lambda0; among
equal real parts the largest |Im lambda0| comes first) when the spec gives no lambda0. A
numeric zero set whose only stealthy zero is lambda0 = 0 makes 0 that choice only if no zero
was missed with Re lambda >= 0, lambda != 0. This module proves exactly that, from the
N-sized pencil in s = lambda^2 + gamma lambda.

The reduction (Modal structure of the condition contract)
    For lambda != 0, (lambda I - A_1, B_F, C) loses rank iff

    .. math::

        Q(s) = \\begin{bmatrix} sI + \\alpha L_1 & -S_F^\\top \\\\ S_M & 0 \\end{bmatrix},
        \\qquad s = \\lambda^2 + \\gamma \\lambda,

    loses column rank (v = lambda xi; lambda S_{M_v} xi = 0 iff S_{M_v} xi = 0); lambda = 0
    is the separate pencil with the position outputs only, decided elsewhere. If every s
    where Q(s) loses rank is real and <= 0, then every lambda != 0 with
    lambda^2 + gamma lambda = s has Re lambda < 0 (real roots of product -s >= 0 and sum
    -gamma < 0, only one of them 0 when s = 0; or complex ones of real part -gamma / 2),
    so every zero lambda != 0 of the 2N system decays: lambda0 = 0 is the fastest-growing
    zero, alone on the imaginary axis.

Twin classes (exact)
    Classes of twin agents (:func:`~glocal_verify.numerics.minors.twin_modes`) outside
    F and M whose partition is verified equitable here (every member of a class has the same
    row sums of L_1 over every class) give W = {x constant on each class}, invariant under
    L_1, with Im S_F^T in W and S_M W^perp = 0. W^perp is invariant too (L_1 symmetric), so
    Q(s) is, in an orthogonal basis, the direct sum of the quotient pencil Q_W(s) (states
    the classes, matrix -alpha L_W with (L_W)_{CD} = sum_{b in D} (L_1)_{rb}, r in C) and
    s I + alpha L_1|W^perp, whose rank drops only at eigenvalues of -alpha L_1 (real,
    <= 0). The twin modes are exact invariant zeros with u0 = 0 (not attacks).

The count on the quotient (modulo a prime)
    :func:`~glocal_verify.numerics.zero_count.zero_count_bound_mod_p` bounds the number of
    points where Q_W(s) loses column rank (with multiplicity) by deg gcd(det(R_1 Q_W),
    det(R_2 Q_W)) mod p, with p not dividing the leading coefficient of det(R_1 Q_W)
    (checked over Z) and the characteristic polynomial read exactly. A bound equal to the
    number of exactly known zeros of Q_W -- none -- proves Q_W has no zero and full normal
    column rank (the 2N system is left-invertible), and with the twins the claim above.
    A positive degree proves nothing (a gcd s^k modulo p does not put the roots at 0): the
    zero set stays uncertified and the note says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Iterable

from glocal_verify.analysis.twins import laplacian_entries
from glocal_verify.analysis.zda_screens import disjoint_paths
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.minors import twin_modes
from glocal_verify.numerics.zero_count import ZeroCountBound, zero_count_bound_mod_p
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["ZeroSetCompleteness", "zero_set_completeness"]

_COMPLETENESS_KIND: Kind["ZeroSetCompleteness"] = Kind("zda-completeness", __name__, "ZeroSetCompleteness")


@dataclass(frozen=True, slots=True)
class ZeroSetCompleteness:
    """Whether every zero lambda != 0 of (A_1, B_F, C) is proven to decay (module docstring).

    Attributes
    ----------
    complete : bool
        Proven: every s where Q(s) loses column rank is real and <= 0, and Q has full normal
        column rank; so the stealthy zero lambda0 = 0, when it exists, is the
        fastest-growing zero, and no other zero has Re lambda >= 0.
    states : int
        States of the quotient pencil Q_W (N minus the twin modes).
    twin_modes : int
        Exact decoupled zeros (eigenvalues of -alpha L_1 on W^perp; u0 = 0).
    count : ZeroCountBound or None
        The modular bound on the quotient.
    text : str
        The witness when ``complete``, else why not.
    """

    complete: bool
    states: int
    twin_modes: int
    count: ZeroCountBound | None
    text: str


def _quotient(system: System, F: list[int], M: list[int]) -> tuple[int, dict[tuple[int, int], Fraction], list[int]]:
    """The quotient by an equitable partition with F and M in singleton cells: (size, entries of -alpha L_W, cell of each agent).

    The partition is the colour refinement of G_1 started from F and M individualised (each
    agent's signature: its cell and the multiset of (cell, weight) over its neighbours),
    which puts twins and mirror-image branches in common cells; it is then checked to be
    equitable directly (equal row sums of L_1 over every cell for every member of a cell).
    """
    n = system.n
    ent = laplacian_entries(system, NORMAL_MODE)
    rows: list[dict[int, Fraction]] = [{} for _ in range(n)]
    for (i, j), v in ent.items():
        if v != 0:
            rows[i][j] = v
    special = set(F) | set(M)
    colour = [(-1 - a) if a in special else 0 for a in range(n)]
    cells = len(set(colour))
    for _ in range(n):
        sig = [(colour[a], tuple(sorted((colour[b], v) for b, v in rows[a].items() if b != a))) for a in range(n)]
        ids: dict[object, int] = {}
        colour = [ids.setdefault(x, len(ids)) for x in sig]
        if len(ids) == cells:
            break
        cells = len(ids)
    rep: dict[int, int] = {}
    cls = [rep.setdefault(colour[a], a) for a in range(n)]  # the first member of each cell represents it
    reps = sorted(set(cls))
    pos = {r: k for k, r in enumerate(reps)}

    def sums(a: int) -> dict[int, Fraction]:
        out: dict[int, Fraction] = {}
        for b, v in rows[a].items():
            out[pos[cls[b]]] = out.get(pos[cls[b]], Fraction(0)) + v
        return {k: v for k, v in out.items() if v != 0}

    if any(cls[a] != a and sums(a) != sums(cls[a]) for a in range(n)) or any(cls[a] != a for a in special):  # pragma: no cover - refinement is equitable
        raise ArithmeticError("colour refinement returned a partition that is not equitable; please report")
    alpha = Fraction(system.alpha_q)
    quot: dict[tuple[int, int], Fraction] = {}
    for r in reps:
        for k, v in sums(r).items():
            quot[(pos[r], k)] = -alpha * v
    return len(reps), quot, [pos[cls[a]] for a in range(n)]


def _known_zeros(system: System, F: list[int], M: list[int], cell: list[int]) -> dict[Fraction, int]:
    """Exact zeros of the quotient pencil Q_W at s0 = -alpha mu <= 0: {s0: independent kernel vectors known}.

    A pair of twin agents {a, r} outside M that meets F (so not merged into a cell) gives
    the exact eigenvector e_a - e_r of L_1 (eigenvalue mu = L_aa - L_ar > 0) vanishing on M;
    its projection on W (cell means; P_W commutes with L_1, W being invariant and L_1
    symmetric) is an exact kernel vector [xi; 0] of Q_W(-alpha mu). Their rank at each s0,
    computed over Q, counts zeros of Q_W there (each invariant factor vanishing at s0 gives
    one kernel dimension and at least one zero).
    """
    import flint

    ent = laplacian_entries(system, NORMAL_MODE)
    Fs = set(F)
    sizes: dict[int, int] = {}
    for c in cell:
        sizes[c] = sizes.get(c, 0) + 1
    by_mu: dict[Fraction, list[dict[int, Fraction]]] = {}
    for mu, pairs in twin_modes(system.n, ent, M):
        for a, r in pairs:
            if a in Fs or r in Fs:
                v: dict[int, Fraction] = {}
                for b, sign in ((a, 1), (r, -1)):
                    v[cell[b]] = v.get(cell[b], Fraction(0)) + Fraction(sign, sizes[cell[b]])
                v = {k: x for k, x in v.items() if x != 0}
                if v:
                    by_mu.setdefault(Fraction(mu), []).append(v)
    alpha = Fraction(system.alpha_q)
    out: dict[Fraction, int] = {}
    for mu, vecs in by_mu.items():
        cols = sorted({k for v in vecs for k in v})
        mat = flint.fmpq_mat(len(vecs), len(cols), [flint.fmpq(v.get(k, Fraction(0)).numerator, v.get(k, Fraction(0)).denominator) for v in vecs for k in cols])
        out[-alpha * mu] = int(mat.rank())
    return out


def zero_set_completeness(system: System, actuators: Iterable[Label]) -> ZeroSetCompleteness:
    """Prove that every invariant zero lambda != 0 of (A_1, B_F, C) has Re lambda < 0, or say why not.

    .. math::

        \\operatorname{rank} Q(s) < N + m \\;\\Rightarrow\\; s \\in (-\\infty, 0]
        \\quad\\Longrightarrow\\quad \\operatorname{Re}\\lambda < 0 \\text{ for every zero } \\lambda \\ne 0

    by the exact twin reduction and the modular count of the module docstring (exact
    statements; no tolerance). Kept on ``system.analysis`` per actuator set.

    Parameters
    ----------
    system : System
    actuators : iterable of labels
        F.

    Returns
    -------
    ZeroSetCompleteness
    """
    F = tuple(actuators)

    def build() -> ZeroSetCompleteness:
        Fi = system.idx(F)
        M = system.idx(system.monitored)
        size, quot, cell = _quotient(system, Fi, M)
        removed = system.n - size
        if len(Fi) > len(M):
            return ZeroSetCompleteness(False, size, removed, None, f"{len(Fi)} attacked agents and {len(M)} monitored ones: never left-invertible")
        paths = disjoint_paths(system, F)
        if paths < len(Fi):
            return ZeroSetCompleteness(
                False, size, removed, None,
                f"not left-invertible: at most {paths} vertex-disjoint path(s) from F to M < |F| = {len(Fi)} (for every choice of the weights), "
                "so a stealthy ZDA exists at every lambda0, unstable ones included: lambda0 = 0 is not the fastest-growing zero",
            )
        cb = zero_count_bound_mod_p(size, quot, [cell[f] for f in Fi], [cell[o] for o in M])
        if cb.bound is None:
            return ZeroSetCompleteness(False, size, removed, cb, f"the modular zero count proved nothing: {cb.note}")
        known = _known_zeros(system, Fi, M, cell)
        k = sum(known.values())
        if cb.bound < k:  # pragma: no cover - the bound counts every zero
            raise ArithmeticError(f"the modular zero count {cb.bound} is below the {k} exactly known zeros; please report")
        at = ", ".join(f"{c} at s = {s0}" for s0, c in sorted(known.items()))
        known_txt = f"{k} ({at}: twin modes meeting F, u0 = 0)" if k else "0"
        cells = f"; the {removed} modes merged by the equitable partition are eigenvalues of -alpha L_1 too" if removed else ""
        if cb.bound > k:
            return ZeroSetCompleteness(
                False, size, removed, cb,
                f"zero set not certified complete: deg gcd mod {cb.prime} = {cb.bound} > {known_txt} = exactly known zeros of the "
                f"{size}-state pencil in s = lambda^2 + gamma lambda: {cb.bound - k} zero(s) of unknown location "
                "(a faster one, Re lambda >= 0, is not excluded)",
            )
        return ZeroSetCompleteness(
            True, size, removed, cb,
            f"zero set complete: deg gcd mod {cb.prime} = {cb.bound} = {known_txt} = exactly known zeros of the {size}-state "
            f"pencil in s = lambda^2 + gamma lambda (two squarings-down det(R Q(s)); leading coefficient a unit mod p, checked over Z; "
            f"characteristic polynomial{' of A - B K' if cb.feedback else ''} read exactly){cells}: Q(s) is left-invertible and loses rank "
            "only at real s <= 0, so every zero lambda != 0 has Re lambda < 0",
        )

    return _COMPLETENESS_KIND.get(system, (F,), build)
