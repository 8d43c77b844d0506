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
    Classes of twin agents (:func:`~glocal_verify.numerics.symmetry.twin_modes`) outside
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
    A positive degree proves nothing by itself (a gcd s^k modulo p does not put the roots at
    0); the cluster step below may still locate the zeros, else the note says so.

The cluster step (zeros located exactly, cluster by cluster)
    Let X be the clusters holding the inputs (first F), Y the other agents still in play,
    S_X the agents of X with a neighbour in Y and S_Y those neighbours, L_{Y,S_X} = S_{S_Y}^T W.
    At s off (-inf, 0] (where s I + alpha L_YY, a principal block of a Laplacian, is
    invertible) a kernel vector (xi, u) of the pencil either has W xi_{S_X} != 0, and then
    (xi_Y, -alpha W xi_{S_X}) is one of the pencil of Y with inputs S_Y and outputs M in Y;
    or, W having full column rank, xi_{S_X} = 0, xi_Y = 0, and (xi_X, u) is one of the pencil
    of X with outputs (M in X) and S_X. Every point where the latter loses rank is a root of
    the gcd of a few exact maximal minors (over Q, on X's equitable quotient); when every
    root gives lambda^2 + gamma lambda = s with Re lambda < 0 (ball enclosures of the roots of
    z(lambda^2 + gamma lambda), s = 0 set apart), X adds no harmful zero. The pencil of Y is
    then settled by the modular count, or by the next step with its inputs S_Y (X grows by
    the next clusters while its minors cannot be computed or located, up to
    ``zero_count_cluster_max_agents``); when Y is empty, X's own outputs decide.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from fractions import Fraction
from typing import Iterable, Mapping

from glocal_verify import config
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda_screens import disjoint_paths
from glocal_verify.derived import Kind
from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.cluster_transfer import adjugate_columns
from glocal_verify.numerics.symmetry import equitable_cells, twin_modes
from glocal_verify.numerics.zero_polynomial import poly_det
from glocal_verify.numerics.zero_count import ZeroCountBound, zero_count_bound_mod_p
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["ZeroSetCompleteness", "zero_set_completeness"]

_COMPLETENESS_KIND: Kind["ZeroSetCompleteness"] = Kind("zda-completeness", __name__, "ZeroSetCompleteness")
_MONITOR_QUOTIENT_KIND: Kind["_Quotient"] = Kind("monitor-quotient", __name__, "_Quotient")


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


@dataclass(frozen=True, slots=True)
class _Quotient:
    """The quotient of :func:`_quotient`.

    Attributes
    ----------
    size : int
        Its cells.
    entries : dict
        The nonzero entries of -alpha L_W.
    cell : list of int
        The cell of each agent.
    alone : frozenset of int
        The agents alone in their cell.
    """

    size: int
    entries: dict[tuple[int, int], Fraction]
    cell: list[int]
    alone: frozenset[int]


def _quotient(n: int, lap: Mapping[tuple[int, int], Fraction], alpha: Fraction, special: set[int]) -> _Quotient:
    """The quotient by an equitable partition with ``special`` agents in singleton cells.

    ``lap`` is a symmetric matrix with nonnegative eigenvalues (L_1 or a principal block). The
    partition is the colour refinement started from the special agents individualised (each
    agent's signature: its cell, its diagonal entry and the multiset of (cell, entry) over its
    neighbours), which puts twins and mirror-image branches in common cells; it is then
    checked to be equitable directly (equal row sums over every cell for every member).
    """
    rows: list[dict[int, Fraction]] = [{} for _ in range(n)]
    for (i, j), v in lap.items():
        if v != 0:
            rows[i][j] = v
    colour = equitable_cells(n, lap, special)
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
    quot: dict[tuple[int, int], Fraction] = {}
    for r in reps:
        for k, v in sums(r).items():
            quot[(pos[r], k)] = -alpha * v
    cell = [pos[cls[a]] for a in range(n)]
    count: dict[int, int] = {}
    for c in cell:
        count[c] = count.get(c, 0) + 1
    return _Quotient(len(reps), quot, cell, frozenset(a for a, c in enumerate(cell) if count[c] == 1))


def _known_zeros(n: int, lap: Mapping[tuple[int, int], Fraction], alpha: Fraction, F: list[int], M: list[int], cell: list[int]) -> dict[Fraction, int]:
    """Exact zeros of the quotient pencil Q_W at s0 = -alpha mu <= 0: {s0: independent kernel vectors known}.

    A pair of twin agents {a, r} outside M that meets F (so not merged into a cell) gives
    the exact eigenvector e_a - e_r of ``lap`` (eigenvalue mu = lap_aa - lap_ar >= 0)
    vanishing on M; its projection on W (cell means; P_W commutes with ``lap``, W being
    invariant and ``lap`` symmetric) is an exact kernel vector [xi; 0] of Q_W(-alpha mu).
    Their rank at each s0, computed over Q, counts zeros of Q_W there (each invariant factor
    vanishing at s0 gives one kernel dimension and at least one zero).
    """
    import flint

    Fs = set(F)
    sizes: dict[int, int] = {}
    for c in cell:
        sizes[c] = sizes.get(c, 0) + 1
    by_mu: dict[Fraction, list[dict[int, Fraction]]] = {}
    for mu, pairs in twin_modes(n, lap, M):
        for a, r in pairs:
            if a in Fs or r in Fs:
                v: dict[int, Fraction] = {}
                for b, sign in ((a, 1), (r, -1)):
                    v[cell[b]] = v.get(cell[b], Fraction(0)) + Fraction(sign, sizes[cell[b]])
                v = {k: x for k, x in v.items() if x != 0}
                if v:
                    by_mu.setdefault(Fraction(mu), []).append(v)
    out: dict[Fraction, int] = {}
    for mu, vecs in by_mu.items():
        cols = sorted({k for v in vecs for k in v})
        mat = flint.fmpq_mat(len(vecs), len(cols), [flint.fmpq(v.get(k, Fraction(0)).numerator, v.get(k, Fraction(0)).denominator) for v in vecs for k in cols])
        out[-alpha * mu] = int(mat.rank())
    return out


@dataclass(frozen=True, slots=True)
class _AxisProof:
    """Whether [[sI + alpha lap, -S_in^T], [S_out, 0]] loses column rank only at real s <= 0."""

    proven: bool
    states: int
    merged: int
    count: ZeroCountBound | None
    text: str


def _negative_axis_only(
    n: int, lap: Mapping[tuple[int, int], Fraction], alpha: Fraction, F: list[int], M: list[int], what: str, base: _Quotient | None = None
) -> _AxisProof:
    """The twin reduction and the modular count (module docstring) for one selection pencil.

    ``base``: the quotient with the agents of M alone individualised (the coarsest equitable
    partition in which they are singletons). When every agent of F is already alone in its
    cell there, it is also the coarsest one with F and M individualised (it is equitable, has
    them all as singletons, and no partition with F and M individualised is coarser than the
    one with M alone): the refinement is not run again for this F (an audit asks for every set).
    """
    q = base if base is not None and base.alone.issuperset(F) else _quotient(n, lap, alpha, set(F) | set(M))
    size, quot, cell = q.size, q.entries, q.cell
    merged = n - size
    cb = zero_count_bound_mod_p(size, quot, [cell[f] for f in F], [cell[o] for o in M])
    if cb.bound is None:
        return _AxisProof(False, size, merged, cb, f"the modular zero count of {what} proved nothing: {cb.note}")
    known = _known_zeros(n, lap, alpha, F, M, cell)
    k = sum(known.values())
    if cb.bound < k:  # pragma: no cover - the bound counts every zero
        raise ArithmeticError(f"the modular zero count {cb.bound} is below the {k} exactly known zeros; please report")
    at = ", ".join(f"{c} at s = {s0}" for s0, c in sorted(known.items()))
    known_txt = f"{k} ({at}: twin modes meeting the inputs, u0 = 0)" if k else "0"
    if cb.bound > k:
        return _AxisProof(
            False, size, merged, cb,
            f"deg gcd mod {cb.prime} = {cb.bound} > {known_txt} = exactly known zeros of {what} ({size} states): "
            f"{cb.bound - k} zero(s) of unknown location",
        )
    cells = f"; the {merged} modes merged by the equitable partition are eigenvalues of -alpha L too" if merged else ""
    return _AxisProof(
        True, size, merged, cb,
        f"deg gcd mod {cb.prime} = {cb.bound} = {known_txt} = exactly known zeros of {what} ({size} states; two squarings-down "
        f"det(R Q(s)), leading coefficient a unit mod p checked over Z, characteristic polynomial{' of A - B K' if cb.feedback else ''} "
        f"read exactly){cells}",
    )


def _cluster_zeros_decay(system: System, name: str, X: list[int], inputs: list[int], outputs: list[int], lap: Mapping[tuple[int, int], Fraction]) -> tuple[bool, str]:
    """Every zero of (-alpha L_XX, S_in^T, S_out) gives lambda with Re lambda < 0 (or s = 0): proven exactly, or why not."""
    import flint

    alpha = Fraction(system.alpha_q)
    xpos = {a: k for k, a in enumerate(X)}
    lap_x = {(xpos[i], xpos[j]): v for (i, j), v in lap.items() if i in xpos and j in xpos and v != 0}
    # the merged modes of the equitable quotient are eigenvalues of -alpha L_XX (real, <= 0)
    qx = _quotient(len(X), lap_x, alpha, {xpos[a] for a in (*inputs, *outputs)})
    nx_, ent_x, cell = qx.size, qx.entries, qx.cell
    A = flint.fmpq_mat(nx_, nx_, [0] * (nx_ * nx_))
    for (i, j), v in ent_x.items():
        A[i, j] = flint.fmpq(v.numerator, v.denominator)
    Fx = [cell[xpos[f]] for f in inputs]
    Ox = [cell[xpos[i]] for i in outputs]
    m = len(Fx)
    d, P = adjugate_columns(A, Fx)
    # every point where the pencil loses column rank is a root of every maximal minor
    # mu_R = det(S_R adj(sI - A) S_F^T) / d^(m - 1) (R an m-subset of the outputs), so of their gcd
    z = None
    for R in itertools.islice(itertools.combinations(Ox, m), config.get("zero_polynomial_subsets")):
        num = poly_det([[P[r][k] for k in range(m)] for r in R])
        if num.is_zero():
            continue
        mu, rem = divmod(num, d ** (m - 1)) if m > 1 else (num, flint.fmpq_poly(0))
        if not rem.is_zero():  # pragma: no cover - the matrix determinant lemma
            raise ArithmeticError("a maximal minor is not divisible by det(sI - A)^(m-1); please report")
        z = mu if z is None else z.gcd(mu)
    if z is None:
        return False, f"{name} ({m} inputs, {len(Ox)} outputs): no nonzero maximal minor among those tried (not shown left-invertible)"
    degree = z.degree()
    x = flint.fmpq_poly([0, 1])
    k0 = 0
    while z.degree() > 0 and z(0) == 0:
        z = z // x
        k0 += 1
    gamma = Fraction(system.gamma_q)
    lam_poly = z(flint.fmpq_poly([0, flint.fmpq(gamma.numerator, gamma.denominator), 1]))  # z(lambda^2 + gamma lambda)
    roots = lam_poly.complex_roots() if lam_poly.degree() > 0 else []
    if not all(r.real < 0 for r, _ in roots):
        return False, f"{name}: a root of the gcd of its maximal minors (degree {degree}) is not proven to decay"
    return True, f"{name}: the gcd of its maximal minors has degree {degree}, {k0} root(s) at s = 0, every other one with Re lambda < 0"


def _cluster_chain(system: System, F: list[int], M: list[int]) -> tuple[bool, str] | None:
    """The cluster step of the module docstring, repeated along the clusters: (proven, text), or None when it does not apply."""
    import flint

    lap = laplacian_entries(system, NORMAL_MODE)
    alpha = Fraction(system.alpha_q)
    labels = system.labels
    Ms = set(M)
    current = set(range(system.n))
    inputs = list(F)
    steps: list[str] = []
    for _ in range(config.get("zero_count_cluster_steps")):
        try:
            names = {system.cluster_of(labels[f]) for f in inputs}
        except ModelError:  # an input agent in no cluster
            return None
        while True:
            # X: the clusters holding the inputs (grown by the next clusters while its pencil is not proved)
            name = "+".join(sorted(names))
            X = sorted(system.index[a] for c in names for a in system.cluster(c).nodes if system.index[a] in current)
            Xs = set(X)
            if len(X) > config.get("zero_count_cluster_max_agents"):
                return None if not steps else (False, "; ".join(steps) + f"; {name} is larger than zero_count_cluster_max_agents")
            cut = [(i, j, v) for (i, j), v in lap.items() if v != 0 and i in Xs and j in current and j not in Xs]
            SX = sorted({i for i, _, _ in cut})
            SY = sorted({j for _, j, _ in cut})
            Y = sorted(current - Xs)
            if not Y:
                # the last clusters: their own pencil (outputs: their monitored agents) decides
                ok, txt = _cluster_zeros_decay(system, name, X, inputs, sorted(Ms & Xs), lap)
                return ok, "; ".join([*steps, txt])
            if not cut or len(SX) > len(SY):
                return None if not steps else (False, "; ".join(steps) + f"; {name} has {len(SX)} boundary agents for {len(SY)} beyond")
            # the coupling L_{Y, S_X} = S_{S_Y}^T W must have full column rank |S_X|
            W = flint.fmpq_mat(len(SY), len(SX), [0] * (len(SY) * len(SX)))
            for i, j, v in cut:
                W[SY.index(j), SX.index(i)] = flint.fmpq(v.numerator, v.denominator)
            ok, txt = (False, f"the coupling out of {name} is rank deficient") if W.rank() < len(SX) else _cluster_zeros_decay(
                system, name, X, inputs, sorted((Ms & Xs) | set(SX)), lap
            )
            if ok:
                break
            try:
                more = {system.cluster_of(labels[j]) for j in SY} - names
            except ModelError:
                more = set()
            if not more:
                return False, "; ".join([*steps, txt])
            names |= more
        steps.append(f"{txt} (outputs its monitored and {len(SX)} boundary agent(s))")
        ypos = {a: k for k, a in enumerate(Y)}
        lap_y = {(ypos[i], ypos[j]): v for (i, j), v in lap.items() if i in ypos and j in ypos}
        outer = _negative_axis_only(len(Y), lap_y, alpha, [ypos[j] for j in SY], [ypos[o] for o in M if o in ypos], f"the pencil beyond {name}")
        if outer.proven:
            return True, "; ".join([*steps, outer.text])
        current, inputs = set(Y), SY
    return False, "; ".join(steps) + "; zero_count_cluster_steps reached"


def zero_set_completeness(system: System, actuators: Iterable[Label], *, cluster_search: bool = True) -> ZeroSetCompleteness:
    """Prove that every invariant zero lambda != 0 of (A_1, B_F, C) has Re lambda < 0, or say why not.

    .. math::

        \\operatorname{rank} Q(s) < N + m \\;\\Rightarrow\\; s \\in (-\\infty, 0]
        \\quad\\Longrightarrow\\quad \\operatorname{Re}\\lambda < 0 \\text{ for every zero } \\lambda \\ne 0

    by the exact twin reduction and the modular count of the module docstring, or, when the
    count finds zeros of unknown location, by the cluster step (exact statements; no
    tolerance). Kept on ``system.analysis`` per actuator set.

    Parameters
    ----------
    system : System
    actuators : iterable of labels
        F.
    cluster_search : bool
        Try the cluster step when the count leaves zeros of unknown location (False: the
        count alone, as an audit of many sets asks).

    Returns
    -------
    ZeroSetCompleteness
    """
    F = tuple(actuators)

    def build() -> ZeroSetCompleteness:
        Fi = system.idx(F)
        M = system.idx(system.monitored)
        if len(Fi) > len(M):
            return ZeroSetCompleteness(False, system.n, 0, None, f"{len(Fi)} attacked agents and {len(M)} monitored ones: never left-invertible")
        paths = disjoint_paths(system, F)
        if paths < len(Fi):
            return ZeroSetCompleteness(
                False, system.n, 0, None,
                f"not left-invertible: at most {paths} vertex-disjoint path(s) from F to M < |F| = {len(Fi)} (for every choice of the weights), "
                "so a stealthy ZDA exists at every lambda0, unstable ones included: lambda0 = 0 is not the fastest-growing zero",
            )
        lap, alpha = laplacian_entries(system, NORMAL_MODE), Fraction(system.alpha_q)
        base = _MONITOR_QUOTIENT_KIND.get(system, (NORMAL_MODE, tuple(M)), lambda: _quotient(system.n, lap, alpha, set(M)))
        whole = _negative_axis_only(system.n, lap, alpha, Fi, M, "the pencil in s = lambda^2 + gamma lambda", base)
        tail = ": Q(s) is left-invertible and loses rank only at real s <= 0, so every zero lambda != 0 has Re lambda < 0"
        if whole.proven:
            return ZeroSetCompleteness(True, whole.states, whole.merged, whole.count, f"zero set complete: {whole.text}{tail}")
        sep = _cluster_chain(system, Fi, M) if cluster_search and whole.count is not None and whole.count.bound is not None else None
        if sep is not None and sep[0]:
            return ZeroSetCompleteness(
                True, whole.states, whole.merged, whole.count,
                f"zero set complete: {whole.text}, located by the cluster of F: {sep[1]}: Q(s) is left-invertible, and every zero lambda != 0 has Re lambda < 0",
            )
        why = f" (the cluster of F does not settle it: {sep[1]})" if sep is not None else ""
        return ZeroSetCompleteness(False, whole.states, whole.merged, whole.count, f"zero set not certified complete: {whole.text}{why} (a faster one, Re lambda >= 0, is not excluded)")

    return _COMPLETENESS_KIND.get(system, (F, cluster_search), build)
