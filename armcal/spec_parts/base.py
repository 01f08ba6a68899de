"""Base model and quantity types shared by every spec section.

Every spec object is strict (an unknown key is an error) and frozen. Quantities
are written in the spec's units (``robot.units``) or with an explicit unit
("43.18 cm") and are converted once, while validating, to mm and rad.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, ValidationInfo, WithJsonSchema, model_validator

from armcal.kinematics.chain import DeclaredParameter, DeclaredPose
from armcal.kinematics.params import POSE_FIELDS
from armcal.support import units
from armcal.support.errors import shown_value


class SpecModel(BaseModel):
    """Strict, frozen base of all spec objects."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def default_unit(info: ValidationInfo, kind: str) -> str:
    """The spec's unit for ``kind`` (from the validation context), else mm / deg."""
    spec_units = (info.context or {}).get("units", {})
    return spec_units.get(kind, {"length": "mm", "angle": "deg", "scale": "1"}[kind])


def convert(value: Any, info: ValidationInfo, kind: str) -> float:
    """Spec quantity -> internal unit; raises ValueError with a plain sentence."""
    return units.to_internal(value, kind, default_unit(info, kind))


def quantity_schema(*kinds: str) -> dict:
    """JSON Schema of a quantity: a number, or a string with a unit of one of ``kinds``."""
    names = "|".join(u for kind in kinds for u in [*units.UNITS_BY_KIND[kind], *(units.ANGLE_ALIASES if kind == "angle" else ())])
    kind = " or ".join(kinds)
    return {
        "anyOf": [
            {"type": "number"},
            {"type": "string", "pattern": rf"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*({names})?\s*$"},
        ],
        "description": f"{kind} in the spec unit, or a string with one of: {names.replace('|', ', ')}",
    }


def _quantity(kind: str):
    return Annotated[
        float,
        BeforeValidator(lambda value, info: convert(value, info, kind)),
        WithJsonSchema(quantity_schema(kind)),
    ]


Length = _quantity("length")
Angle = _quantity("angle")


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {shown_value(value)}")
    return value


Number = Annotated[float, BeforeValidator(_finite), AfterValidator(_finite)]  # after too: a quoted 'nan' is a float only then


class Parameter(SpecModel):
    """A model parameter: its value (internal units), whether the fit may vary it, bounds, and the standard
    uncertainty of the calibration that wrote the value (calibrated.yaml; read by ``armcal compare``, never by a fit)."""

    value: float
    vary: bool = True
    min: float | None = None
    max: float | None = None
    std: float | None = Field(None, ge=0.0)

    @model_validator(mode="after")
    def _bounds(self) -> "Parameter":
        if self.min is not None and self.max is not None and self.min >= self.max:
            raise ValueError(f"min ({self.min:g}) must be below max ({self.max:g})")
        if self.min is not None and self.value < self.min or self.max is not None and self.value > self.max:
            raise ValueError(f"value {self.value:g} lies outside its bounds [{self.min}, {self.max}]")
        return self

    def declared(self) -> DeclaredParameter:
        """The parameter as the kinematics and the instruments' models take it."""
        return DeclaredParameter(self.value, self.vary, self.min, self.max)


def declared_pose(model: SpecModel, fields: tuple[str, ...] = POSE_FIELDS) -> DeclaredPose:
    """The given ones of a pose's (a point's, a link's) parameter ``fields``, in that order."""
    return {f: getattr(model, f).declared() for f in fields if getattr(model, f, None) is not None}


def declared_points(points: dict[str, SpecModel]) -> dict[str, DeclaredPose]:
    """Named points (an instrument's pivots, sockets, microphones) as the instruments' models take them."""
    return {name: declared_pose(point) for name, point in points.items()}


def fixed(value: float) -> Parameter:
    """A parameter held at ``value`` (the default of kinematic and device parameters a spec leaves out)."""
    return Parameter(value=value, vary=False)


def normalize_parameter(raw: Any, info: ValidationInfo, kind: str) -> Any:
    """Number, 'number unit' or {value, vary, min, max} -> Parameter fields in internal units."""
    if isinstance(raw, Parameter):
        return raw
    if isinstance(raw, dict):
        out = dict(raw)
        for key in ("value", "min", "max", "std"):
            if out.get(key) is not None:
                try:
                    out[key] = convert(out[key], info, kind)
                except ValueError as exc:
                    raise ValueError(f"{key}: {exc}") from None
        return out
    return {"value": convert(raw, info, kind)}


PARAMETER_EXAMPLES = {"length": [431.8, "43.18 cm"], "angle": [-90, "1.5708 rad", "180°"], "scale": [1, 1.0005]}


def parameter_schema(*kinds: str) -> dict:
    """JSON Schema of a parameter: a quantity or {value, vary, min, max}; examples of both forms for editors."""
    quantity = quantity_schema(*kinds)
    kind = " or ".join(kinds)
    examples = [example for k in kinds for example in PARAMETER_EXAMPLES[k]]
    return {
        "examples": [*examples, {"value": examples[0], "vary": False}],
        "anyOf": [
            quantity,
            {
                "type": "object",
                "properties": {"value": quantity, "vary": {"type": "boolean"}, "min": quantity, "max": quantity, "std": quantity},
                "required": ["value"],
                "additionalProperties": False,
            },
        ],
        "description": f"{kind} parameter: a value (free in the fit) or {{value, vary, min, max, std}} "
        "(std: the standard uncertainty a calibration wrote, read by armcal compare)",
    }


def _parameter(kind: str):
    return Annotated[
        Parameter,
        BeforeValidator(lambda raw, info: normalize_parameter(raw, info, kind)),
        WithJsonSchema(parameter_schema(kind)),
    ]


LengthParam = _parameter("length")
AngleParam = _parameter("angle")
ScaleParam = _parameter("scale")
