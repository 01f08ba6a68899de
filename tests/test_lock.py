"""requirements.lock (what tasks.sh installs) agrees with pyproject.toml's ranges, is closed under the locked
packages' own requirements, and is what this environment holds (issue 28: one environment on every machine)."""

from __future__ import annotations

import tomllib
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]


def _locked() -> dict[str, tuple[Version, Requirement]]:
    pins = {}
    for line in (ROOT / "requirements.lock").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            requirement = Requirement(line)
            (specifier,) = requirement.specifier
            assert specifier.operator == "==", line
            pins[canonicalize_name(requirement.name)] = (Version(specifier.version), requirement)
    return pins


def _project_requirements() -> list[Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    return [Requirement(text) for text in project["dependencies"] + [r for group in extras.values() for r in group]]


def test_every_dependency_of_the_project_is_locked_within_its_range():
    locked = _locked()
    for requirement in _project_requirements():
        name = canonicalize_name(requirement.name)
        assert name in locked, f"{requirement.name} is in pyproject.toml but not in requirements.lock"
        version = locked[name][0]
        assert requirement.specifier.contains(version, prereleases=True), f"{name}=={version} is outside pyproject.toml's {requirement}"


def test_the_lock_is_closed_under_its_packages_requirements():
    """Each locked package's requirements (on this machine, without extras) are locked too, at a version they admit."""
    locked = _locked()
    for name, (_, pin) in locked.items():
        if pin.marker is not None and not pin.marker.evaluate():
            continue
        for text in distribution(name).requires or []:
            requirement = Requirement(text)
            if requirement.marker is not None and not requirement.marker.evaluate({"extra": ""}):
                continue
            needed = canonicalize_name(requirement.name)
            assert needed in locked, f"{name} requires {requirement}, which requirements.lock does not pin"
            assert requirement.specifier.contains(locked[needed][0], prereleases=True), f"{name} requires {requirement}"


def test_this_environment_holds_exactly_the_locked_versions():
    for name, (version, pin) in _locked().items():
        if pin.marker is not None and not pin.marker.evaluate():
            continue
        try:
            installed = Version(distribution(name).version)
        except PackageNotFoundError:
            raise AssertionError(f"{name} is locked but not installed: run bash tasks.sh setup") from None
        assert installed == version, f"{name} {installed} installed, {version} locked: run bash tasks.sh setup"
