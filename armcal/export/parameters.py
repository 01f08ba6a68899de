"""Every calibrated parameter and effect as JSON, for other tools: values in the spec's units, uncertainties where
a run's results.json gives them."""

from __future__ import annotations

import json

from pydantic import ValidationError

from armcal.kinematics.params import parameter_set
from armcal.results.schema import Results
from armcal.spec import LoadedSpec
from armcal.spec.checks import residual_model_problems
from armcal.spec.loader import plain_message
from armcal.support.errors import UserError
from armcal.spec.learned import ResidualModelSection, section_of
from armcal.support.units import from_internal


def parameters_json(loaded: LoadedSpec, results: Results | None) -> str:
    """JSON text: the robot, its chain parameters (value, unit, free, std) and its effects as the spec writes them."""
    spec = loaded.spec
    std = {p.name: p.std for p in results.parameters} if results else {}
    rows = []
    for entry in parameter_set(spec.robot.chain()).entries:
        unit = spec.robot.units.of(entry.kind)
        rows.append({
            "name": entry.name,
            "value": from_internal(entry.nominal, entry.kind, unit),
            "unit": unit,
            "free": entry.free,
            "std": std.get(entry.name),
        })
    document = {
        "robot": {"name": spec.robot.name, "model": spec.robot.model, "serial": spec.robot.serial, "convention": spec.robot.convention},
        "source": str(loaded.path),
        "run_id": results.run_id if results else None,
        "parameters": rows,
        "effects": [e.model_dump(mode="json", by_alias=True, exclude_none=True) for e in spec.effects],
    }
    learned = learned_section(loaded, results)
    if learned is not None:  # the run's accepted learned residual model (docs/export.md)
        document["residual_model"] = learned.model_dump(mode="json")
    return json.dumps(document, indent=2) + "\n"


def learned_section(loaded: LoadedSpec, results: Results | None) -> ResidualModelSection | None:
    """The accepted learned residual model a calibration carries: its calibrated spec's residual_model section, else
    (a run written before calibrated.yaml stored it) its results.json's."""
    if loaded.spec.residual_model is not None:
        return loaded.spec.residual_model
    section = section_of(results.residual_model.model_dump() if results and results.residual_model else None)
    if section is None:
        return None
    try:
        model = ResidualModelSection.model_validate(section)
    except ValidationError as exc:  # a model armcal did not write (the file was edited)
        error = exc.errors()[0]
        loc = ("residual_model", *error["loc"])
        raise UserError(f"the run's results.json: {'.'.join(map(str, loc))}: {plain_message(error, loc).rstrip('.')} (not a model armcal writes)") from None
    problem = next(residual_model_problems(model, loaded.spec.robot), None)
    if problem is not None:
        loc, message = problem
        raise UserError(f"the run's results.json: {'.'.join(map(str, loc))}: {message} (not a model of this calibrated spec's robot)")
    return model
