"""Which parameters the data can determine: QR with column pivoting of the scaled Jacobian.

Columns of the Jacobian at the nominal are scaled to unit norm (parameters of
different units become comparable), then QR with column pivoting orders them by
how much new information each adds (Goswami: counting independent columns,
nonzero singular values). The first ``rank`` pivots form the base parameter set;
every other free parameter is fixed at its nominal with the base parameters it is
redundant with. Reported too: the condition number of the scaled base Jacobian,
the observability index O1 = (s_1 ... s_m)^(1/m) / sqrt(M) (Borm & Menq), and
directions no parameter can carry, such as the overall scale of a network.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from armcal.kinematics.params import ParameterSet

RANK_TOLERANCE = 1e-7  # |R_kk| / |R_00| below which a pivoted column adds nothing new


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


def analyse(J: np.ndarray, parameters: ParameterSet, free: np.ndarray) -> Identifiability:
    """Base parameter set among the ``free`` columns of the (weighted) Jacobian J at the nominal."""
    names = parameters.names
    fixed = [(n, "fixed in the spec") for n, f in zip(names, free) if not f]
    columns = np.flatnonzero(free)
    norms = np.linalg.norm(J[:, columns], axis=0)
    scale = np.max(norms) if len(norms) else 1.0
    silent = norms <= 1e-12 * scale
    fixed += [(names[c], "does not affect the measurements") for c in columns[silent]]
    columns = columns[~silent]
    scaled = J[:, columns] / norms[~silent]
    _, R, pivots = scipy.linalg.qr(scaled, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(R))
    rank = int(np.sum(diagonal > RANK_TOLERANCE * diagonal[0])) if len(diagonal) else 0
    base = columns[pivots[:rank]]
    for k in range(rank, len(pivots)):
        fixed.append((names[columns[pivots[k]]], _redundancy(R, rank, k, [names[c] for c in base])))
    singular = np.linalg.svd(scaled[:, pivots[:rank]], compute_uv=False) if rank else np.zeros(0)
    condition = float(singular[0] / singular[-1]) if rank else float("inf")
    o1 = float(np.exp(np.mean(np.log(singular))) / np.sqrt(len(J))) if rank else 0.0
    return Identifiability(
        n_parameters=len(names),
        rank=rank,
        base=tuple(names[c] for c in base),
        fixed=tuple(fixed),
        condition_number=condition,
        observability_o1=o1,
        singular_values=singular,
        unidentifiable=tuple(_null_directions(J, parameters, free)),
    )


def _redundancy(R: np.ndarray, rank: int, k: int, base_names: list[str]) -> str:
    """Which base parameters a dependent column is a combination of: R11 x = R12[:, k]."""
    x = scipy.linalg.solve_triangular(R[:rank, :rank], R[:rank, k]) if rank else np.zeros(0)
    weight = np.abs(x)
    if not len(weight) or weight.max() == 0:
        return "not identifiable from these data"
    order = [i for i in np.argsort(-weight) if weight[i] >= 0.1 * weight.max()][:4]
    return "redundant with " + ", ".join(base_names[i] for i in order)


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
