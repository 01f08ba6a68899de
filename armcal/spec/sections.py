"""Smaller spec sections: data files, simulation, fit, diagnosis, tasks, acceptance, report (the effects they
declare: spec/effect_vocabulary.py)."""

from __future__ import annotations

import math
import re
from typing import Annotated, Literal

from pydantic import AfterValidator, Field, model_validator

from armcal.spec_parts.base import Angle, Length, Number, SpecModel
from armcal.spec.effect_vocabulary import EFFECT_NAMES, Effect
from armcal.support.units import LENGTH_UNITS

DEG = math.pi / 180.0

STANDS_FOR = {  # the fields `armcal new` and `armcal import-urdf` write stand-ins for (spec/placeholders.py), and what they stand for
    "robot.serial": "the robot's serial number",
    "robot.targets": "the points the instrument measures on the robot",
    "device": "the measuring instrument's placement, targets and noise",
    "procedure": "the calibration poses as measured",
    "validation": "the held-out poses as measured",
}


def _fingerprint(value: str) -> str:
    if not re.fullmatch(r"[0-9a-f]{16}", value):
        raise ValueError("a placeholder's fingerprint is the 16 hex digits armcal wrote; to keep the value as it is, remove the line")
    return value


Placeholders = dict[Literal[tuple(STANDS_FOR)], Annotated[str, AfterValidator(_fingerprint)]]


class Data(SpecModel):
    """Measured data files (CSV, contract columns), relative to the spec file."""

    calibration: str = Field(description="CSV file of the calibration measurements")
    validation: str | None = Field(None, description="CSV file of held-out measurements")
    instrument_moved: bool = Field(
        False, description="the tracker was set up anew for the validation data: re-register it there (robot kept)"
    )


class Simulate(SpecModel):
    """How ``armcal simulate`` builds the true robot and its measurements.

    The true robot is the nominal chain with six small error freedoms after the
    base and after every link, and an encoder error per joint (Stone 7.1-7.8
    generalised): a richer model than any convention that is fitted.
    """

    seed: int = Field(0, ge=0, description="seed of the true robot and the noise")
    sigma_p: Length = Field(0.1, ge=0.0, description="positional manufacturing error sigma (Stone 7.2)")
    sigma_o: Angle = Field(0.01 * DEG, ge=0.0, description="orientational manufacturing error sigma (Stone 7.2)")
    sigma_e: Angle = Field(0.1 * DEG, ge=0.0, description="encoder calibration error sigma (Stone 7.2)")
    noise: bool = Field(True, description="add the instrument's noise to the readings")
    noise_factor: Number = Field(1.0, gt=0.0, description="k: the instrument's noise sigma times k (Stone 7.4.3)")
    effects: list[Effect] = Field([], description="hidden effects, never visible to the fit")
    time_step: float = Field(10.0, ge=0.0, description="seconds between samples (t column)")
    temperature: tuple[float, float] | None = Field(None, description="start and end temperature, degC")


class Fit(SpecModel):
    """How the parameters are identified."""

    method: Literal["least_squares", "s_model_features"] = Field(
        "least_squares", description="Levenberg-Marquardt on all data, or Stone's feature-based S-Model identification"
    )
    loss: Literal["linear", "huber", "cauchy"] = Field("linear", description="least squares, or a robust loss against gross errors")
    loss_scale: float = Field(3.0, gt=0.0, description="robust loss threshold, in noise sigmas")
    max_iterations: int = Field(100, ge=1, description="Levenberg-Marquardt iteration limit")


class Diagnose(SpecModel):
    """The residual diagnosis loop after each fit."""

    enabled: bool = Field(True, description="run the diagnosis after the fit")
    alpha: float = Field(0.001, gt=0.0, lt=1.0, description="family-wise false-positive rate of a round's score tests")
    max_rounds: int = Field(3, ge=0, description="effects added at most (one per round)")
    candidates: list[Literal[EFFECT_NAMES]] | None = Field(None, description="effect types tried (default: all the data allow)")  # type: ignore[valid-type]
    harmonic_orders: int = Field(3, ge=1, description="gear harmonics tried up to this order")
    holdout: Literal["kfold", "validation"] = Field(
        "kfold",
        description="data that must confirm an effect: k-fold cross-validation over the calibration poses (the validation set "
        "stays untouched for the final figures), or the validation set (its figures are then not independent)",
    )
    folds: int = Field(5, ge=2, description="k of the k-fold cross-validation")
    residual_model: Literal["none", "gp"] = Field(
        "none",
        description="a learned model of what the physical model leaves, after the physical effects: none, or gp (a Gaussian "
        "process per learned coordinate on the joint values, kept only when it holds out on the k-fold folds as an effect must)",
    )


class IsoCube(SpecModel):
    """Where the ISO 9283 test cube stands: its centre in the robot base frame and its side."""

    x: Length = Field(description="centre, robot base frame")
    y: Length = Field(description="centre, robot base frame")
    z: Length = Field(description="centre, robot base frame")
    side: Length = Field(gt=0.0, description="side of the cube")


ACCEPTANCE_STATISTICS = ("validation_rms", "validation_max", "validation_rms_3d", "validation_max_3d")


class Acceptance(SpecModel):
    """A tolerance the calibrated robot must meet on the held-out data, and the decision rule (ILAC-G8:2019)."""

    tolerance: Length = Field(gt=0.0, description="upper limit of the statistic")
    statistic: Literal[ACCEPTANCE_STATISTICS] = Field(  # type: ignore[valid-type]
        "validation_rms",
        description="the held-out figure judged, calibrated model: validation_rms / validation_max (per coordinate), "
        "validation_rms_3d / validation_max_3d (3D distance per pose, tracker)",
    )
    decision_rule: Literal["simple", "guarded"] = Field(
        "simple",
        description="simple: pass when the figure is at most the tolerance; guarded: when the figure plus its expanded "
        "uncertainty U (95 %: k from Student's t over the held-out poses) is (RMS statistics only)",
    )

    @model_validator(mode="after")
    def _guarded_needs_rms(self) -> "Acceptance":
        if self.decision_rule == "guarded" and "_rms" not in self.statistic:
            raise ValueError(f"guarded acceptance needs the figure's uncertainty, which armcal computes for RMS statistics only, not {self.statistic}; use decision_rule: simple")
        return self


class Report(SpecModel):
    """Certificate fields, and the evaluation tasks it shows (with simulated data, whose truth is known)."""

    tasks: list[Literal["grid_task", "iso9283"]] = Field(
        ["grid_task", "iso9283"],
        description="Stone's grid task (7.2.1; Table 7-1 where the robot reaches it, else scaled to the robot and placed in its "
        "workspace), the ISO 9283 cube",
    )
    iso9283_cube: IsoCube | None = Field(
        None, description="where the ISO 9283 cube stands; left out, armcal places the largest cube the robot reaches near its workspace's centre"
    )
    unit: Literal[tuple(LENGTH_UNITS)] | None = Field(None, description="the certificate's one length unit; default: robot.units.length")  # type: ignore[valid-type]
    certificate_number: str | None = Field(None, description="default: ARMCAL-<serial>-<date>-<spec hash>")
    customer: str | None = Field(None, description="printed on the certificate")
    operator: str | None = Field(None, description="who calibrated, printed with the signature lines")
    location: str | None = Field(None, description="where the calibration took place")
    notes: str | None = Field(None, description="free text printed on the certificate")
    template: str | None = Field(None, description="folder of your own certificate templates, searched first")
