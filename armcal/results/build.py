"""Assemble results.json from the stages' plain outputs (values in the spec's units)."""

from __future__ import annotations

import math

import numpy as np

from armcal import __version__
from armcal.results.breakdown import after_fit
from armcal.results.campaign_block import report_fields
from armcal.results.plausibility import plausibility
from armcal.results.schema import Results
from armcal.results.provenance import git_info, utc_now
from armcal.spec import LoadedSpec
from armcal.spec.placeholders import placeholders
from armcal.spec.sections import STANDS_FOR
from armcal.support.units import from_internal


def parameter_rows(loaded: LoadedSpec, entries, values: np.ndarray, std: np.ndarray, identified: set[str]) -> list[dict]:
    rows = []
    for entry, value, sd in zip(entries, values, std):
        unit = loaded.spec.robot.units.of(entry.kind)
        shown = lambda v: from_internal(float(v), entry.kind, unit)  # noqa: E731
        rows.append(
            {
                "name": entry.name,
                "unit": unit,
                "nominal": shown(entry.nominal),
                "value": shown(value),
                "std": None if math.isnan(sd) else shown(sd),
                "free": entry.name in identified,
            }
        )
    return rows


def build_results(loaded: LoadedSpec, figures: dict, **run) -> Results:
    """Results from a run's figures (evaluate/run_figures.py: status, unit, identifiability, parameters, residuals,
    improvement_factor, diagnosis, evaluation, solver, noise_check, correlations, campaign...) and what the run adds
    (``run``: run_id, simulated, warnings): the parameters in the spec's units, the parameter counts' breakdown. The
    spec's path is stored resolved and absolute: the same file gives the same results however its path was typed."""
    spec = loaded.spec
    created = utc_now()
    stages = dict(figures)
    fitted = stages.pop("parameters")
    stages["parameters"] = parameter_rows(loaded, fitted["entries"], fitted["values"], fitted["std"], fitted["identified"])
    stages["plausibility"] = plausibility(spec, fitted["entries"], fitted["values"], fitted["std"], fitted["identified"])
    stages["identifiability"] = {**stages["identifiability"], "breakdown": after_fit(fitted["entries"], fitted["base"], fitted["fixed"])}
    return Results.model_validate(
        {
            "armcal_version": __version__,
            "created": created,
            "report": report_fields(loaded, created),
            "spec": {"path": str(loaded.path.resolve()), "sha256": loaded.sha256, "git": git_info(loaded.path),
                     "placeholders": [{"field": field, "stands_for": STANDS_FOR[field]} for field, _ in placeholders(loaded)]},
            "robot": {"name": spec.robot.name, "serial": spec.robot.serial, "convention": spec.robot.convention, "dof": spec.robot.dof},
            "device": {"type": spec.device.type, "unit": stages.pop("unit"), "noise_sigma": stages.pop("noise_sigma")},
            **stages,
            **run,
        }
    )
