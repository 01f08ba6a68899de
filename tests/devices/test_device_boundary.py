"""Nothing outside armcal/devices/ names an instrument (issue 19): the rest of armcal asks the registry's entry.

A module outside devices/ names an instrument when it holds a registered device type as a
string ("tracker" compared with device.type, a dict keyed by it), imports an instrument's
module, names an instrument's model or spec-section class, or calls a model method only one
instrument defines (duck typing on one instrument). The scanner is tested on sources that do
each of these, so a pass means the package has none of these namings (not that no module
could know an instrument another way: a type inside a longer text is not looked for).
"""

from __future__ import annotations

import ast

import pytest
from conftest import ROOT

from armcal.devices.base import DeviceModel
from armcal.devices.registry import INSTRUMENTS

PACKAGE = ROOT / "armcal"
SHARED = {"__init__", "base", "registry"}  # devices/ modules that are no instrument


def _instrument_modules() -> set[str]:
    return {model.__module__ for model in INSTRUMENTS.values()} | {
        f"armcal.devices.{p.stem}" for p in (PACKAGE / "devices").glob("*.py") if p.stem not in SHARED
    }


def _class_names() -> set[str]:
    return {model.__name__ for model in INSTRUMENTS.values()} | {model.section.__name__ for model in INSTRUMENTS.values()}


def _one_instrument_methods() -> set[str]:
    """Methods of one registered model only (not of DeviceModel): calling one is duck typing on that instrument."""
    defined: dict[str, int] = {}
    for model in INSTRUMENTS.values():
        for name, value in vars(model).items():
            if callable(value) and not hasattr(DeviceModel, name):
                defined[name] = defined.get(name, 0) + 1
    return {name for name, count in defined.items() if count == 1}


def namings(source: str) -> list[tuple[int, str]]:
    """(line, what) of every place ``source`` names an instrument."""
    types, modules, classes, methods = set(INSTRUMENTS), _instrument_modules(), _class_names(), _one_instrument_methods()
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in types:
            found.append((node.lineno, f"the device type {node.value!r}"))
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported = {node.module, *(f"{node.module}.{a.name}" for a in node.names)}
            found += [(node.lineno, f"import of {m}") for m in sorted(imported & modules)]
            found += [(node.lineno, f"import of {a.name}") for a in node.names if a.name in classes]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, f"import of {a.name}") for a in node.names if a.name in modules]
        elif isinstance(node, ast.Name) and node.id in classes:
            found.append((node.lineno, f"the class {node.id}"))
        elif isinstance(node, ast.Attribute) and node.attr in classes:
            found.append((node.lineno, f"the class {node.attr}"))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in methods:
            found.append((node.lineno, f"a call of {node.func.attr}, which one instrument's model alone defines"))
    return found


def test_no_module_outside_devices_names_an_instrument():
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.parent == PACKAGE / "devices":
            continue
        offenders += [f"{path.relative_to(PACKAGE.parent)}:{line}: {what}" for line, what in namings(path.read_text())]
    assert not offenders, "outside armcal/devices/:\n" + "\n".join(offenders)


@pytest.mark.parametrize("source", [
    'if spec.device.type == "tracker":\n    pass\n',
    'UNITS = {"theodolite": "arcsec"}\n',
    "from armcal.devices.ballbar import BallBarModel\n",
    "from armcal.devices import sonic\n",
    "import armcal.devices.tracker\n",
    "ok = isinstance(device, TheodoliteModel)\n",
    "ok = isinstance(spec.device, devices.BallBar)\n",
    f"sigma = device.{min(_one_instrument_methods())}(readings)\n",
])
def test_the_scanner_finds_each_way_of_naming_an_instrument(source):
    assert namings(source), source


def test_every_instrument_module_is_registered():
    """An instrument module the registry lacks would be a method nobody can use (and a place the rule cannot see)."""
    registered = {model.__module__ for model in INSTRUMENTS.values()}
    modules = {f"armcal.devices.{p.stem}" for p in (PACKAGE / "devices").glob("*.py") if p.stem not in SHARED}
    assert modules == registered
