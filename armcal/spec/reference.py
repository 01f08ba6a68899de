"""The spec reference (docs/spec-reference.md), generated from the JSON Schema of the pydantic models.

Every section and key with its type, unit, default, description and an example:
the first value the shipped specs (examples/*/spec.yaml, specs/*.yaml) give it,
else its default. `armcal schema --markdown` prints it; a test keeps the page in
step with the models.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ruamel.yaml import YAML

from armcal.spec.schema import spec_json_schema

QUANTITY_UNITS = {"length": ("mm", "cm", "m"), "angle": ("rad", "deg", "arcsec")}
SHOWN_DEFAULT = {"length": ("mm", 1.0), "angle": ("deg", 180.0 / math.pi)}  # internal unit -> how a default is shown


def shipped_specs() -> list[Path]:
    """The specs shipped beside the package in a checkout of the project (none in a plain install)."""
    root = Path(__file__).resolve().parents[2]
    return sorted([*root.glob("examples/*/spec.yaml"), *root.glob("specs/*.yaml")])


def reference_markdown(example_specs: list[Path] = ()) -> str:
    """The whole reference page."""
    schema = spec_json_schema()
    definitions = schema["$defs"]
    examples = _examples(schema, example_specs)
    lines = [
        "# Spec reference",
        "",
        "Generated from armcal's pydantic models by `armcal schema --markdown` (a test fails when",
        "this page is out of date). Quantities are numbers in the spec's units (`robot.units`) or",
        'strings with a unit ("43.18 cm", "2 arcsec"); defaults of quantities are shown in mm and',
        "deg. A *parameter* is a quantity (free in the fit) or `{value, vary, min, max}`. Examples are",
        "taken from the shipped specs (examples/, specs/).",
        "",
    ]
    for name, node in [("Spec", schema), *_reachable(schema, definitions)]:
        lines += _section(name, node, examples.get(name, {}), definitions)
    return "\n".join(lines).rstrip() + "\n"


def _reachable(schema: dict, definitions: dict) -> list[tuple[str, dict]]:
    """The definitions in the order a reader meets them, from the top of a spec down."""
    order: list[str] = []
    queue = _refs(schema)
    while queue:
        name = queue.pop(0)
        if name not in order:
            order.append(name)
            queue += _refs(definitions[name])
    return [(name, definitions[name]) for name in order]


def _refs(node) -> list[str]:
    if isinstance(node, dict):
        found = [node["$ref"].split("/")[-1]] if "$ref" in node else []
        for key, value in node.items():
            if key not in ("$defs", "discriminator"):
                found += _refs(value)
        return found
    if isinstance(node, list):
        return [name for item in node for name in _refs(item)]
    return []


def _section(name: str, node: dict, examples: dict, definitions: dict) -> list[str]:
    title = "Spec (top level)" if name == "Spec" else name
    lines = [f"## {title}", ""]
    if node.get("description"):
        lines += [" ".join(node["description"].split()), ""]
    required = set(node.get("required", []))
    lines += ["| key | type | required / default | description | example |", "|---|---|---|---|---|"]
    for key, field in node.get("properties", {}).items():
        kind = _quantity_kind(field)
        default = "required" if key in required else _default(field, kind)
        description = _description(field, definitions)
        example = examples.get(key, "")
        lines.append(f"| `{key}` | {_type(field)} | {default} | {_cell(description)} | {_cell(example)} |")
    return lines + [""]


def _type(node: dict) -> str:
    """A field's type in words, with links to the sections of nested objects."""
    if "$ref" in node:
        name = node["$ref"].split("/")[-1]
        return f"[{name}](#{name.lower()})"
    if "const" in node:
        return f"`{json.dumps(node['const'])}`"
    if "enum" in node:
        return "one of " + ", ".join(f"`{v}`" for v in node["enum"])
    if _is_quantity(node):
        return f"{_quantity_kind(node)} quantity"
    if _is_parameter(node):
        return f"{_quantity_kind(node)} parameter"
    options = node.get("oneOf") or node.get("anyOf")
    if options:
        return " or ".join(dict.fromkeys(_type(o) for o in options))
    kind = node.get("type")
    if kind == "array":
        if "prefixItems" in node:
            return "[" + ", ".join(_type(i) for i in node["prefixItems"]) + "]"
        return f"list of {_type(node.get('items', {}))}"
    if kind == "object":
        values = node.get("additionalProperties")
        return f"map of name to {_type(values)}" if isinstance(values, dict) else "mapping"
    return {"number": "number", "integer": "integer", "string": "text", "boolean": "true/false", "null": "null"}.get(kind, "any")


