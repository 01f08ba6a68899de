"""Residual statistics in the instrument's unit, before and after the fit, and improvement factors."""

from __future__ import annotations

import numpy as np

from armcal.identify.problem import Problem
from armcal.identify.uncertainty import residual_stats
from armcal.units import ANGLE_UNITS

ARCSEC = ANGLE_UNITS["arcsec"]


def residual_unit(device_type: str) -> tuple[str, str]:
    """(kind of the readings summarised, unit shown): angles in arc-seconds for theodolites, else mm."""
    return ("angle", "arcsec") if device_type == "theodolite" else ("length", "mm")


def readings_residuals(problem: Problem, theta: np.ndarray, device_type: str) -> np.ndarray:
    """Predicted minus measured readings of the summarised kind, in the unit shown (spec pseudo-observations left out)."""
    kind, unit = residual_unit(device_type)
    r, _ = problem.evaluate(theta)
    residual = problem.residuals
    chosen = (np.array(residual.kind) == kind) & (residual.sample >= 0)
    values = r[chosen] * residual.sigma[chosen]
    return values / ARCSEC if unit == "arcsec" else values


def before_after(problem: Problem, start: np.ndarray, theta: np.ndarray, device_type: str) -> dict:
    return {
        "before": residual_stats(readings_residuals(problem, start, device_type)),
        "after": residual_stats(readings_residuals(problem, theta, device_type)),
    }


def improvement(pair: dict) -> float:
    """RMS before / RMS after."""
    after = pair["after"]["rms"]
    return float(pair["before"]["rms"] / after) if after > 0 else float("inf")
