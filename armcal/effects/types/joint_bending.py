"""joint_bending: the links beyond a revolute joint tilt about o_(joint-1), about the axes square to the joint, by a
bending compliance times the moment of their weight there (the mass-moment products of joint_compliance's moments
form, for the tilt).

The diagnosis builds its candidates as compliance's, from the tilt patterns (products.py), but tries them only when
``diagnose.candidates`` names it (opt_in): a tilt about an axis square to joint j is, up to the lever, a turn about
the axis of the joint before or after it, so bending and the neighbours' compliance explain a deflection almost
equally well (measured: docs/effects.md), and left in the default pool the diagnosis names either.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, ValidationInfo, model_validator

from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.library import moment_terms, product_fields, with_products
from armcal.effects.measurement import bending_regressor, bending_regressors
from armcal.effects.types.products import independent_terms, product_keys, product_keys_schema
from armcal.spec_parts.base import AngleParam


class JointBending(JointEffect):
    """The links beyond joint `joint` tilt about o_(joint-1), about the axes square to the joint, by a bending
    compliance times the moment of their weight there: keys m<c><k> as in joint_compliance's moments form
    (compliance x g x first moment of link k about axis c of its frame; angle parameters, left out: free from 0).
    Revolute joints."""

    model_config = ConfigDict(extra="allow", frozen=True, json_schema_extra=product_keys_schema)
    __pydantic_extra__: dict[str, AngleParam]  # the m<c><k> products

    type: Literal["joint_bending"]
    vary: bool = Field(True, description="identify the products (else keep the values given)")

    @model_validator(mode="before")
    @classmethod
    def _moment_products(cls, data: Any, info: ValidationInfo) -> Any:
        return product_keys(cls, data, info, True)


class JointBendingType(EffectType):
    name = "joint_bending"
    spec_model = JointBending
    opt_in = True
    products = True
    tilts = True

    def fields(self, effect):
        return product_fields(effect.terms)

    def candidates(self, kinematics, data, harmonic_orders):
        frames = kinematics.link_frames_batch(np.nan_to_num(data.q))
        out = []
        for joint, kind in enumerate(kinematics.joint_types, start=1):
            if kind != "revolute":
                continue
            every = moment_terms(joint, kinematics.dof)
            patterns = bending_regressors(frames, joint, every)
            terms = independent_terms(patterns.reshape(-1, len(every)), every)
            if terms:
                out.append(with_products(self, joint, terms))
        return out

    def tilt(self, effect, frames, value):
        return sum(value(t) * bending_regressor(frames, effect.joint, t) for t in effect.terms)


JOINT_BENDING = JointBendingType()
