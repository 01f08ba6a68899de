"""Which parameters the data can determine: QR with column pivoting of the scaled Jacobian.

The base set is decided once per model and campaign design, at the design point
(the nominal, or the nominal with the instrument registered; for a contact instrument at the
recorded poses moved into the contacts the nominal model holds, Problem.design_jacobian), and kept for every
refit, fold and study: away from the design a redundancy the geometry has exactly
(parallel axes, a target on the last axis) is broken by the fitted errors and would
look identifiable, with a condition number of 1e7 and a fit that slides along the
valley.

Columns of the Jacobian at the design point are scaled to unit norm (parameters of
different units become comparable), then QR with column pivoting orders them by
how much new information each adds (Goswami: counting independent columns,
nonzero singular values), group by group in PRIORITY order: the instrument's
parameters, then the targets', then the robot's own, each group's columns first
projected off those chosen before. A column whose new part (|R_kk|) is below
RANK_TOLERANCE adds nothing new; every such free parameter is held at its start
value with the base parameters it is redundant with. Columns whose new parts are
equal (to TIE) are taken in the spec's order, so which of two redundant parameters
is identified (a joint's offset or the next one's, along the same line) is decided
by the spec and not by the last bits of the arithmetic (compiler, processor). So where no reading can tell
two parameters apart, the instrument or the target carries the difference and the
robot's parameter stays at its nominal: a reflector on the last axis takes the
flange's offset along it, a free tracker pose the first joint's zero. Effect parameters are added after the geometry (``extend``):
one is kept only when its column keeps more than EFFECT_NEW_PART of its norm off
the base columns, so an effect never makes a geometric parameter identifiable that
the geometry alone could not identify, nor is fitted along a near-flat direction. Reported too: the observability index
O1 = (s_1 ... s_m)^(1/m) / sqrt(M) (Borm & Menq), directions no parameter can
carry, such as the overall scale of a network, and, at the solution, the
condition number and the flat directions of the scaled base Jacobian.

Everything here depends on the Jacobian only through its columns' inner products
(norms, projections, the pivots' new parts, singular values), so a tall Jacobian is
first reduced to the triangular factor R of its QR decomposition (J^T J = R^T R),
taken in row blocks: the rest, the base choice included, costs O(p^3) whatever the
number of readings, and no copy of J is made.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg

from armcal.identify.precision import WEAK, weakly_identifiable
from armcal.identify.threads import each
from armcal.kinematics.params import ParameterSet

RANK_TOLERANCE = 1e-7  # norm of a unit column's part the columns chosen before it leave, below which it adds nothing
EFFECT_NEW_PART = 1e-3  # an effect column's new part below which it is held: its std would be inflated over 1000-fold
# (variance inflation 1/part^2 > 1e6), the fit would slide along that near-flat direction and not converge
PRIORITY = ("device", "target", "chain")  # who carries a redundancy: the instrument and the targets before the robot
FLAT_RATIO = 1e-3  # s_k / s_1 of the scaled base Jacobian below which a direction is reported as flat
TIE = 1e-10  # difference of two unit columns' new parts below which the one first in the spec is taken (rounding
# makes new parts as small as RANK_TOLERANCE err by up to ~1e-13: a relative tie would be no wider than that)
ALIGNED = 1e-2  # two new parts of sizes equal to this fraction and directions equal to it (sine of their angle) are
# one choice, taken in the spec's order: columns exactly redundant but for a rounded angle (a URDF's 1.5708 for pi/2,
# 3.7e-6 rad) differ by that angle times a lever ratio, up to ~1e-3 (a Gen3's L4.beta and L5.alpha: sizes 2e-5
# apart, directions 1.3e-3), the sign set by the poses: by size alone two campaigns would hold different ones
ROWS = 1024  # rows of J per step of its blockwise QR (triangular)
SHARE = 4 * ROWS  # rows of J whose R one thread computes (triangular)


@dataclass(frozen=True)
class Identifiability:
    n_parameters: int
    rank: int
    base: tuple[str, ...]  # the identified free parameters
    fixed: tuple[tuple[str, str], ...]  # (name, reason), spec-fixed ones included
    condition_number: float
    observability_o1: float
    singular_values: np.ndarray
    unidentifiable: tuple[str, ...]  # named directions: "scale"


def analyse(J: np.ndarray, parameters: ParameterSet, free: np.ndarray, hold_weak: bool = True) -> Identifiability:
    """Base parameter set among the ``free`` columns of the (weighted) Jacobian J at the design point:
    the geometric ones by pivoted QR, group by group in PRIORITY order, less the robot values the data determine
    too poorly (precision.py; ``hold_weak`` False while the weights are provisional), then the effects' by ``extend``."""
    names = parameters.names
    roles = np.array([e.role for e in parameters.entries])
    fixed = [(n, held_reason(e)) for n, f, e in zip(names, free, parameters.entries) if not f]
    readings, J = len(J), triangular(J)
    columns = np.flatnonzero(free & (roles != "effect"))
    norms = np.linalg.norm(J[:, columns], axis=0)
    scale = np.max(norms) if len(norms) else 1.0
    silent = norms <= 1e-12 * scale
    fixed += [(names[c], "does not affect the measurements") for c in columns[silent]]
    columns, norms = columns[~silent], norms[~silent]
    scaled = J[:, columns] / norms
    groups = [g for g in (np.flatnonzero(roles[columns] == role) for role in PRIORITY) if len(g)]
    basis, chosen, dependent = np.zeros((len(J), 0)), [], []
    for group in groups:  # each projected off the columns of the groups before it
        pivots, directions = _pivoted(_off(basis, scaled[:, group]))
        taken = group[pivots]
        chosen += list(taken)
        dependent += [k for k in group if k not in taken]
        basis = np.column_stack([basis, directions])
    base = columns[chosen]
    base_names = [names[c] for c in base]
    fixed += [(names[columns[k]], reason) for k, reason in zip(dependent, _redundancies(scaled[:, chosen], base_names, scaled[:, dependent]))]
    if hold_weak:
        in_spec_order = np.argsort(base)  # the pivots' order depends on the data; a tie is broken by the spec's
        weak = [(int(in_spec_order[k]), reason) for k, reason in
                weakly_identifiable(J[:, base[in_spec_order]], [parameters.entries[c] for c in base[in_spec_order]])]
        fixed += [(base_names[k], reason) for k, reason in weak]
        kept = sorted(set(range(len(base))) - {k for k, _ in weak})
        chosen, base, base_names = [chosen[k] for k in kept], base[kept], [base_names[k] for k in kept]
    rank = len(base)
    singular = np.linalg.svd(scaled[:, chosen], compute_uv=False) if rank else np.zeros(0)
    condition = float(singular[0] / singular[-1]) if rank else float("inf")
    o1 = float(np.exp(np.mean(np.log(singular))) / np.sqrt(readings)) if rank else 0.0
    geometric = Identifiability(
        n_parameters=len(names),
        rank=rank,
        base=tuple(base_names),
        fixed=tuple(fixed),
        condition_number=condition,
        observability_o1=o1,
        singular_values=singular,
        unidentifiable=tuple(_null_directions(J, parameters, free & (roles != "effect"))),
    )
    effects = [names[c] for c in np.flatnonzero(free & (roles == "effect"))]
    return extend(geometric, J, parameters, effects) if effects else geometric


