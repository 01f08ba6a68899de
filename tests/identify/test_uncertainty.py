"""identify/uncertainty.estimate on ill-conditioned Jacobians (issue 29 item 2): the covariance from J's singular
values, never from inverting J^T J, agrees with a 60-digit computation (mpmath) of pinv(J^T J) for the same J, and
its correlations lie within [-1, 1] where the J^T J route left them (condition numbers of 1e5 to 1e8, as the real
campaigns of robots whose first joint barely moves give)."""

import mpmath
import numpy as np
import pytest

from armcal.identify.uncertainty import estimate


def _ill_conditioned(condition: float, seed: int) -> np.ndarray:
    """A weighted Jacobian (80, 6) whose two last columns are nearly the same direction (condition number given)."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(80, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    return (Q * np.geomspace(1.0, 1.0 / condition, 6)) @ V.T * 40.0


def _exact_covariance(J: np.ndarray) -> np.ndarray:
    """(J^T J)^-1 of the float matrix J, in 60 significant digits."""
    mpmath.mp.dps = 60
    A = mpmath.matrix(J.tolist())
    return np.array((A.T * A) ** -1, dtype=float)


@pytest.mark.parametrize("condition, seed", [(1e5, 0), (1e6, 1), (1e7, 2), (1e8, 3)])
def test_the_covariance_agrees_with_sixty_digits_and_correlations_stay_within_one(condition, seed):
    J = _ill_conditioned(condition, seed)
    r = np.random.default_rng(seed + 10).normal(size=len(J))
    exact = _exact_covariance(J)
    found = estimate(J, r, [f"p{i}" for i in range(6)])
    # the singular value decomposition's backward error is a few units of the last place of ||J||: relative to the
    # covariance's scale that is the condition number times eps, the bound of any method that starts from J
    bound = 50 * condition * np.finfo(float).eps
    std = np.sqrt(np.diag(exact))
    assert np.abs(found.covariance - exact).max() <= bound * std.max() ** 2
    assert np.allclose(found.std, std, rtol=bound)
    correlation = exact / np.outer(std, std)
    assert found.correlations  # the flat direction correlates the parameters beyond CORRELATION_REPORTED
    for a, b, value in found.correlations:
        assert -1.0 <= value <= 1.0
        assert value == pytest.approx(correlation[int(a[1]), int(b[1])], abs=bound)


def test_the_route_through_j_transpose_j_is_what_broke_the_bounds():
    """The oracle can fail: pinv(J^T J) at a condition number of 1e8 is off from 60 digits by far more than the
    bound above (its error grows with the condition number squared)."""
    J = _ill_conditioned(1e8, 3)
    exact = _exact_covariance(J)
    squared = np.linalg.pinv(J.T @ J)
    assert not np.allclose(np.sqrt(np.diag(squared)), np.sqrt(np.diag(exact)), rtol=50 * 1e8 * np.finfo(float).eps)
