"""Levenberg-Marquardt with Marquardt's scaling, Goswami (5)-(10).

Step: (J^T W J + lambda D) dp = -J^T W r with D = diag(J^T W J) (Marquardt's
scaling of (7), which makes the step independent of parameter units); lambda
shrinks after a step that lowers the cost and grows after one that does not.
A robust loss (Huber or Cauchy, as iteratively reweighted least squares)
down-weights outliers.

The fit has reached a minimum when one of three scale-free tests holds (none
depends on the parameters' units or on the size of the residuals, so neither on
the noise level declared):
- scaled gradient: max_i |g_i| / (sqrt(A_ii) sqrt(2 cost)) <= GTOL, the cosine
  between the residual vector and every Jacobian column (MINPACK's gtol): no
  parameter can move the residuals towards smaller values;
- relative cost decrease: an accepted step lowered the cost by at most FTOL of
  it and the linear model predicted no more (MINPACK's ftol);
- scaled step: max_i |dp_i| sqrt(A_ii) / sqrt(2 cost) <= XTOL, no parameter's
  step changes the residual vector by more than XTOL of its length.
When no step lowers the cost at any lambda, the fit has converged if the
Gauss-Newton model predicts no decrease above FTOL of the cost (the minimum to
rounding), else it has not. The iteration limit is a safety net that a fit
converging normally does not meet; reaching it is reported as not converged.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

GTOL = 1e-8  # cosine between the residual vector and any Jacobian column
FTOL = 1e-10  # relative cost decrease, actual and predicted
XTOL = 1e-8  # step, as the change of the residual vector it makes, relative to that vector's length


@dataclass(frozen=True)
class LMResult:
    x: np.ndarray
    cost: float  # 1/2 sum w r^2 at x
    iterations: int
    converged: bool
    reason: str
    weights: np.ndarray  # robust-loss weights of the residuals at x (1 for the linear loss)


def robust_weights(r: np.ndarray, loss: str, scale: float) -> np.ndarray:
    """IRLS weights: Huber w = min(1, k/|r|), Cauchy w = 1 / (1 + (r/k)^2)."""
    if loss == "huber":
        return np.minimum(1.0, scale / np.maximum(np.abs(r), 1e-300))
    if loss == "cauchy":
        return 1.0 / (1.0 + (r / scale) ** 2)
    return np.ones_like(r)


def scaled_gradient(g: np.ndarray, A: np.ndarray, cost: float) -> float:
    """max_i |g_i| / (sqrt(A_ii) sqrt(2 cost)): 0 at a minimum, 1 when a column points along the residuals."""
    norms = np.sqrt(np.maximum(np.diag(A), 0.0)) * np.sqrt(2.0 * cost)
    with np.errstate(divide="ignore", invalid="ignore"):
        cosines = np.where(norms > 0, np.abs(g) / norms, 0.0)
    return float(np.max(cosines)) if len(cosines) else 0.0


def solve(
    residuals: Callable[..., tuple[np.ndarray, np.ndarray]],
    x0: np.ndarray,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    loss: str = "linear",
    loss_scale: float = 3.0,
    max_iterations: int = 100,
    initial: tuple[np.ndarray, np.ndarray] | None = None,
    buffered: bool = False,
) -> tuple[LMResult, np.ndarray, np.ndarray]:
    """Minimise 1/2 sum w(r) r(x)^2 (``residuals(x)`` returns (r, J)): the result, with (r, J) at the solution;
    ``initial``: (r, J) at x0 when the caller has them.

    ``buffered``: ``residuals(x, out)`` writes J into ``out`` (None: a fresh array), a Jacobian a rejected trial
    left; so the fit holds two Jacobians at most, the accepted one and the trial's, and none is copied."""
    x = np.asarray(x0, dtype=float).copy()
    lower = np.full_like(x, -np.inf) if lower is None else lower
    upper = np.full_like(x, np.inf) if upper is None else upper
    evaluate = (lambda x, out: residuals(x, out)) if buffered else (lambda x, out: residuals(x))  # noqa: E731
    r, J = evaluate(x, None) if initial is None else initial
    spare = None
    w = robust_weights(r, loss, loss_scale)
    cost = 0.5 * float(np.sum(w * r**2))
    lam = 1e-3
    for iteration in range(1, max_iterations + 1):
        if loss == "linear":  # w = 1: no weighted copy of J
            A, g = J.T @ J, J.T @ r
        else:
            JW = J * w[:, None]
            A, g = JW.T @ J, JW.T @ r
            del JW
        if cost == 0.0:
            return LMResult(x, cost, iteration - 1, True, "the model reproduces every reading exactly", w), r, J
        gradient = scaled_gradient(g, A, cost)
        if gradient <= GTOL:
            return LMResult(x, cost, iteration - 1, True, f"scaled gradient {gradient:.1e} below {GTOL:g}", w), r, J
        largest = float(np.max(np.diag(A))) if len(A) else 0.0
        D = np.maximum(np.diag(A), 1e-12 * largest if largest > 0 else 1.0)  # relative floor: scale-free
        while True:
            try:
                step = -np.linalg.solve(A + lam * np.diag(D), g)  # (10) with Marquardt's scaling
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            x_new = np.clip(x + step, lower, upper)
            r_new, J_new = evaluate(x_new, spare)
            cost_new = 0.5 * float(np.sum(w * r_new**2))
            if np.isfinite(cost_new) and cost_new <= cost:
                break
            spare = J_new if buffered else None
            lam *= 4.0
            if lam > 1e16:
                predicted = 0.5 * float(g @ np.linalg.pinv(A) @ g)
                if predicted <= FTOL * cost:
                    return LMResult(x, cost, iteration, True, "at the minimum to rounding (no step lowers the cost)", w), r, J
                return LMResult(x, cost, iteration, False, "no step lowers the cost (lambda exhausted)", w), r, J
        taken = x_new - x
        predicted = -float(g @ taken) - 0.5 * float(taken @ A @ taken)
        decrease = cost - cost_new
        scaled_step = float(np.max(np.abs(taken) * np.sqrt(np.diag(A)))) / max(np.sqrt(2.0 * cost), 1e-300) if len(taken) else 0.0
        spare = J if buffered else None
        x, r, J = x_new, r_new, J_new
        w = robust_weights(r, loss, loss_scale)
        cost = 0.5 * float(np.sum(w * r**2))
        lam = max(lam / 5.0, 1e-12)
        if scaled_step <= XTOL:
            return LMResult(x, cost, iteration, True, f"scaled step {scaled_step:.1e} below {XTOL:g}", w), r, J
        if loss == "linear" and decrease <= FTOL * cost_new and predicted <= FTOL * cost_new:
            return LMResult(x, cost, iteration, True, f"relative cost decrease below {FTOL:g}", w), r, J
    return LMResult(x, cost, max_iterations, False, f"iteration limit ({max_iterations}) reached before a minimum", w), r, J
