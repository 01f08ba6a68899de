"""docs/spec-reference.md is generated from the models; it must say what the models say."""

from conftest import ROOT

from armcal.spec.reference import reference_markdown, shipped_specs
from armcal.spec.schema import spec_json_schema


def test_the_reference_page_is_up_to_date():
    page = (ROOT / "docs" / "spec-reference.md").read_text()
    assert page == reference_markdown(shipped_specs()), "regenerate: .venv/bin/armcal schema --markdown > docs/spec-reference.md"


def test_every_key_of_every_section_is_documented_with_a_description():
    schema = spec_json_schema()
    page = reference_markdown(shipped_specs())
    sections = {"Spec (top level)": schema, **schema["$defs"]}
    for name, node in sections.items():
        if name != "Spec (top level)" and f"## {name}\n" not in page:
            continue  # a definition no spec reaches (none today)
        block = page.split(f"## {name}\n", 1)[1].split("\n## ", 1)[0]
        for key in node.get("properties", {}):
            row = next((line for line in block.splitlines() if line.startswith(f"| `{key}` |")), None)
            assert row is not None, f"{name}.{key} is missing"
            assert row.split(" | ")[3].strip(), f"{name}.{key} has no description"


def test_quantity_defaults_are_shown_in_mm_and_deg():
    page = reference_markdown([])
    simulate = page.split("## Simulate\n", 1)[1].split("\n## ", 1)[0]
    assert "| `sigma_o` | angle quantity | `0.01 deg` |" in simulate
    assert "| `sigma_p` | length quantity | `0.1 mm` |" in simulate