def _pivoted(columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """QR with column pivoting of unit ``columns``, ties taken in their order: the pivots whose new part exceeds
    RANK_TOLERANCE, and the orthonormal directions they add (Golub & Van Loan's algorithm 5.4.1, norms recomputed).
    A tie is equal new parts (TIE), or new parts equal in size and direction to ALIGNED: an earlier column is then
    taken before the largest."""
    rest = columns.copy()
    pivots, directions = [], []
    for _ in range(min(rest.shape)):
        parts = np.linalg.norm(rest, axis=0)
        parts[pivots] = 0.0
        largest = parts.max(initial=0.0)
        if largest <= RANK_TOLERANCE:
            break
        k = int(np.flatnonzero(parts >= largest - TIE)[0])
        q = rest[:, k] / parts[k]
        twins = [j for j in np.flatnonzero(parts[:k] >= largest * (1.0 - ALIGNED))
                 if np.linalg.norm(rest[:, j] - q * (q @ rest[:, j])) <= ALIGNED * parts[j]]
        if twins:  # an earlier column whose new part is this one's, but for a rounded angle: the spec's order
            k = twins[0]
            q = rest[:, k] / parts[k]
        if directions:  # once more off the directions before it: Gram-Schmidt loses orthogonality once
            q = _off(np.column_stack(directions), q[:, None])[:, 0]
            q /= np.linalg.norm(q)
        rest -= np.outer(q, q @ rest)
        pivots.append(k)
        directions.append(q)
    return np.array(pivots, dtype=int), np.column_stack(directions) if directions else np.zeros((len(columns), 0))


def triangular(J: np.ndarray) -> np.ndarray:
    """R (p, p) with R^T R = J^T J (J itself when it has no more rows than columns): the R of each SHARE rows of J,
    shared out to threads (threads.py), then the R of those stacked; the same cut on any number of threads."""
    if len(J) <= SHARE:
        return _blockwise(J)
    return _blockwise(np.concatenate(each(_blockwise, [J[first : first + SHARE] for first in range(0, len(J), SHARE)])))


def _blockwise(J: np.ndarray) -> np.ndarray:
    """R of J: QR of J's first ROWS rows, then of R stacked on the next ROWS rows, and so on (each step's copy is
    ROWS rows, never J)."""
    p = J.shape[1]
    if len(J) <= p:
        return J
    R = np.zeros((0, p))
    for first in range(0, len(J), ROWS):  # each stack column-major and factorised in place; "raw": R of its first p rows
        rows = J[first : first + ROWS]
        stack = np.concatenate([R, rows], out=np.empty((len(R) + len(rows), p), order="F"))
        R = scipy.linalg.qr(stack, overwrite_a=True, mode="raw", check_finite=False)[1][:p]
        del stack  # before the next one is made
    return R


def _off(basis: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``columns`` projected off the orthonormal ``basis`` (twice: Gram-Schmidt loses orthogonality once)."""
    rest = columns - basis @ (basis.T @ columns)
    return rest - basis @ (basis.T @ rest)


def held_reason(entry) -> str:
    """Why a parameter is not free: the spec holds it, or the model does (parallel axes)."""
    return entry.reason or "fixed in the spec"


def extend(design: Identifiability, J: np.ndarray, parameters: ParameterSet, names: list[str]) -> Identifiability:
    """The design's base set with the effect parameters ``names`` added where the base cannot absorb them.

    Each scaled column (at the design point) is projected off the base columns and the
    effect columns kept before it; one that keeps no more than RANK_TOLERANCE of its
    norm is redundant, one that keeps no more than EFFECT_NEW_PART weakly identifiable:
    held at its value, with the base parameters that (nearly) absorb it.
    """
    J = triangular(J)
    index = parameters.index
    base_names = list(design.base)
    columns = J[:, [index(n) for n in base_names]]
    scaled = columns / np.maximum(np.linalg.norm(columns, axis=0), 1e-300)
    basis = np.linalg.qr(scaled)[0] if len(base_names) else np.zeros((len(J), 0))
    largest = float(np.max(np.linalg.norm(J, axis=0))) if J.size else 0.0
    fixed = [f for f in design.fixed if f[0] not in names]
    for name in names:
        column = J[:, index(name)]
        norm = float(np.linalg.norm(column))
        if norm <= 1e-12 * largest:
            fixed.append((name, "does not affect the measurements"))
            continue
        rest = _off(basis, (column / norm)[:, None])[:, 0]
        new_part = float(np.linalg.norm(rest))
        if new_part <= EFFECT_NEW_PART:
            reason = _redundancies(scaled, base_names, (column / norm)[:, None])[0]
            if new_part > RANK_TOLERANCE:
                reason = f"{WEAK}: nearly {reason} (new part {new_part:.1e} of its column, below {EFFECT_NEW_PART:g})"
            fixed.append((name, reason + " at the design point"))
            continue
        basis = np.column_stack([basis, rest / np.linalg.norm(rest)])
        scaled = np.column_stack([scaled, column / norm])
        base_names.append(name)
    added = len(base_names) - len(design.base)
    return replace(design, rank=design.rank + added, base=tuple(base_names), fixed=tuple(fixed))


def _redundancies(scaled_base: np.ndarray, base_names: list[str], units: np.ndarray) -> list[str]:
    """Which base parameters each dependent (unit) column of ``units`` is a combination of: the largest weights of
    its fit (one least-squares solve for all)."""
    weights = np.abs(np.linalg.lstsq(scaled_base, units, rcond=None)[0]) if base_names else np.zeros((0, units.shape[1]))
    reasons = []
    for weight in weights.T:
        if not len(weight) or weight.max() == 0:
            reasons.append("not identifiable from these data")
            continue
        order = [i for i in np.argsort(-weight) if weight[i] >= 0.1 * weight.max()][:4]
        reasons.append("redundant with " + ", ".join(base_names[i] for i in order))
    return reasons


@dataclass(frozen=True)
class Conditioning:
    """The scaled base Jacobian at the solution: its condition number and its flat directions."""

    condition_number: float
    flat: tuple[dict, ...]  # {ratio: s_k / s_1, parameters: [(name, component)]} for s_k / s_1 < FLAT_RATIO


def conditioning(J: np.ndarray, names: list[str]) -> Conditioning:
    """Condition number of the column-scaled J (base columns) and the directions it barely sees."""
    if not J.shape[1]:
        return Conditioning(float("inf"), ())
    J = triangular(J)
    scaled = J / np.maximum(np.linalg.norm(J, axis=0), 1e-300)
    _, s, Vt = np.linalg.svd(scaled, full_matrices=False)
    flat = []
    for k in np.flatnonzero(s < FLAT_RATIO * s[0]):
        v = Vt[k]
        order = [i for i in np.argsort(-np.abs(v)) if abs(v[i]) >= 0.1][:6]
        flat.append({"ratio": float(s[k] / s[0]), "parameters": [(names[i], float(v[i])) for i in order]})
    return Conditioning(float(s[0] / s[-1]) if s[-1] > 0 else float("inf"), tuple(flat))


def _null_directions(J: np.ndarray, parameters: ParameterSet, free: np.ndarray) -> list[str]:
    """Named directions the data cannot see: scaling every length at once (no length reference).

    Scaling all lengths by (1 + e) changes the predictions by e J s, s the nominal
    lengths. When the measurements do not see that (J s = 0, e.g. angles only),
    and the free parameters can carry the part of it that falls on fixed lengths,
    a free direction leaves every prediction unchanged: the scale is unidentifiable.
    """
    lengths = np.array([e.kind == "length" for e in parameters.entries])
    s = np.where(lengths, parameters.nominal, 0.0)
    typical = np.linalg.norm(J[:, lengths] * s[lengths])
    if typical == 0 or not free.any() or np.linalg.norm(J @ s) > 1e-9 * typical:
        return []
    on_fixed = J[:, ~free] @ s[~free]
    if np.linalg.norm(on_fixed) == 0:
        return ["scale"]
    y, *_ = np.linalg.lstsq(J[:, free], on_fixed, rcond=None)
    return ["scale"] if np.linalg.norm(J[:, free] @ y - on_fixed) <= 1e-6 * np.linalg.norm(on_fixed) else []
