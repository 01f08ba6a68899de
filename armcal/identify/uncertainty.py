"""Uncertainty of the identified parameters and a check of the noise model.

With residuals weighted by the device's noise sigma, the covariance of the
base parameters is (J^T J)^-1 at the solution, computed from the singular values
of J (or of its triangular factor R, R^T R = J^T J), never by inverting J^T J: with
J = U S V^T, C = W W^T for W = V S^-1, so a condition number of J is not squared, and
the correlations (rows of W normalised, then their inner products) lie within
[-1, 1] by construction, up to one rounding that is clipped. chi^2 = sum r^2 is compared with
its distribution on M - p degrees of freedom: if the residuals are larger than
the noise model allows (p-value below 1 %), the covariance is scaled by
chi^2 / dof so the uncertainties stay honest, and the report says so; if they
are smaller than it allows (chi^2 in its lower 1 %), the declared noise is too
large and the uncertainties are overstated. Either way the verdict is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import chdtr, chdtrc  # chi-square distribution and survival functions; scipy.stats imports slowly

NOISE_CHECK_LEVEL = 0.01
CORRELATION_REPORTED = 0.95


@dataclass(frozen=True)
class Uncertainty:
    covariance: np.ndarray  # (p, p) over the base parameters
    std: np.ndarray  # (p,)
    chi2: float
    dof: int
    p_value: float  # of chi2 >= observed under the noise model
    scaled: bool  # covariance scaled by chi2 / dof
    verdict: str  # consistent | residuals_too_large | residuals_too_small
    correlations: tuple[tuple[str, str, float], ...]  # pairs above CORRELATION_REPORTED
    correlation: np.ndarray  # (p, p) over the base parameters, within [-1, 1]


def estimate(J: np.ndarray, r: np.ndarray, names: list[str]) -> Uncertainty:
    """Covariance of the parameters of the weighted Jacobian J (M, p) at the solution (or of its triangular factor R,
    R^T R = J^T J) from the weighted residuals r (M,)."""
    chi2 = float(r @ r)
    dof = max(len(r) - J.shape[1], 1)
    p_value = float(chdtrc(dof, chi2))
    scaled = p_value < NOISE_CHECK_LEVEL and chi2 > dof
    verdict = "residuals_too_large" if scaled else "residuals_too_small" if chdtr(dof, chi2) < NOISE_CHECK_LEVEL else "consistent"
    W = _root(J) * (np.sqrt(chi2 / dof) if scaled else 1.0)
    covariance = W @ W.T
    std = np.linalg.norm(W, axis=1)
    unit = W / np.where(std > 0, std, 1.0)[:, None]
    correlation = np.clip(unit @ unit.T, -1.0, 1.0)
    pairs = [
        (names[i], names[j], float(correlation[i, j]))
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if abs(correlation[i, j]) >= CORRELATION_REPORTED
    ]
    return Uncertainty(covariance, std, chi2, dof, p_value, scaled, verdict, tuple(pairs), correlation)


def _root(J: np.ndarray) -> np.ndarray:
    """W (p, k) with W W^T = pinv(J^T J): V S^-1 over the singular values above eps x size x the largest (the
    rank cutoff of numpy's matrix_rank; below it a direction is rounding, not data)."""
    _, singular, Vt = np.linalg.svd(J, full_matrices=False)
    kept = singular > np.finfo(float).eps * max(J.shape) * (singular[0] if len(singular) else 0.0)
    return Vt[kept].T / singular[kept]


def residual_stats(values: np.ndarray) -> dict:
    """STATS of the contract: n, rms, mean, std, max_abs."""
    values = np.asarray(values, dtype=float)
    if not len(values):
        return {"n": 0, "rms": 0.0, "mean": 0.0, "std": 0.0, "max_abs": 0.0}
    return {
        "n": int(len(values)),
        "rms": float(np.sqrt(np.mean(values**2))),
        "mean": float(np.mean(values)),
        "std": float(np.std(values)),
        "max_abs": float(np.max(np.abs(values))),
    }
