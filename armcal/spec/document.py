"""The whole spec: robot + device + procedure, and the optional sections."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from armcal.spec_parts.base import SpecModel
from armcal.spec.device import DEVICE_TYPES, Device
from armcal.spec.procedure import Procedure
from armcal.spec_parts.robot import Robot
from armcal.spec.effect_vocabulary import Effect
from armcal.spec.learned import ResidualModelSection
from armcal.spec.sections import STANDS_FOR, Acceptance, Data, Diagnose, Fit, Placeholders, Report, Simulate


class Spec(SpecModel):
    """A calibration spec, all quantities in mm and rad."""

    armcal: Literal[1] = Field(1, description="spec format version")
    robot: Robot = Field(description="the chain (convention: dh, mdh, s_model, six_parameter), its nominal parameters, base, tool and targets")
    device: Device = Field(description=f"the measuring instrument (type: {DEVICE_TYPES})")
    procedure: Procedure = Field(description="how the calibration poses are planned (type: circle_point, shells, poses)")
    validation: Procedure | None = Field(None, description="procedure of the held-out validation set")
    data: Data | None = None
    simulate: Simulate | None = None
    effects: list[Effect] = Field([], description="non-geometric effects in the fitted model")
    fit: Fit = Fit()
    diagnose: Diagnose = Diagnose()
    report: Report = Report()
    acceptance: Acceptance | None = Field(None, description="a tolerance on a held-out figure: the certificate states pass or fail")
    residual_model: ResidualModelSection | None = Field(
        None, description="a learned residual model a run accepted (armcal run writes it into calibrated.yaml): export --format json and "
        "compensate carry it; a run learns its own and does not read it (docs/method.md)"
    )
    placeholders: Placeholders = Field({}, description=f"the stand-ins armcal new and import-urdf wrote ({', '.join(STANDS_FOR)}), each with the "
                                       "fingerprint of its value as written: while the value is unchanged, validate warns and the certificate states it not given")
