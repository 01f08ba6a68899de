"""Weak identifiability: robot values the data determine only to worse than a physically meaningful precision.

A base parameter of the pivoted QR (identifiability.py) adds more than RANK_TOLERANCE of new
information, yet a joint that barely moves in the data (a torso at +-0.01 deg) leaves columns
that differ by 1e-4 of their norm: "identifiable", with a predicted standard deviation of tens
of mm. Fitted, such a direction follows the noise and the model's missing effects, the fit
slides along the valley (not converged) and ends metres from the drawing with a std that looks
small at the far end. Such a direction is not fitted: it is held at its nominal value, with
its reason.

The predicted covariance of the base parameters is (J^T J)^-1 of the weighted Jacobian at the
design point (Goswami, Quaid & Peshkin: the covariance of the least-squares estimate; Stone
eq. 5.23's weighting by the readings' sigmas), taken from the SVD of its triangular factor R
(J^T J = R^T R), never by inverting J^T J. A robot value (a chain or target length or angle, an
encoder scale) whose predicted std exceeds its precision, robot.tolerance / PRECISION_SHARE
(1 mm, 0.2 deg and 0.001 by default), is held; one at a time, the worst first (its std over its precision), since holding
one makes the others of its near-redundant group determined. The parameters of such a group have
nearly equal stds (they differ by the group's small new part, which the poses decide), so ratios within
TIE of the worst count as equal and the one latest in the spec is held: two campaigns of one robot hold
the same one (the base choice, too, takes the earlier in the spec). The instrument's parameters and the
effects are not judged: the registration has no meaningful nominal to hold, and an effect must
earn its place on held-out data.
"""

from __future__ import annotations

import math

import numpy as np

PRECISION_SHARE = 10.0  # precision = robot.tolerance / PRECISION_SHARE: a value fitted by noise of 3 std stays within a third of what is plausible
WEAK = "weakly identifiable"  # how a held parameter's reason starts
TIE = 0.05  # relative difference of two std/precision ratios below which the one later in the spec is held


def weakly_identifiable(R: np.ndarray, entries: list) -> list[tuple[int, str]]:
    """(position in ``entries``, reason) of the base parameters to hold, in the order they were held.

    ``R`` (k, len(entries)): a triangular factor of the weighted Jacobian's base columns (R^T R = J^T J);
    ``entries``: their ParameterInfo in the spec's order (a tie holds the last), whose ``tolerance`` (internal unit)
    is None where not judged."""
    precision = np.array([e.tolerance / PRECISION_SHARE if e.tolerance is not None else np.inf for e in entries])
    kept = list(range(len(entries)))
    held = []
    while kept and np.isfinite(precision[kept]).any():
        std = predicted_std(R[:, kept])
        ratio = np.where(np.isfinite(precision[kept]), std / precision[kept], 0.0)
        worst = float(np.max(ratio))
        if worst <= 1.0:
            break
        last = int(np.flatnonzero(ratio >= worst * (1.0 - TIE))[-1])
        position = kept.pop(last)
        held.append((position, _reason(entries[position], float(std[last]), float(precision[position]))))
    return held


def predicted_std(R: np.ndarray) -> np.ndarray:
    """Standard deviations of the parameters of the columns of ``R``: the norms of the rows of V S^-1 (SVD of R);
    inf along a direction R does not see."""
    _, s, Vt = np.linalg.svd(R, full_matrices=False)
    if not len(s) or s[-1] <= s[0] * np.finfo(float).eps * max(R.shape):
        return np.full(R.shape[1], np.inf)
    return np.linalg.norm(Vt.T / s, axis=1)


def _reason(entry, std: float, precision: float) -> str:
    if entry.kind == "angle":
        shown, unit = math.degrees(std), "deg"
        limit = math.degrees(precision)
    elif entry.kind == "scale":
        shown, unit, limit = std, "(ratio)", precision
    else:
        shown, unit, limit = std, "mm", precision
    return f"{WEAK}: predicted std {shown:.3g} {unit} > {limit:.3g} {unit} (robot.tolerance / {PRECISION_SHARE:g})"
