"""One fit: base parameter set at the nominal, Levenberg-Marquardt on it, uncertainty at the solution."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.identify.identifiability import Identifiability, analyse
from armcal.identify.lm import LMResult, levenberg_marquardt
from armcal.identify.problem import Problem
from armcal.identify.uncertainty import Uncertainty, estimate
from armcal.spec.sections import Fit

OUTLIER_WEIGHT = 0.5  # robust weight below which a residual is listed as an outlier


@dataclass(frozen=True)
class FitResult:
    theta: np.ndarray  # all parameters, identified ones updated
    start: np.ndarray
    base: np.ndarray  # indices of the identified parameters in theta
    identifiability: Identifiability
    uncertainty: Uncertainty
    solver: LMResult
    outliers: np.ndarray  # residual indices the robust loss down-weighted

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of every parameter (NaN where not identified)."""
        out = np.full(len(self.theta), np.nan)
        out[self.base] = self.uncertainty.std
        return out


def fit(problem: Problem, settings: Fit, start: np.ndarray | None = None) -> FitResult:
    """Identify the base parameters of ``problem`` from ``start`` (default: the nominal)."""
    parameters = problem.parameters
    theta0 = parameters.nominal if start is None else np.asarray(start, dtype=float)
    _, J0 = problem.evaluate(theta0)
    identifiability = analyse(J0, parameters, parameters.free)
    base = np.array([parameters.index(name) for name in identifiability.base], dtype=int)
    lower = np.array([e.lower if e.lower is not None else -np.inf for e in parameters.entries])[base]
    upper = np.array([e.upper if e.upper is not None else np.inf for e in parameters.entries])[base]

    def residuals(x: np.ndarray):
        theta = theta0.copy()
        theta[base] = x
        r, J = problem.evaluate(theta)
        return r, J[:, base]

    solver = levenberg_marquardt(
        residuals, theta0[base], lower, upper, settings.loss, settings.loss_scale, settings.max_iterations
    )
    theta = theta0.copy()
    theta[base] = solver.x
    r, J = residuals(solver.x)
    weights = np.sqrt(solver.weights)
    uncertainty = estimate(J * weights[:, None], r * weights, list(identifiability.base))
    outliers = np.flatnonzero(solver.weights < OUTLIER_WEIGHT)
    return FitResult(theta, theta0, base, identifiability, uncertainty, solver, outliers)
