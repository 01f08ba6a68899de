"""Shared fixtures: paths of the shipped specs and compiled reference robots.

The tests mirror armcal's tree (tests/identify/ tests armcal/identify/...); the tests of the whole
tool (CLI, pipeline, documentation, safety) stay here. A test may take its cases from a test of
another folder by module name: every folder is on the import path.
"""

import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import armcal  # noqa: F401 - before numpy, as the CLI: its one-thread BLAS settings hold here as in the workers it spawns
import numpy as np
import pytest

from typer.testing import CliRunner

from armcal.cli import app
from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"
SPECS = ROOT / "specs"
sys.path.extend(str(folder) for folder in sorted(TESTS.iterdir()) if folder.is_dir() and any(folder.glob("test_*.py")))
SHARED_DATA = ROOT.parent / "shared" / "data"


EXAMPLE_DATA = ("spec.yaml", "calibration.csv", "validation.csv")


def copy_example(name: str, folder: Path, files: tuple[str, ...] = EXAMPLE_DATA) -> Path:
    """The files of examples/<name> among ``files`` copied into ``folder`` (tests never write into the repository)."""
    for file in files:
        if (ROOT / "examples" / name / file).exists():
            shutil.copy(ROOT / "examples" / name / file, Path(folder) / file)
    return Path(folder)


def armcal_process(*args, cwd: Path = ROOT, timeout: float = 300, env: dict | None = None) -> subprocess.CompletedProcess:
    """`python -m armcal ARGS` in a process of its own from ``cwd``, output captured: for what only a process
    shows (its own environment, a hang cut by ``timeout``, a first import)."""
    return subprocess.run([sys.executable, "-m", "armcal", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=timeout, env=env)


# Python's own filters for a script (python -W default shows the rest): what `python -m armcal` prints
IGNORED_WARNINGS = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


def armcal_cli(*args, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """`armcal ARGS` as `python -m armcal ARGS` runs it from ``cwd`` (the project's folder), in this process: exit code,
    stdout and stderr (Python's warnings printed there too); an exception the CLI lets escape fails the test.
    The working folder and the environment are restored after (the CLI sets ARMCAL_COMPILE).
    ARMCAL_TEST_PROCESS=1 runs each in a process of its own instead (docs/development.md)."""
    if os.environ.get("ARMCAL_TEST_PROCESS"):
        return armcal_process(*args, cwd=cwd)
    folder, environment = os.getcwd(), dict(os.environ)
    os.chdir(cwd)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            for category in IGNORED_WARNINGS:
                warnings.simplefilter("ignore", category)
            result = CliRunner().invoke(app, [str(arg) for arg in args], catch_exceptions=False, prog_name="armcal")
    finally:
        os.chdir(folder)
        os.environ.clear()
        os.environ.update(environment)
    shown = "".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno) for w in caught)
    return subprocess.CompletedProcess(["armcal", *map(str, args)], result.exit_code, result.stdout, result.stderr + shown)


def shipped_specs() -> list[Path]:
    return sorted([*SPECS.glob("*.yaml"), *(ROOT / "examples").glob("*/spec.yaml")])


@pytest.fixture(scope="session")
def puma_models():
    """The PUMA 560 of Table 6-2 compiled in the three conventions."""
    return {name: compile_robot(load_spec(SPECS / f"{name}.yaml").spec.robot.chain()) for name in ("puma560_dh", "puma560_smodel", "puma560_six")}


def random_configurations(model, count: int, seed: int = 0) -> np.ndarray:
    """Joint configurations uniformly within the joint limits."""
    return np.random.default_rng(seed).uniform(model.limits[:, 0], model.limits[:, 1], (count, model.dof))
