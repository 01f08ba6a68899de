"""What joint_compliance (form moments) and joint_bending share: their mass-moment products m<c><k> in the spec, and
which of them the diagnosis proposes.

Of a joint's products only those whose deflection (or tilt) patterns over the calibration poses are independent are
proposed (Gram-Schmidt in link and axis order at the nominal geometry, INDEPENDENT): the others are combinations of
them (a product along a joint's own axis regroups onto the link before it, products the poses never vary together
with others drop out), and a candidate with dependent columns would count degrees of freedom its score test cannot see.
"""

from __future__ import annotations

import difflib
import re
from typing import Any

import numpy as np
from pydantic import ValidationInfo

from armcal.spec_parts.base import parameter_schema
from armcal.support.errors import shown_key, shown_value

MOMENT_KEY = re.compile(r"^m[xyz][1-9][0-9]*$")  # form moments: m<c><k>, axis c of frame F_k, link k (effects/library.py)
INDEPENDENT = 1e-6  # norm a unit deflection pattern must keep off those before it to be a product of its own
SILENT = 1e-9  # a pattern below this fraction of the joint's largest is no deflection at all


def product_keys(cls, data: Any, info: ValidationInfo, moments: bool) -> Any:
    """Refuse unknown keys (only m<c><k> may be extra); where ``moments``, fill in the products left out with 0
    (free), from the robot's joints in the validation context: m<c><k> for links joint..n, or w (prismatic)."""
    if not isinstance(data, dict):
        return data
    for key in data:
        if key not in cls.model_fields and not MOMENT_KEY.match(str(key)):
            close = difflib.get_close_matches(str(key), list(cls.model_fields), n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(cls.model_fields) + " and m<c><k> such as mx3"
            raise ValueError(f"{shown_key(key, quoted=True)} is unknown in a {shown_value(data.get('type'))} effect: remove it or check its spelling ({hint})")
    kinds = (info.context or {}).get("joint_kinds", [])
    joint = data.get("joint")
    if not moments or not isinstance(joint, int) or not 1 <= joint <= len(kinds):
        return data
    out = dict(data)
    if kinds[joint - 1] == "angle":
        for k in range(joint, len(kinds) + 1):
            for c in "xyz":
                out.setdefault(f"m{c}{k}", 0.0)
    elif "w" in cls.model_fields:
        out.setdefault("w", 0.0)
    return out


def product_keys_schema(schema: dict) -> None:
    """The m<c><k> keys of the moments form in the JSON Schema: angle parameters, nothing else extra."""
    schema["patternProperties"] = {MOMENT_KEY.pattern: parameter_schema("angle")}
    schema["additionalProperties"] = False


def independent_terms(patterns: np.ndarray, terms: tuple[str, ...]) -> tuple[str, ...]:
    """The terms whose (N,) columns of ``patterns`` are independent of the columns kept before them."""
    norms = np.linalg.norm(patterns, axis=0)
    if not len(terms) or norms.max() == 0:
        return ()
    kept, basis = [], np.zeros((len(patterns), 0))
    for term, column, norm in zip(terms, patterns.T, norms):
        if norm <= SILENT * norms.max():
            continue
        rest = column / norm - basis @ (basis.T @ (column / norm))
        rest -= basis @ (basis.T @ rest)
        if np.linalg.norm(rest) > INDEPENDENT:
            kept.append(term)
            basis = np.column_stack([basis, rest / np.linalg.norm(rest)])
    return tuple(kept)
