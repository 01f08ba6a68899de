"""Do the held-out data agree with the calibrated model? And when they do not, why.

A calibration can match its own data to the noise and still predict held-out
readings poorly. Two reasons can be told apart with what the run has:

- the parameters' own uncertainty: the calibration poses leave a direction of the
  parameters poorly determined (a flat direction of the base Jacobian), so the
  prediction at held-out poses carries the covariance C of the base parameters,
  J_v C J_v' (the linearised propagation behind Stone's 7.4 spreads), plus G G' where
  held-out stations are re-registered from their own readings (identify/heldout.py); the
  weighted held-out residuals are expected with covariance S = I + J_v C J_v' + G G': the
  residuals are weighted by the noise that is known (the declared sigmas, or those
  estimated from the data where the spec says auto), never by a noise scaled by the
  fit's own chi2, so "noise sigmas" are those sigmas (C itself is the reported one,
  scaled by chi2/dof where the noise check found the residuals too large: then the
  held-out data usually exceed the prediction too, and the terminal names the declared
  noise first among the causes);
- something the calibration data do not contain: the held-out residuals exceed even
  that expectation (r' S^-1 r, chi2 with n degrees of freedom on the n held-out
  readings, tested at NOISE_CHECK_LEVEL). The parameters' error is one draw shared by
  every held-out reading: summing r_i^2 / S_ii instead would count a flat direction's
  one degree of freedom n times, and the verdict would turn on that draw alone:
  the instrument moved, a parameter only the held-out data use is held at a wrong
  value (an extension rod's length, another target), or an effect the calibration
  poses cannot see.

The first is said when the held-out RMS is more than twice the noise and most of
it is the parameters' uncertainty: add poses that move the flat direction
(`armcal plan --extend`), or hold values known from a measurement.
"""

from __future__ import annotations

import numpy as np
from scipy.special import chdtrc

from armcal.identify.fit import FitResult
from armcal.identify.problem import Problem
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL

NOISE_MULTIPLE = 2.0  # held-out RMS over the noise's above which a poor prediction is explained
PARAMETER_SHARE = 0.5  # share of the expected held-out variance from the parameters' uncertainty that names it


def held_out_check(calibration: Problem, validation: Problem | None, result: FitResult, theta: np.ndarray) -> dict | None:
    """The held-out chi2 against noise plus propagated parameter uncertainty, and a verdict (None without held-out data)."""
    if validation is None:
        return None
    r, J = validation.evaluate(theta)
    if not len(r):
        return None
    uncertainty = result.uncertainty
    A = J[:, result.base]
    propagated = np.einsum("ij,jk,ik->i", A, uncertainty.covariance, A)
    G = validation.registration_noise(theta)
    expected = 1.0 + propagated + np.sum(G**2, axis=1)  # noise sigmas squared (module docstring)
    chi2 = _chi2(r, A, uncertainty.covariance, G)
    dof = len(r)
    p_value = float(chdtrc(dof, chi2))
    share = float(propagated.sum() / expected.sum())
    multiple = float(np.sqrt(np.mean(r**2)))
    only_held_out = _only_held_out(calibration, validation, J, theta)
    if p_value < NOISE_CHECK_LEVEL:
        verdict = "beyond_prediction"
    elif multiple > NOISE_MULTIPLE and share > PARAMETER_SHARE:
        verdict = "parameter_uncertainty"
    else:
        verdict = "consistent"
    return {
        "chi2": chi2,
        "dof": dof,
        "p_value": p_value,
        "rms_over_noise": multiple,
        "expected_rms_over_noise": float(np.sqrt(np.mean(expected))),
        "parameter_share": share,
        "held_out_only": only_held_out,
        "verdict": verdict,
    }


def _chi2(r: np.ndarray, A: np.ndarray, covariance: np.ndarray, G: np.ndarray | None = None) -> float:
    """r' S^-1 r with S = I + A C A' + G G' (n x n, never formed): C = V L V', B = [A V L^1/2, G], and by Woodbury
    S^-1 = I - B (I + B'B)^-1 B', a solve of the size of the base parameters plus 6 per re-registered station."""
    values, vectors = np.linalg.eigh((covariance + covariance.T) / 2)
    B = A @ (vectors * np.sqrt(np.clip(values, 0.0, None)))
    B = B if G is None else np.hstack([B, G])
    Br = B.T @ r
    inner = np.linalg.solve(np.eye(B.shape[1]) + B.T @ B, Br)
    return float(r @ r - Br @ inner)


def _only_held_out(calibration: Problem, validation: Problem, J: np.ndarray, theta: np.ndarray) -> list[str]:
    """Parameters the held-out readings depend on and the calibration readings do not (held at their spec value)."""
    _, Jc = calibration.evaluate(theta)
    used = np.any(J != 0, axis=0) & ~np.any(Jc != 0, axis=0)
    return [calibration.parameters.names[i] for i in np.flatnonzero(used)]
