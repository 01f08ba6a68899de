"""The spec's ``residual_model`` section: a learned residual model a run accepted (diagnose/residual_model.py), stored
in its calibrated.yaml so that export and compensate carry it. Internal units throughout (joint values rad or mm as
joint_units say, targets and variances mm or rad), whatever robot.units says: the numbers are the run's, unconverted.

Every count is bounded (at most MAX_COORDINATES coordinates, MAX_TRAINING rows each) and every number finite; the
rows' widths, the length scales and joint_units are checked against the robot's joints by spec/checks.py."""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import AfterValidator, Field, model_validator

from armcal.spec_parts.base import Number, SpecModel
from armcal.support.errors import shown_value

JOINT_UNIT = {"angle": "rad", "length": "mm"}  # the unit of a joint's value (params.joint_kind) in the model's inputs
BASE = ("base_x", "base_y", "base_z")  # a point's learned coordinates: its error in the robot's base frame
MAX_TRAINING = 800  # readings per coordinate that train a model at most (a spread subset above)
MAX_COORDINATES = 16  # a point's three base coordinates, a tracker's three angles, a sonic digitizer's microphones
MAX_WHERE = 256  # characters of a coordinate's ``at``
MAX_JOINTS = 64  # values in a row or length scales at most, before they are checked against the robot's joints
CHANNELS = ("rx", "ry", "rz", "length", "contact", "dx", "dy", "dz", "azimuth", "elevation")  # read as coordinates of their own
# (devices/*.py channels; a point's x, y, z are learned in the base frame), and a sonic digitizer's s_<microphone>
MICROPHONE = re.compile(r"s_[A-Za-z0-9_]{1,64}")


def _coordinate(name: str) -> str:
    if name in BASE or name in CHANNELS or MICROPHONE.fullmatch(name):
        return name
    raise ValueError(f"{shown_value(name)} is not a learned coordinate: {', '.join(BASE)} (a point's error in the robot's base frame), "
                     f"{', '.join(CHANNELS)} or s_<microphone>")

LARGEST = 1e6  # rad or mm: no joint value or correction is larger (a kilometre, 160,000 turns)
Variance = Annotated[Number, Field(gt=0.0, le=LARGEST**2)]
Value = Annotated[Number, Field(ge=-LARGEST, le=LARGEST)]
NOISE_RATIO = 1e-10  # the noise variance is at least this fraction of the signal's: the kernel matrix stays positive
# definite in double precision whatever the inputs (a fitted one's is: its noise term is at least (0.5 sigma)^2 and its
# signal variance at most half that / NOISE_RATIO, diagnose/residual_model.fit_coordinate)


class LearnedCoordinate(SpecModel):
    """One coordinate's Gaussian process, C * RBF(length_scales) + White, as the run fitted it: enough to reproduce
    its predictions without fitting again."""

    coordinate: Annotated[str, AfterValidator(_coordinate)] = Field(description="base_x, base_y, base_z (a point's error in the robot's base frame) or a channel as read")
    at: str = Field(min_length=1, max_length=MAX_WHERE, pattern=r"^[^\x00-\x1f\x7f]+$",
                    description="where it is read: a point's target (a robot target), else its readings' key (target, pivot, station, plane; '/' between names)")
    inputs: list[Annotated[list[Value], Field(max_length=MAX_JOINTS)]] = Field(
        min_length=1, max_length=MAX_TRAINING, description="joint values of the training readings, one row per reading (joint_units)"
    )
    targets: list[Value] = Field(min_length=1, max_length=MAX_TRAINING, description="measured - predicted by the physical model, one per row (mm, or rad for an angle)")
    signal_variance: Variance = Field(description="C: the learned function's prior variance")
    length_scales: list[Annotated[Number, Field(ge=1e-6, le=LARGEST)]] = Field(max_length=MAX_JOINTS, description="one per joint (joint_units)")
    noise_variance: Variance = Field(description="the noise term's variance")

    @model_validator(mode="after")
    def _one_target_a_row(self) -> "LearnedCoordinate":
        if len(self.targets) != len(self.inputs):
            raise ValueError(f"{len(self.inputs)} rows of inputs and {len(self.targets)} targets: one target a row")
        if self.noise_variance < NOISE_RATIO * self.signal_variance:
            raise ValueError(f"the noise_variance ({self.noise_variance:g}) is below {NOISE_RATIO:g} of the signal_variance ({self.signal_variance:g}): "
                             "no fitted model's is, and its Gaussian process could not be computed")
        return self


class ResidualModelSection(SpecModel):
    """A learned residual model a run accepted (written by armcal run into calibrated.yaml; read by export and
    compensate, never by a run, which learns its own). Its numbers are in mm and rad whatever robot.units says."""

    kind: Literal["gp"] = Field(description="gp: Gaussian processes on the joint values")
    outside_fraction: Annotated[Number, Field(gt=0.0, le=1.0)] = Field(
        description="a prediction whose standard deviation exceeds this fraction of the prior's is outside the calibrated region"
    )
    joint_units: list[Literal[tuple(JOINT_UNIT.values())]] = Field(max_length=MAX_JOINTS, description="rad (revolute) or mm (prismatic), one per joint")  # type: ignore[valid-type]
    coordinates: list[LearnedCoordinate] = Field(min_length=1, max_length=MAX_COORDINATES, description="one Gaussian process per learned coordinate")

    @model_validator(mode="after")
    def _each_coordinate_once(self) -> "ResidualModelSection":
        names = [f"{c.coordinate} at {c.at}" for c in self.coordinates]
        if len(set(names)) != len(names):
            raise ValueError(f"a coordinate is given twice ({', '.join(sorted({n for n in names if names.count(n) > 1}))}): one model each")
        return self


def section_of(block: dict | None) -> dict | None:
    """The residual_model section of a run's results.json residual_model block (None: none accepted)."""
    if not block or not block.get("model"):
        return None
    return {"kind": block["kind"], "outside_fraction": block["outside_fraction"], "joint_units": block["joint_units"], "coordinates": block["model"]}