def _is_quantity(node: dict) -> bool:
    options = node.get("anyOf", [])
    return len(options) == 2 and options[0].get("type") == "number" and "pattern" in options[1]


def _is_parameter(node: dict) -> bool:
    options = node.get("anyOf", [])
    return len(options) == 2 and _is_quantity(options[0]) and "value" in options[1].get("properties", {})


def _quantity_kind(node: dict) -> str | None:
    """length, angle or "angle or length" from the units a quantity's pattern accepts."""
    if _is_parameter(node):
        return _quantity_kind(node["anyOf"][0])
    if not _is_quantity(node):
        return None
    pattern = node["anyOf"][1]["pattern"]
    kinds = [kind for kind, units in QUANTITY_UNITS.items() if any(f"|{u}|" in pattern.replace("(", "|").replace(")", "|") for u in units)]
    return " or ".join(sorted(kinds)) or "scale"


def _description(field: dict, definitions: dict) -> str:
    """The field's own description; else the first sentence of the section it refers to."""
    text = field.get("description", "")
    if text.startswith(("length in the spec unit", "angle in the spec unit", "angle or length in the spec")):
        text = ""  # the generic text of a quantity: the type column says it
    if not text and "const" in field:
        text = "selects this kind"
    if not text:
        referred = _refs({k: v for k, v in field.items() if k != "default"})
        if len(set(referred)) == 1:
            text = " ".join(definitions[referred[0]].get("description", "").split()).split(". ")[0]
    return " ".join(text.split())


def _default(node: dict, kind: str | None) -> str:
    if "default" not in node:
        return "optional"
    value = node["default"]
    if isinstance(value, dict) and {"value", "vary"} <= set(value):  # a parameter's default
        return f"`{value['value']:g}`, {'free' if value['vary'] else 'fixed'}"
    if isinstance(value, dict) and value:
        return "each key's default"
    if isinstance(value, list) and node.get("prefixItems") and kind is None:
        kind = _quantity_kind(node["prefixItems"][0])
        if kind in SHOWN_DEFAULT:
            unit, factor = SHOWN_DEFAULT[kind]
            return "`[" + ", ".join(f"{v * factor:.6g}" for v in value) + f"] {unit}`"
    if kind in SHOWN_DEFAULT and isinstance(value, (int, float)):
        unit, factor = SHOWN_DEFAULT[kind]
        return f"`{value * factor:.6g} {unit}`"
    return f"`{json.dumps(value)}`"


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _examples(schema: dict, spec_paths: list[Path]) -> dict[str, dict[str, str]]:
    """{definition: {key: the first value a shipped spec gives it, compact}}."""
    found: dict[str, dict[str, str]] = {}
    yaml = YAML(typ="safe")
    for path in spec_paths:
        _walk(schema, "Spec", yaml.load(Path(path).read_text()), schema["$defs"], found)
    return found


def _walk(node: dict, name: str, data, definitions: dict, found: dict) -> None:
    """Record the values of ``data`` under the definition ``name`` and descend into nested objects."""
    if not isinstance(data, dict):
        return
    for key, value in data.items():
        field = node.get("properties", {}).get(key)
        if field is None:
            continue
        found.setdefault(name, {}).setdefault(key, _compact(value))
        for child_name, child_value in _children(field, value, definitions):
            _walk(definitions[child_name], child_name, child_value, definitions, found)


def _children(field: dict, value, definitions: dict) -> list[tuple[str, object]]:
    """(definition, data) pairs below a field's value: the object itself, list items, map values."""
    if "$ref" in field:
        return [(field["$ref"].split("/")[-1], value)]
    mapping = field.get("discriminator", {}).get("mapping")
    if mapping and isinstance(value, dict) and value.get(field["discriminator"]["propertyName"]) in mapping:
        return [(mapping[value[field["discriminator"]["propertyName"]]].split("/")[-1], value)]
    pairs = []
    for option in field.get("anyOf", []) + field.get("oneOf", []):
        if "$ref" in option and isinstance(value, dict):
            pairs += [(option["$ref"].split("/")[-1], value)]
            break
    if field.get("type") == "array" and isinstance(value, list):
        pairs += [pair for item in value for pair in _children(field.get("items", {}), item, definitions)]
    values = field.get("additionalProperties")
    if isinstance(values, dict) and isinstance(value, dict):
        pairs += [pair for item in value.values() for pair in _children(values, item, definitions)]
    return pairs


def _compact(value) -> str:
    """A value as short YAML flow text for the example column (long ones cut)."""
    text = json.dumps(value, separators=(", ", ": ")) if not isinstance(value, str) else value
    text = text.replace('"', "")
    return f"`{text if len(text) <= 48 else text[:45] + '...'}`"
