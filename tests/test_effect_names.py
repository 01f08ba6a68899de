"""Effect type names are strings only under armcal/effects/ and armcal/devices/ (docs/architecture.md, issue 32).

Every other module asks an effect's type object (effects/effect_type.py) or the vocabulary
(armcal/devices/registry.py). The walk reads each module's syntax tree: a string constant equal to a registered
type's name fails; docstrings are skipped (prose may name a type), and so are longer strings that mention one (a
message such as "use encoder_scale").
"""

import ast

from conftest import ROOT

from armcal.devices.registry import vocabulary

OWNERS = ("effects", "devices")  # the sub-packages that define effect types


def docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring nodes of a module, its classes and functions."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                out.add(id(first.value))
    return out


def named_types(source: str, names: set[str]) -> list[tuple[int, str]]:
    """(line, name) of every string constant of ``source`` equal to one of ``names``, docstrings left out."""
    tree = ast.parse(source)
    skipped = docstrings(tree)
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and node.value in names and id(node) not in skipped]


def test_no_effect_type_name_outside_effects_and_devices():
    names = set(vocabulary())
    package = ROOT / "armcal"
    found = [f"{path.relative_to(ROOT)}:{line}: {name}" for path in sorted(package.rglob("*.py"))
             if path.relative_to(package).parts[0] not in OWNERS for line, name in named_types(path.read_text(), names)]
    assert found == []


def test_the_walk_finds_a_literal_and_skips_docstrings():
    """Oracle: a hand-made module naming a type in a docstring, a message and a comparison."""
    source = '"""Compares with backlash."""\n\ndef f(e):\n    """backlash"""\n    msg = "use backlash here"\n    return e.type == "backlash"\n'
    assert named_types(source, {"backlash"}) == [(6, "backlash")]
