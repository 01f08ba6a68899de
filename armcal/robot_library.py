"""The robot library: nominal robot sections of common industrial robots, in armcal/robots/ (specs/robots/ links
to it), shipped with the package.

A library file is YAML with two keys: ``home`` (the maker's home configuration, one value per
joint in the robot's units) and ``robot`` (a spec's robot section, every number's source in a
comment). The folder is inside the package (package data), whatever the current directory.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

from pydantic import TypeAdapter, ValidationError

from armcal.support.errors import UserError
from armcal.spec.loader import parse_yaml, validation_context
from armcal.spec_parts.robot import Robot, RobotBase

LIBRARY = Path(__file__).resolve().parent / "robots"


@dataclass(frozen=True)
class LibraryRobot:
    """One library robot: its file's text, its maker's home configuration and its validated robot section."""

    name: str
    path: Path
    text: str
    home: tuple[float, ...]
    robot: RobotBase


def names() -> list[str]:
    """The library's robot names (file stems), sorted."""
    return sorted(path.stem for path in LIBRARY.glob("*.yaml"))


def library_robot(name: str) -> LibraryRobot:
    """The library robot called ``name`` (case and '-' vs '_' do not matter); a UserError naming the choices otherwise."""
    known = names()
    if not known:
        raise UserError(f"the robot library is not there ({LIBRARY}); reinstall armcal")
    key = name.strip().lower().replace("-", "_").replace(" ", "_")
    if key not in known:
        close = difflib.get_close_matches(key, known, n=1, cutoff=0.5)
        hint = f" Did you mean '{close[0]}'?" if close else ""
        raise UserError(f"no robot '{name}' in the library.{hint} The library has: {', '.join(known)}")
    path = LIBRARY / f"{key}.yaml"
    text = path.read_text(encoding="utf-8")
    data = parse_yaml(text, path).data
    try:
        robot = TypeAdapter(Robot).validate_python(data["robot"], context=validation_context(data))
    except ValidationError as exc:  # a shipped file is checked by the tests; this is armcal's bug
        raise RuntimeError(f"{path}: the library's robot section is not valid:\n{exc}") from None
    return LibraryRobot(key, path, text, tuple(float(v) for v in data["home"]), robot)
