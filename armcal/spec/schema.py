"""JSON Schema of specs, for editors and for checking shipped specs."""

from __future__ import annotations

from armcal.spec.model import Spec


def spec_json_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a spec as written by a user."""
    schema = Spec.model_json_schema(mode="validation")
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "armcal calibration spec"
    return schema
