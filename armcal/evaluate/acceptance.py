"""The statement of conformity (ISO/IEC 17025:2017 7.8.6, ILAC-G8:2019): a held-out figure against the spec's tolerance.

Simple acceptance (ILAC-G8 4.2.1) passes when the figure is at most the tolerance. Guarded
acceptance (4.2.3, guard band w = U) passes when the figure plus its expanded uncertainty
U = k u is: u is the Type A standard uncertainty of an RMS from the finite sample of n
held-out poses (the poses independent, each pose's squared residuals summed), by the delta
method on the ratio estimator, and k the two-sided 95 % quantile of Student's t with n - 1
degrees of freedom (GUM G.3: 2.0 from about 60 poses, 12.7 with two). A maximum has no such uncertainty, so it takes simple
acceptance only. U leaves out the instrument's own calibration uncertainty (its MPE).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import stdtrit  # Student's t quantile (scipy.stats.t.ppf's own); scipy.stats imports slowly

from armcal.support.errors import UserError
from armcal.evaluate.residuals import distance_errors, readings_by_sample, residual_unit
from armcal.identify.uncertainty import residual_stats

COVERAGE = 0.95  # the level of confidence of the expanded uncertainty


def rms_uncertainty(squares: np.ndarray, counts: np.ndarray) -> float:
    """Standard uncertainty of sqrt(sum(squares) / sum(counts)), each pose one independent draw (delta method)."""
    n = len(squares)
    if n < 2:
        return math.nan
    ratio = squares.sum() / counts.sum()
    variance = np.sum((squares - ratio * counts) ** 2) / (n - 1) * n / counts.sum() ** 2
    return float(math.sqrt(variance) / (2 * math.sqrt(ratio))) if ratio > 0 else 0.0


def figures(validation, theta: np.ndarray, reading_kind: str) -> dict[str, tuple[float, float | None, int]]:
    """Each held-out statistic of the calibrated model: (value, standard uncertainty or None, poses behind it)."""
    values, samples = readings_by_sample(validation, theta, reading_kind)
    stats = residual_stats(values)
    _, slot = np.unique(samples, return_inverse=True)
    poses = int(slot.max()) + 1 if len(slot) else 0
    found = {
        "validation_rms": (stats["rms"], rms_uncertainty(np.bincount(slot, values**2), np.bincount(slot).astype(float)), poses),
        "validation_max": (stats["max_abs"], None, poses),
    }
    distances = distance_errors(validation, theta)
    if distances is not None and len(distances):
        found["validation_rms_3d"] = (float(np.sqrt(np.mean(distances**2))), rms_uncertainty(distances**2, np.ones(len(distances))), len(distances))
        found["validation_max_3d"] = (float(np.max(distances)), None, len(distances))
    return found


def acceptance_block(acceptance, validation, theta: np.ndarray, reading_kind: str) -> dict | None:
    """results.json's acceptance: the figure, the tolerance (device unit), the rule, U where guarded, the verdict."""
    if acceptance is None:
        return None
    found = figures(validation, theta, reading_kind) if validation is not None else {}
    if acceptance.statistic not in found:
        raise UserError(f"acceptance.statistic: the run has no {acceptance.statistic} (it needs validation data{', of points' if '_3d' in acceptance.statistic else ''})")
    value, u, poses = found[acceptance.statistic]
    guarded = acceptance.decision_rule == "guarded"
    if guarded and not math.isfinite(u):
        raise UserError("acceptance.decision_rule: guarded acceptance needs at least two held-out poses for the figure's uncertainty")
    k = float(stdtrit(poses - 1, 0.5 + COVERAGE / 2)) if guarded else None
    expanded = k * u if guarded else None
    limit = acceptance.tolerance - expanded if guarded else acceptance.tolerance
    return {
        "statistic": acceptance.statistic,
        "value": value,
        "unit": residual_unit(reading_kind)[1],
        "tolerance": acceptance.tolerance,
        "decision_rule": acceptance.decision_rule,
        "expanded_uncertainty": expanded,
        "coverage_factor": k,
        "acceptance_limit": limit,
        "verdict": "pass" if value <= limit else "fail",
    }
