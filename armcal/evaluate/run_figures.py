"""A run's figures from the stages' outputs, plain (internal units): statistics, identifiability, the fitted
parameters, diagnosis, evaluation. results/build.py assembles results.json from them."""

from __future__ import annotations

import numpy as np

from armcal.diagnose.causes import likely_causes
from armcal.evaluate.held_out_check import held_out_check
from armcal.diagnose.loop import Diagnosis
from armcal.diagnose.calibration import Calibration
from armcal.diagnose.loop import HOLDS_OUT
from armcal.diagnose.residual_model import CARRIED, OUTSIDE, Figures
from armcal.spec.learned import JOINT_UNIT
from armcal.evaluate.acceptance import acceptance_block
from armcal.devices.base import DeviceModel
from armcal.devices.registry import vocabulary
from armcal.effects.library import EffectSpec
from armcal.evaluate.features import evaluation
from armcal.evaluate.residuals import before_after, distance_before_after, improvement, reading_noise, readings_residuals, residual_unit
from armcal.identify.uncertainty import residual_stats
from armcal.kinematics.parallel_axes import parallel_axes
from armcal.kinematics.params import joint_kind
from armcal.spec import LoadedSpec
from armcal.support.units import from_internal


CHOSEN_ON = {
    "kfold": "the calibration data, by {folds}-fold cross-validation over its poses, a joint's effect over contiguous ranges of "
    "that joint's angle (the validation data did not choose)",
    "validation": "the validation data (diagnose.holdout: validation): its figures are not independent of that choice",
}


def reported_names(calibration: Calibration) -> set[str]:
    """Robot and device parameters, and those of the effects in the model (not the candidates left out)."""
    names = calibration.problem.parameters.names
    if calibration.diagnosis is None:
        return set(names)
    in_model = {p.name for e in calibration.diagnosis.in_model for p in e.parameters()}
    return {n for n in names if n.split(".")[0] not in vocabulary() or n in in_model}


def run_figures(
    loaded: LoadedSpec, calibration: Calibration, device: DeviceModel, raw_rows: np.ndarray, tasks: dict, evidence: dict | None, plots: list[str], measured: dict
) -> dict:
    """The figures results.json reports, by its keys; ``parameters`` as the fitted entries, values and standard
    deviations (internal units) with the base set and the held parameters' reasons; ``device``: the instrument's model."""
    spec = loaded.spec
    reading_kind = spec.device.reading_kind
    _, unit = residual_unit(reading_kind)
    problem, identified = calibration.problem, calibration.identified
    result = identified.least_squares
    start = calibration.start
    calibration_pair = before_after(problem, start, identified.theta, reading_kind)
    validation_pair = before_after(calibration.validation, start, identified.theta, reading_kind) if calibration.validation else None
    names = reported_names(calibration)
    identified_names = set(result.identifiability.base) if identified.features is None else _changed(problem, identified.theta)
    entries = [(e, v, s) for e, v, s in zip(problem.parameters.entries, identified.theta, identified.std) if e.name in names]
    ident = result.identifiability
    uncertainty = result.uncertainty
    outliers = raw_rows[problem.residuals.sample[result.outliers]] if len(result.outliers) else []
    return dict(
        status="converged" if identified.features is not None or result.solver.converged else "not_converged",
        unit=unit,
        noise_sigma=reading_noise(problem, reading_kind),
        identifiability={
            "n_parameters": len(entries),
            "rank": ident.rank,
            "free": list(ident.base),
            "fixed": [{"name": n, "reason": r} for n, r in ident.fixed if n in names],
            "condition_number": result.conditioning.condition_number,
            "observability_o1": ident.observability_o1,
            "unidentifiable": list(ident.unidentifiable),
            "design_point": _design_point(identified, start, problem),
            "flat_directions": list(result.conditioning.flat),
            "parallel_axes": [
                {"joints": (p.joint, p.joint + 1), "added": f"{p.name}.beta" if p.beta_added else None, "held": f"{p.name}.d" if p.d_held else None}
                for p in parallel_axes(spec.robot.chain())
            ],
        },
        parameters={"entries": [e for e, _, _ in entries], "values": np.array([v for _, v, _ in entries]), "std": np.array([s for _, _, s in entries]),
                    "identified": identified_names, "base": set(ident.base), "fixed": dict(ident.fixed)},
        residuals={"calibration": calibration_pair, "validation": validation_pair},
        residuals_3d=_distances(problem, calibration.validation, start, identified.theta),
        improvement_factor={
            "calibration": improvement(calibration_pair),
            "validation": improvement(validation_pair) if validation_pair else None,
        },
        diagnosis={
            **(diagnosis_block(loaded, calibration) if calibration.diagnosis else {"rounds": [], "added_effects": [], "unexplained": _unexplained(calibration, uncertainty)}),
            "evidence": evidence,
            "plots": plots,
        },
        evaluation={**evaluation(loaded, problem, identified, calibration.validation), **tasks},
        solver={
            "method": identified.method,
            "iterations": result.solver.iterations,
            "reason": result.solver.reason if identified.features is None else (
                f"closed-form feature identification (Stone 4.3); least squares beside it, from the spec's start: {result.solver.reason}"
            ),
            "loss": spec.fit.loss,
            "outliers": sorted(int(r) for r in set(np.asarray(outliers).tolist())),
        },
        noise=noise_block(loaded, calibration.noise) if calibration.noise else None,
        noise_check={"chi2": uncertainty.chi2, "dof": uncertainty.dof, "p_value": uncertainty.p_value, "covariance_scaled": uncertainty.scaled, "verdict": uncertainty.verdict,
                     "causes": likely_causes(loaded, calibration, device)},
        correlations=[list(c) for c in uncertainty.correlations],
        correlation_matrix={"parameters": list(ident.base), "matrix": uncertainty.correlation.tolist()},
        campaign=measured,
        acceptance=acceptance_block(spec.acceptance, calibration.validation, identified.theta, reading_kind),
        held_out_check=held_out_check(problem, calibration.validation, result, identified.theta) if identified.features is None else None,
        residual_model=residual_model_block(loaded, calibration),
    )


