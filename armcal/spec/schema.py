"""JSON Schema of specs, for editors and for checking shipped specs."""

from __future__ import annotations

from functools import lru_cache

from armcal.spec.document import Spec

SCHEMA_ID = "urn:armcal:spec:1"  # names the spec format (armcal: 1); a URN, as the project publishes no URL


def spec_json_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a spec as written by a user."""
    schema = Spec.model_json_schema(mode="validation")
    schema.pop("title", None)
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": SCHEMA_ID, "title": "armcal calibration spec", **schema}


@lru_cache(maxsize=1)
def _schema() -> dict:
    return spec_json_schema()


def _resolve(node: dict, data) -> dict:
    """Follow $ref and pick the union member that fits ``data`` (by discriminator, else the first object)."""
    defs = _schema().get("$defs", {})
    while True:
        if "$ref" in node:
            node = defs[node["$ref"].split("/")[-1]]
            continue
        options = node.get("oneOf") or node.get("anyOf")
        if not options:
            return node
        mapping = node.get("discriminator", {})
        tag = data.get(mapping.get("propertyName")) if isinstance(data, dict) and mapping else None
        if tag in mapping.get("mapping", {}):
            node = {"$ref": mapping["mapping"][tag]}
            continue
        objects = [o for o in options if "$ref" in o or o.get("type") == "object"]
        node = objects[0] if objects else options[0]


def allowed_keys(loc: tuple, data) -> list[str]:
    """The keys a spec allows in the mapping at ``loc`` (empty if unknown)."""
    node = _resolve(_schema(), data)
    for part in loc:
        if isinstance(data, dict) and part in data:
            data = data[part]
        else:
            data = None
        if isinstance(part, int):
            node = node.get("items") or (node.get("prefixItems") or [{}])[min(part, len(node.get("prefixItems", [{}])) - 1)]
        elif part in node.get("properties", {}):
            node = node["properties"][part]
        else:
            node = node.get("additionalProperties") if isinstance(node.get("additionalProperties"), dict) else {}
        node = _resolve(node, data)
    return sorted(node.get("properties", {}))
