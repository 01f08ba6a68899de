"""joint_compliance: a joint's deflection under gravity.

Form masses: one compliance times the gravity torque of lumped masses. Form moments: the torque is linear in the
links' unknown first mass moments, and the products compliance x g x moment (m<c><k>, or a prismatic joint's w) are
the parameters (effects/library.py). The diagnosis proposes one compliance per joint times the gravity torque of the
robot's declared masses (``robot.masses``, the maker's data) or, without them, the mass-moment form with the
products the poses tell apart (products.py), no masses assumed; a joint whose gravity torque is zero at every pose (a
vertical first axis) gets no candidate.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, ValidationInfo, model_validator

from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.library import EffectSpec, moment_terms, product_fields, with_products
from armcal.effects.measurement import gravity_torque, gravity_torque_function, moment_regressor, moment_regressors, torque_masses
from armcal.effects.types.products import SILENT, independent_terms, product_keys, product_keys_schema
from armcal.spec_parts.base import AngleParam, LengthParam, Number
from armcal.spec_parts.robot import LinkMass


class JointCompliance(JointEffect):
    """Joint deflection under gravity. form masses: compliance x the gravity torque of lumped masses. form moments:
    the torque is linear in the links' unknown first mass moments, and the products compliance x g x moment,
    keys m<c><k> (axis c = x, y, z of frame F_k, links k = joint..n; angle parameters, left out: free from 0),
    are identified with no masses given; a prismatic joint has the one product w."""

    model_config = ConfigDict(extra="allow", frozen=True, json_schema_extra=product_keys_schema)
    __pydantic_extra__: dict[str, AngleParam]  # the m<c><k> products (form moments)

    type: Literal["joint_compliance"]
    form: Literal["masses", "moments"] = Field(
        "masses",
        description="masses: one compliance times the torque of `masses`; moments: the products m<c><k> "
        "(compliance x g x first moment of link k about axis c of its frame), no masses needed",
    )
    compliance: Number = Field(0.0, description="rad per N m (form masses)")
    vary: bool = Field(True, description="identify the effect's parameters (else keep the values given)")
    masses: list[LinkMass] = Field([], description="form masses: lumped masses for the gravity torque (default: robot.masses, else 5 kg at each link frame's origin beyond the joint, assumed)")
    w: LengthParam | None = Field(None, description="form moments, prismatic joint: deflection along the axis under the weight beyond it, axis vertical")

    @model_validator(mode="before")
    @classmethod
    def _moment_products(cls, data: Any, info: ValidationInfo) -> Any:
        return product_keys(cls, data, info, data.get("form") == "moments" if isinstance(data, dict) else False)


class JointComplianceType(EffectType):
    name = "joint_compliance"
    spec_model = JointCompliance
    compensated = True
    products = True

    def fields(self, effect):
        if effect.terms:
            return product_fields(effect.terms)
        return [("compliance", "compliance")]

    def lists_products(self, entry):
        return entry.form == "moments"

    def form(self, effect):
        return "moments" if effect.terms else "masses"

    def spec_keys(self, effect):
        return {"form": "moments"} if effect.form == "moments" else {}

    def candidates(self, kinematics, data, harmonic_orders):
        q = np.nan_to_num(data.q)
        if kinematics.masses:
            torque = np.array(gravity_torque_function(kinematics).map(len(q))(q.T, kinematics.parameters.nominal)).T
            spread = np.ptp(torque, axis=0)
            return [EffectSpec(self, joint=j + 1) for j in range(kinematics.dof) if spread[j] > SILENT * spread.max()]
        frames = kinematics.link_frames_batch(q)
        out = []
        for joint, kind in enumerate(kinematics.joint_types, start=1):
            every = moment_terms(joint, kinematics.dof, kind == "revolute")
            terms = independent_terms(moment_regressors(frames, joint, every), every)
            if terms:
                out.append(with_products(self, joint, terms))
        return out

    def joint_deviation(self, effect, chain, value):
        if effect.form == "moments":
            return sum(value(t) * moment_regressor(chain.frames, effect.joint, t) for t in effect.terms)
        return value("compliance") * gravity_torque(chain.frames, effect.joint, torque_masses(chain.kinematics, effect.masses))


JOINT_COMPLIANCE = JointComplianceType()