def _unexplained(calibration: Calibration, uncertainty) -> bool:
    """No diagnosis ran: the residuals exceed the noise model, or (noise estimated) the data reject a declared sigma as
    too small."""
    too_small = calibration.noise is not None and any(g.test.verdict == "declared_too_small" for g in calibration.noise.rejected)
    return bool(uncertainty.scaled) or too_small


def noise_block(loaded: LoadedSpec, noise) -> dict:
    """results.json's noise: each estimated group's sigma in the spec's unit, its uncertainty, and its test."""
    units = loaded.spec.robot.units
    shown = lambda value, kind: from_internal(value, kind, units.of(kind))  # noqa: E731
    return {
        "method": noise.method,
        "rounds": noise.rounds,
        "converged": noise.converged,
        "groups": [
            {
                "group": g.group,
                "field": g.field,
                "unit": units.of(g.kind),
                "readings": g.readings,
                "redundancy": g.redundancy,
                "sigma": shown(g.sigma, g.kind),
                "std": shown(g.std, g.kind),
                "interval": [shown(v, g.kind) for v in g.interval],
                "declared": None if g.declared is None else shown(g.declared, g.kind),
                "test": None if g.test is None else {"statistic": g.test.statistic, "dof": g.test.dof, "p_value": g.test.p_value, "verdict": g.test.verdict},
            }
            for g in noise.groups
        ],
    }


def _distances(problem, validation, start: np.ndarray, theta: np.ndarray) -> dict | None:
    """Per-pose 3D distance statistics (mm) before and after, where the instrument measures points."""
    calibration = distance_before_after(problem, start, theta)
    if calibration is None:
        return None
    return {"unit": "mm", "calibration": calibration, "validation": distance_before_after(validation, start, theta) if validation else None}


def _design_point(identified, start: np.ndarray, problem) -> str:
    """Where the base set was decided: the features' model, the registered start or the nominal (a contact
    instrument's at the data's poses moved into the nominal model's contacts)."""
    if identified.features is not None:
        return "Stone's feature identification"
    point = "nominal, instrument registered" if not np.array_equal(start, problem.parameters.nominal) else "nominal"
    return point + (", poses moved into contact" if problem.design is not None else "")


def _changed(problem, theta: np.ndarray) -> set[str]:
    """Parameters a method moved from their nominal values."""
    return {e.name for e, v in zip(problem.parameters.entries, theta) if v != e.nominal}


