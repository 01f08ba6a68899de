"""The identification method a spec asks for: least squares, or Stone's features (with the least-squares fit beside them)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices import device_model
from armcal.identify.feature_method import feature_parameters
from armcal.identify.stone_features import FeatureIdentification
from armcal.identify.fit import FitResult, fit
from armcal.identify.problem import Problem
from armcal.spec.document import Spec


@dataclass(frozen=True)
class Identified:
    """The reported parameter values, and the least-squares fit behind or beside them."""

    theta: np.ndarray
    std: np.ndarray  # NaN where the method gives no uncertainty
    least_squares: FitResult
    features: FeatureIdentification | None = None
    feature_theta: np.ndarray | None = None

    @property
    def method(self) -> str:
        return "s_model_features" if self.features is not None else "least_squares"


def identify_parameters(spec: Spec, problem: Problem, raw: Measurements, start: np.ndarray | None = None) -> Identified:
    """Run ``spec.fit.method`` on a problem built from ``raw`` calibration data (least squares from ``start``)."""
    if spec.fit.method == "least_squares":
        result = fit(problem, spec.fit, start=start)
        return Identified(result.theta, result.std, result)
    points = device_model(spec, "points").prepare(raw)
    theta, found = feature_parameters(spec, points, problem.parameters)
    compared = fit(problem, spec.fit, start=start)  # the full least-squares fit beside them, from the spec's start
    return Identified(theta, np.full(len(theta), np.nan), compared, found, theta)
