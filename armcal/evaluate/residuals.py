"""Residual statistics in the instrument's unit, before and after the fit, and improvement factors."""

from __future__ import annotations

import numpy as np

from armcal.support.fileio import csv_text
from armcal.identify.problem import Problem
from armcal.identify.uncertainty import residual_stats
from armcal.support.units import ANGLE_UNITS, from_internal

ARCSEC = ANGLE_UNITS["arcsec"]


def residual_unit(reading_kind: str) -> tuple[str, str]:
    """(kind of the readings summarised, unit shown): angles in arc-seconds (a theodolite's), lengths in mm."""
    return ("angle", "arcsec") if reading_kind == "angle" else ("length", "mm")


def readings_residuals(problem: Problem, theta: np.ndarray, reading_kind: str) -> np.ndarray:
    """Predicted minus measured readings of the summarised kind, in the unit shown (spec pseudo-observations left out)."""
    return readings_by_sample(problem, theta, reading_kind)[0]


def readings_by_sample(problem: Problem, theta: np.ndarray, reading_kind: str) -> tuple[np.ndarray, np.ndarray]:
    """readings_residuals, and the sample (pose) each reading belongs to."""
    kind, unit = residual_unit(reading_kind)
    r, _ = problem.evaluate(theta)
    residual = problem.residuals
    chosen = (np.array(residual.kind) == kind) & (residual.sample >= 0)
    values = r[chosen] * residual.sigma[chosen]
    return (values / ARCSEC if unit == "arcsec" else values), residual.sample[chosen]


def reading_noise(problem: Problem, reading_kind: str) -> float:
    """The noise model's sigma of one summarised reading (RMS over the readings, in the unit shown): the resolution
    at which the certificate shows residual statistics."""
    kind, unit = residual_unit(reading_kind)
    residual = problem.residuals
    chosen = (np.array(residual.kind) == kind) & (residual.sample >= 0)
    sigma = float(np.sqrt(np.mean(residual.sigma[chosen] ** 2)))
    return sigma / ARCSEC if unit == "arcsec" else sigma


def before_after(problem: Problem, start: np.ndarray, theta: np.ndarray, reading_kind: str) -> dict:
    return {
        "before": residual_stats(readings_residuals(problem, start, reading_kind)),
        "after": residual_stats(readings_residuals(problem, theta, reading_kind)),
    }


POINT_CHANNELS = ("x", "y", "z")


def distance_errors(problem: Problem, theta: np.ndarray) -> np.ndarray | None:
    """Per pose, the 3D distance (mm) between measured and predicted point: None unless the instrument reads x, y, z."""
    r, _ = problem.evaluate(theta)
    residual = problem.residuals
    chosen = np.isin(np.array(residual.channel), POINT_CHANNELS) & (residual.sample >= 0)
    if not chosen.any():
        return None
    samples, slot = np.unique(residual.sample[chosen], return_inverse=True)
    squares = np.bincount(slot, (r[chosen] * residual.sigma[chosen]) ** 2)
    complete = np.bincount(slot) == len(POINT_CHANNELS)
    return np.sqrt(squares[complete])


def distance_stats(errors: np.ndarray) -> dict:
    """n, mean, rms, max of per-pose distance errors (what papers and peers report)."""
    if not len(errors):
        return {"n": 0, "mean": 0.0, "rms": 0.0, "max": 0.0}
    return {"n": int(len(errors)), "mean": float(np.mean(errors)), "rms": float(np.sqrt(np.mean(errors**2))), "max": float(np.max(errors))}


def distance_before_after(problem: Problem, start: np.ndarray, theta: np.ndarray) -> dict | None:
    before, after = distance_errors(problem, start), distance_errors(problem, theta)
    return None if before is None else {"before": distance_stats(before), "after": distance_stats(after)}


def residual_rows(problem: Problem, start: np.ndarray, theta: np.ndarray, lines: np.ndarray, units, label: str) -> list[list[str]]:
    """One row per reading: data set, data-file line, key, channel, unit, measured, residual before and after
    (predicted - measured), in the spec's units; the spec's pseudo-observations left out."""
    residual = problem.residuals
    before, _ = problem.evaluate(start)
    after, _ = problem.evaluate(theta)
    rows = []
    for i in np.flatnonzero(residual.sample >= 0):
        kind = residual.kind[i]
        unit = units.of(kind)
        shown = lambda value: f"{from_internal(float(value), kind, unit):.10g}"  # noqa: E731
        key = "-".join(str(part) for part in residual.key[i] if part is not None)
        sigma = residual.sigma[i]
        rows.append([label, str(int(lines[residual.sample[i]])), key, residual.channel[i], unit,
                     shown(residual.measured[i]), shown(before[i] * sigma), shown(after[i] * sigma)])
    return rows


RESIDUAL_COLUMNS = ("data", "line", "key", "channel", "unit", "measured", "residual_before", "residual_after")


def residuals_csv(calibrated, calibration_lines: np.ndarray, validation_lines: np.ndarray | None, units) -> str:
    """residuals.csv: every reading of the calibration and validation data with its residual before and after."""
    theta, start = calibrated.identified.theta, calibrated.start
    rows = residual_rows(calibrated.problem, start, theta, calibration_lines, units, "calibration")
    if calibrated.validation is not None:
        rows += residual_rows(calibrated.validation, start, theta, validation_lines, units, "validation")
    return csv_text([list(RESIDUAL_COLUMNS), *rows])


def improvement(pair: dict) -> float:
    """RMS before / RMS after."""
    after = pair["after"]["rms"]
    return float(pair["before"]["rms"] / after) if after > 0 else float("inf")
