"""One fit: the base parameter set of the design, Levenberg-Marquardt on it, uncertainty at the solution.

The base set is decided at the design point (``design_identifiability``) and
handed to every later fit of the same model and campaign design (refits of the
diagnosis, k-fold folds, Monte-Carlo robots); a fit never decides it again at a
fitted point (identifiability.py says why).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.identify.identifiability import Conditioning, Identifiability, analyse, conditioning, triangular
from armcal.identify.lm import LMResult, solve
from armcal.identify.problem import Problem
from armcal.identify.uncertainty import Uncertainty, estimate
from armcal.spec.sections import Fit

OUTLIER_WEIGHT = 0.5  # robust weight below which a residual is listed as an outlier


@dataclass(frozen=True)
class FitResult:
    theta: np.ndarray  # all parameters, identified ones updated
    start: np.ndarray
    base: np.ndarray  # indices of the identified parameters in theta
    identifiability: Identifiability  # decided at the design point
    conditioning: Conditioning  # of the scaled base Jacobian at the solution
    uncertainty: Uncertainty
    solver: LMResult
    outliers: np.ndarray  # residual indices the robust loss down-weighted
    at_solution: tuple[np.ndarray, np.ndarray]  # (r, J over the base columns) at theta, where a later fit from theta starts

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of every parameter (NaN where not identified)."""
        out = np.full(len(self.theta), np.nan)
        out[self.base] = self.uncertainty.std
        return out


def design_identifiability(problem: Problem, design: np.ndarray, hold_weak: bool = True) -> Identifiability:
    """The base set of ``problem``'s free parameters at the design point ``design`` (identifiability.analyse)."""
    return analyse(problem.design_jacobian(design), problem.parameters, problem.parameters.free, hold_weak)


def fit(
    problem: Problem,
    settings: Fit,
    start: np.ndarray | None = None,
    identifiability: Identifiability | None = None,
    initial: tuple[np.ndarray, np.ndarray] | None = None,
) -> FitResult:
    """Identify the base parameters of ``problem`` from ``start`` (default: the nominal).

    ``identifiability`` is the design's base set; without it, ``start`` is the design point. ``initial``: (r, J over
    the base columns) at ``start`` when the caller has them (a fit from where another ended, FitResult.at_solution).
    """
    identifiability, theta0, theta, base, solver, r, J = _solved(problem, settings, start, identifiability, initial)
    if np.all(solver.weights == 1.0):  # the linear loss: J and r are the weighted ones
        weighted, r_weighted = J, r
    else:
        weights = np.sqrt(solver.weights)
        weighted, r_weighted = J * weights[:, None], r * weights
    R = triangular(weighted)  # J^T J = R^T R: all the uncertainty and the conditioning need of J
    uncertainty = estimate(R, r_weighted, list(identifiability.base))
    outliers = np.flatnonzero(solver.weights < OUTLIER_WEIGHT)
    return FitResult(theta, theta0, base, identifiability, conditioning(R, list(identifiability.base)), uncertainty, solver, outliers, (r, J))


def fit_theta(
    problem: Problem, settings: Fit, start: np.ndarray, identifiability: Identifiability, initial: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """The parameters ``fit`` identifies, without their uncertainty at the solution (a k-fold fold's fit, of which
    only the parameters are used)."""
    return _solved(problem, settings, start, identifiability, initial)[2]


def _solved(problem: Problem, settings: Fit, start: np.ndarray | None, identifiability: Identifiability | None, initial) -> tuple:
    """Levenberg-Marquardt on the base parameters (fit's arguments): the base set, the start, the solution (all
    parameters), the base columns, the solver's result and (r, J) at the solution."""
    parameters = problem.parameters
    theta0 = parameters.nominal if start is None else np.asarray(start, dtype=float)
    design = None
    if identifiability is None:  # the design point is the start: its evaluation serves both
        design = problem.evaluate(theta0)
        identifiability = analyse(design[1] if problem.design is None else problem.design_jacobian(theta0), parameters, parameters.free)
    base = np.array([parameters.index(name) for name in identifiability.base], dtype=int)
    if design is not None:
        initial = (design[0], design[1][:, base])
    del design  # the Jacobian of every parameter: only its base columns are kept
    lower = np.array([e.lower if e.lower is not None else -np.inf for e in parameters.entries])[base]
    upper = np.array([e.upper if e.upper is not None else np.inf for e in parameters.entries])[base]

    def residuals(x: np.ndarray, out: np.ndarray | None = None):
        theta = theta0.copy()
        theta[base] = x
        return problem.evaluate(theta, base, out)

    limit = settings.max_iterations
    solver, r, J = solve(residuals, theta0[base], lower, upper, settings.loss, settings.loss_scale, limit, initial, buffered=True)
    theta = theta0.copy()
    theta[base] = solver.x
    return identifiability, theta0, theta, base, solver, r, J