def effect_result(loaded: LoadedSpec, effect: EffectSpec, problem, theta: np.ndarray, std: np.ndarray) -> dict:
    """EFFECT of the contract, values in the spec's units."""
    parameters = []
    for p in effect.parameters():
        i = problem.parameters.index(p.name)
        unit = loaded.spec.robot.units.of(p.kind)
        shown = lambda v: None if v is None or np.isnan(v) else from_internal(float(v), p.kind, unit)  # noqa: E731
        parameters.append({"name": p.name, "value": shown(theta[i]), "std": shown(std[i]), "unit": unit})
    return {"type": effect.type, "joint": effect.joint, "order": effect.order, "parameters": parameters,
            "from_joint": effect.source_joint, "form": effect.form}


def diagnosis_block(loaded: LoadedSpec, calibration: Calibration) -> dict:
    diagnosis: Diagnosis = calibration.diagnosis
    reading_kind = loaded.spec.device.reading_kind
    problem, validation = calibration.problem, calibration.validation
    final_std = calibration.identified.std
    rms = lambda pr, theta: residual_stats(readings_residuals(pr, theta, reading_kind))["rms"] if pr else None  # noqa: E731
    rounds = []
    for round_ in diagnosis.rounds:
        rounds.append(
            {
                "candidates": [
                    {
                        "effect": t.effect.type,
                        "id": t.effect.id,
                        "joint": t.effect.joint,
                        "order": t.effect.order,
                        "from_joint": t.effect.source_joint,
                        "statistic": t.statistic,
                        "dof": t.dof,
                        "p_value": t.p_value,
                        "distinguishable": t.distinguishable,
                        "significant": t.significant,
                    }
                    for t in sorted(round_.tests, key=lambda t: -t.statistic)
                ],
                "accepted": effect_result(loaded, round_.accepted, problem, round_.theta_after, final_std) if round_.accepted else None,
                "note": round_.note,
                "partly_explained": round_.partly_explained,
                "rms_before": {"calibration": rms(problem, round_.theta_before), "validation": rms(validation, round_.theta_before)},
                "rms_after": {"calibration": rms(problem, round_.theta_after), "validation": rms(validation, round_.theta_after)},
            }
        )
    theta = calibration.identified.theta
    return {
        "rounds": rounds,
        "added_effects": [effect_result(loaded, e, problem, theta, final_std) for e in diagnosis.added],
        "unexplained": diagnosis.unexplained,
        "chosen_on": CHOSEN_ON[diagnosis.chosen_on].format(folds=loaded.spec.diagnose.folds),
        "alpha": loaded.spec.diagnose.alpha,
    }


def residual_model_block(loaded: LoadedSpec, calibration: Calibration) -> dict | None:
    """results.json's residual_model: the learned model's test on the k-fold folds, its held-out and validation
    figures without and with it (mm, deg), its hyperparameters and the predictions outside the calibrated region."""
    judgement = calibration.residual
    if judgement is None:
        return None
    res = calibration.problem.residuals
    kinds = dict(zip(res.channel, res.kind))
    unit = lambda name: "deg" if kinds.get(name) == "angle" else "mm"  # noqa: E731
    shown = lambda name, v: float(from_internal(v, "angle", "deg")) if unit(name) == "deg" else float(v)  # noqa: E731

    def figures(f: Figures | None) -> dict | None:
        if f is None:
            return None
        rows = [{"coordinate": n, "unit": unit(n), "physical": shown(n, f.rms_physical[n]), "learned": shown(n, f.rms_learned[n])}
                for n in f.rms_physical]
        three = {"rms_3d_physical": f.rms_3d[0], "rms_3d_learned": f.rms_3d[1]} if f.rms_3d else {}
        return {"per_coordinate": rows, **three, "outside": f.outside, "readings": f.readings}

    return {
        "kind": "gp",
        "accepted": judgement.accepted,
        "z": judgement.z,
        "threshold": HOLDS_OUT,
        "folds": loaded.spec.diagnose.folds,
        "folds_along_joint": judgement.along,
        "held_out": figures(judgement.held_out),
        "validation": figures(calibration.residual_validation),
        "outside_fraction": OUTSIDE,
        "joint_units": [JOINT_UNIT[joint_kind(j.type)] for j in loaded.spec.robot.joints],
        "hyperparameters": [
            {"coordinate": n, "at": at, "unit": unit(n), "signal_std": shown(n, float(np.sqrt(m.constant))), "noise_std": shown(n, float(np.sqrt(m.noise))),
             "length_scales": [float(v) for v in m.length_scales], "training_readings": len(m.y)}
            for (n, at), m in judgement.model.coordinates.items()
        ],
        "seconds": judgement.seconds,
        "carried": CARRIED,
        "model": [m.carried() for m in judgement.model.coordinates.values()] if judgement.accepted else None,
    }
