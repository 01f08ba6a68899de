"""Levenberg-Marquardt with Marquardt's scaling, Goswami (5)-(10).

Step: (J^T W J + lambda D) dp = -J^T W r with D = diag(J^T W J) (Marquardt's
scaling of (7), which makes the step independent of parameter units); lambda
shrinks after a step that lowers the cost and grows after one that does not.
Stops on a small step, a small gradient or a stalled cost; at the iteration
limit the last iterate is kept and the status says why. A robust loss (Huber
or Cauchy, as iteratively reweighted least squares) down-weights outliers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


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


def levenberg_marquardt(
    residuals: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x0: np.ndarray,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    loss: str = "linear",
    loss_scale: float = 3.0,
    max_iterations: int = 100,
    xtol: float = 1e-10,
    gtol: float = 1e-10,
    ftol: float = 1e-12,
) -> LMResult:
    """Minimise 1/2 sum w(r) r(x)^2; ``residuals(x)`` returns (r, J)."""
    x = np.asarray(x0, dtype=float).copy()
    lower = np.full_like(x, -np.inf) if lower is None else lower
    upper = np.full_like(x, np.inf) if upper is None else upper
    r, J = residuals(x)
    w = robust_weights(r, loss, loss_scale)
    cost = 0.5 * float(np.sum(w * r**2))
    lam = 1e-3
    for iteration in range(1, max_iterations + 1):
        JW = J * w[:, None]
        A = JW.T @ J
        g = JW.T @ r
        if np.max(np.abs(g)) <= gtol * max(1.0, cost):
            return LMResult(x, cost, iteration - 1, True, "gradient below tolerance", w)
        D = np.maximum(np.diag(A), 1e-12 * max(1.0, np.max(np.diag(A))))
        while True:
            try:
                step = -np.linalg.solve(A + lam * np.diag(D), g)  # (10) with Marquardt's scaling
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            x_new = np.clip(x + step, lower, upper)
            r_new, J_new = residuals(x_new)
            cost_new = 0.5 * float(np.sum(w * r_new**2))
            if np.isfinite(cost_new) and cost_new <= cost:
                break
            lam *= 4.0
            if lam > 1e16:
                return LMResult(x, cost, iteration, False, "no step lowers the cost (lambda exhausted)", w)
        small_step = np.linalg.norm(x_new - x) <= xtol * (np.linalg.norm(x) + xtol)
        stalled = cost - cost_new <= ftol * max(cost, 1e-300)
        x, r, J = x_new, r_new, J_new
        w = robust_weights(r, loss, loss_scale)
        cost = 0.5 * float(np.sum(w * r**2))
        lam = max(lam / 5.0, 1e-12)
        if small_step:
            return LMResult(x, cost, iteration, True, "step below tolerance", w)
        if stalled and loss == "linear":
            return LMResult(x, cost, iteration, True, "cost no longer decreases", w)
    return LMResult(x, cost, max_iterations, False, f"iteration limit ({max_iterations}) reached", w)
