"""The evaluation block of results.json: Stone's feature method beside the least-squares fit."""

from __future__ import annotations

import numpy as np

from armcal.evaluate.residuals import before_after
from armcal.support.units import from_internal


def evaluation(loaded, problem, identified, validation_problem) -> dict:
    """For ``s_model_features``: each joint's features and accuracy (6.11-6.13), pseudo-DH table,
    and residuals of the features' parameters against the least-squares fit started from them."""
    if identified.features is None:
        return {}
    spec = loaded.spec
    units = spec.robot.units
    reading_kind = spec.device.reading_kind
    length = lambda v: from_internal(float(v), "length", units.length)  # noqa: E731
    angle = lambda v: from_internal(float(v), "angle", units.angle)  # noqa: E731
    joints = [
        {
            "joint": f.joint,
            "radius": length(f.radius),
            "range_deg": f.range_deg,
            "normal_residual_std": length(np.std(f.normal_residuals)),
            "radial_residual_std": length(np.std(f.radial_residuals)),
            "plane_sigma": angle(f.sigma_plane),
            "centre_sigma": length(f.sigma_centre),
        }
        for f in identified.features.features
    ]
    table = [
        {"joint": i, "theta_offset": angle(r.theta), "d": length(r.d), "a": length(r.a), "alpha": angle(r.alpha)}
        for i, r in enumerate(identified.features.pseudo_dh.rows, start=1)
    ]
    least_squares = identified.least_squares.theta
    comparison = {
        "s_model_features": before_after(problem, problem.parameters.nominal, identified.theta, reading_kind)["after"],
        "least_squares": before_after(problem, problem.parameters.nominal, least_squares, reading_kind)["after"],
    }
    if validation_problem is not None:
        comparison["validation"] = {
            "s_model_features": before_after(validation_problem, identified.theta, identified.theta, reading_kind)["after"],
            "least_squares": before_after(validation_problem, least_squares, least_squares, reading_kind)["after"],
        }
    return {"s_model_features": {"units": {"length": units.length, "angle": units.angle}, "joints": joints, "pseudo_dh": table, "residuals": comparison}}
