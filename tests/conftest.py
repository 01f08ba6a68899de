"""Shared fixtures: paths of the shipped specs and compiled reference robots."""

from pathlib import Path

import numpy as np
import pytest

from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
SPECS = ROOT / "specs"
SHARED_DATA = ROOT.parent / "shared" / "data"


def shipped_specs() -> list[Path]:
    return sorted([*SPECS.glob("*.yaml"), *(ROOT / "examples").glob("*/spec.yaml")])


@pytest.fixture(scope="session")
def puma_models():
    """The PUMA 560 of Table 6-2 compiled in the three conventions."""
    return {name: compile_robot(load_spec(SPECS / f"{name}.yaml").spec.robot) for name in ("puma560_dh", "puma560_smodel", "puma560_six")}


def random_configurations(model, count: int, seed: int = 0) -> np.ndarray:
    """Joint configurations uniformly within the joint limits."""
    return np.random.default_rng(seed).uniform(model.limits[:, 0], model.limits[:, 1], (count, model.dof))
